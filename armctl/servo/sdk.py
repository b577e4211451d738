"""Thin adapters over the vendor SDKs: every packet armctl sends goes through them.

``dynamixel_sdk`` (Protocol 2.0) and ``scservo_sdk`` (feetech-servo-sdk) share a port-handler
design. armctl subclasses their ``PortHandler`` to fix what users suffer from
(``docs/bus.md``): input is flushed before every transmit (SDK-FT 1.0.0 and SDK-DXL 3.8.4 only
``flush()`` output, so a late reply would be read as the next answer), the reply timeout uses a
configurable adapter latency instead of the fixed 16 ms, waiting for bytes sleeps in ``select``
instead of spinning a core, and the port is opened exclusively (``flock``, and ``TIOCEXCL`` on
a real serial device) so that no second program talks on the same bus.

The adapters expose one small, uniform surface (send a request, receive one status packet as
``(id, error, data)``, SDK result codes) that :class:`armctl.servo.driver.ServoBus` builds its
contract on; the driver matches every status packet to its request.
"""

from __future__ import annotations

import contextlib
import inspect
import os
import select
from abc import ABC, abstractmethod
from typing import Any

__all__ = ["IO_ERRORS", "Dxl1Sdk", "DxlSdk", "FeetechSdk", "Sdk", "Status"]

#: ``(servo id, error byte, data bytes)`` of one status packet.
Status = tuple[int, int, list[int]]


def _io_errors() -> tuple[type[BaseException], ...]:
    try:
        import termios
    except ImportError:  # not POSIX
        return (OSError,)
    return (OSError, termios.error)


#: What pyserial raises for a failed read, write, flush or ioctl on an open port
#: (``SerialException`` is an ``OSError``; ``tcflush`` raises ``termios.error``).
IO_ERRORS = _io_errors()


def _is_pseudo_terminal(fd: int) -> bool:
    """Whether ``fd`` is the slave side of a pseudo-terminal (Linux: majors 136-143)."""
    try:
        return 136 <= os.major(os.fstat(fd).st_rdev) <= 143
    except (OSError, AttributeError):
        return False


def _exclusive(fd: int, on: bool) -> None:
    """Set or clear the terminal's exclusive mode (further opens fail with EBUSY).

    Not on pseudo-terminals: the simulator keeps its pty's slave side open, so the mode would
    outlive a client that was killed.
    """
    try:
        import termios
    except ImportError:
        return
    request = getattr(termios, "TIOCEXCL" if on else "TIOCNXCL", None)
    if request is None or _is_pseudo_terminal(fd):
        return
    with contextlib.suppress(OSError):
        import fcntl

        fcntl.ioctl(fd, request)


def _port_class(base: type) -> type:
    class Port(base):
        latency_ms = 16.0
        is_open: bool

        def setupPort(self, cflag_baud: int) -> bool:
            """Open the port as the SDK does, but exclusively (pyserial ``flock``)."""
            import serial

            if self.is_open:
                self.closePort()
            self.ser = serial.Serial(port=self.port_name, baudrate=self.baudrate,
                                     bytesize=serial.EIGHTBITS, timeout=0, exclusive=True)
            self.is_open = True
            _exclusive(self.ser.fileno(), True)
            self.ser.reset_input_buffer()
            self.tx_time_per_byte = (1000.0 / self.baudrate) * 10.0
            return True

        def closePort(self) -> None:
            with contextlib.suppress(*IO_ERRORS, ValueError):
                _exclusive(self.ser.fileno(), False)
            with contextlib.suppress(*IO_ERRORS):
                self.ser.close()
            self.is_open = False

        def clearPort(self) -> None:
            self.ser.reset_input_buffer()

        def setPacketTimeout(self, packet_length: int) -> None:
            self.packet_start_time = self.getCurrentTime()
            self.packet_timeout = (self.tx_time_per_byte * packet_length
                                   + 2.0 * self.latency_ms + 2.0)

        def readPort(self, length: int) -> Any:
            data = self.ser.read(length)
            if not data:
                try:
                    select.select([self.ser.fileno()], [], [], 0.0005)
                except (OSError, ValueError, AttributeError):
                    pass
            return data

    return Port


class Sdk(ABC):
    """The SDK calls armctl needs, with result codes left to the caller.

    A transaction is a ``send_*`` call (which also starts the reply timeout) followed by
    :meth:`receive` calls, one status packet each, until the caller has matched its replies.
    """

    SUCCESS = 0
    TIMEOUT = 0
    CORRUPT = 0
    feetech = False
    has_sync_read = True
    has_reboot = True
    #: Data bytes in a ping's status packet.
    ping_size = 0
    #: Bytes of a status packet around its data (header, id, length, error, checksum).
    status_overhead = 6

    def __init__(self, port_name: str, latency_ms: float):
        self.port: Any = self._port_cls(port_name)
        self.port.latency_ms = latency_ms
        self.pk: Any = None

    _port_cls: Any

    def open(self, baudrate: int) -> bool:
        """Open the port at ``baudrate``; False if the SDK refuses the rate."""
        self.port.baudrate = baudrate
        return bool(self.port.setBaudRate(baudrate))

    def close(self) -> None:
        """Close the port (never raises for a port that is already gone)."""
        if self.port.ser is not None and self.port.is_open:
            self.port.closePort()

    def fileno(self) -> int | None:
        """The port's file descriptor, when it has one."""
        try:
            return int(self.port.ser.fileno())
        except (AttributeError, OSError, ValueError):
            return None

    def flush_input(self) -> None:
        """Discard unread input."""
        self.port.ser.reset_input_buffer()
        self.port.is_using = False

    def waiting(self) -> int:
        """Bytes waiting in the input."""
        return int(self.port.ser.in_waiting)

    def drain(self) -> list[Status]:
        """Read the complete status packets already waiting.

        The rest of the input is left to the flush that every transmit does (``clearPort``).

        Returns:
            The packets that were waiting (late replies of earlier requests).
        """
        out: list[Status] = []
        while self.waiting():
            self.port.setPacketTimeoutMillis(0)  # take only what has arrived
            rx, result = self.receive()
            if result != self.SUCCESS:
                break
            out.append(self.status(rx))
        self.port.is_using = False
        return out

    @abstractmethod
    def result_text(self, result: int) -> str:
        """The SDK's text for a result code."""

    @abstractmethod
    def receive(self) -> tuple[list[int], int]:
        """``(packet, result)``: the next status packet, within the request's timeout."""

    @abstractmethod
    def status(self, rx: list[int]) -> Status:
        """``(id, error, data)`` of a received status packet."""

    def send_read(self, sid: int, addr: int, n: int) -> int:
        """Send a READ of ``n`` bytes at ``addr``; returns the result code."""
        return int(self.pk.readTx(self.port, sid, addr, n))

    def send_write(self, sid: int, addr: int, data: bytes) -> int:
        """Send a WRITE (its status packet is then received like any other)."""
        result = int(self.pk.writeTxOnly(self.port, sid, addr, len(data), list(data)))
        self.port.setPacketTimeout(self.status_overhead)
        return result

    @abstractmethod
    def send_ping(self, sid: int) -> int:
        """Send a PING to one servo."""

    @abstractmethod
    def send_reboot(self, sid: int) -> int:
        """Send a REBOOT to one servo."""

    @abstractmethod
    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Send a SYNC READ; returns the result code."""

    def sync_write(self, addr: int, n: int, items: dict[int, bytes]) -> int:
        """Send a SYNC WRITE (no reply); returns the result code."""
        group = self._sync_write_cls(self.port, self.pk, addr, n)
        for sid, data in items.items():
            group.addParam(sid, list(data))
        return int(group.txPacket())

    _sync_write_cls: Any

    @abstractmethod
    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """``({id: (model or 0 when unknown, firmware)}, result)`` of a broadcast ping."""

    def _send_packet(self, txpacket: list[int], reply_size: int) -> int:
        result = int(self.pk.txPacket(self.port, txpacket))
        self.port.setPacketTimeout(self.status_overhead + reply_size)
        self.port.is_using = False
        return result


class DxlSdk(Sdk):
    """Dynamixel Protocol 2.0 through ``dynamixel_sdk``."""

    ping_size = 3  # model number (2), firmware (1)
    status_overhead = 11

    def __init__(self, port_name: str, latency_ms: float):
        import dynamixel_sdk as dxl

        self._dxl = dxl
        self._port_cls = _port_class(dxl.PortHandler)
        self._sync_write_cls = dxl.GroupSyncWrite
        super().__init__(port_name, latency_ms)
        self.pk = dxl.PacketHandler(2.0)
        self.SUCCESS, self.TIMEOUT, self.CORRUPT = (dxl.COMM_SUCCESS, dxl.COMM_RX_TIMEOUT,
                                                    dxl.COMM_RX_CORRUPT)
        self._fast_arg = "fast_option" in inspect.signature(self.pk.syncReadTx).parameters
        self._rx_arg = "fast_option" in inspect.signature(self.pk.rxPacket).parameters

    def result_text(self, result: int) -> str:
        """The SDK's text for a result code."""
        return str(self.pk.getTxRxResult(result))

    def receive(self) -> tuple[list[int], int]:
        """The next status packet (byte stuffing removed)."""
        if self._rx_arg:
            rx, result = self.pk.rxPacket(self.port, False)
        else:
            rx, result = self.pk.rxPacket(self.port)
        return rx, int(result)

    def status(self, rx: list[int]) -> Status:
        """``(id, error, data)``: LEN counts INST, ERR, the data and the CRC."""
        n = max(0, (rx[5] | rx[6] << 8) - 4)
        return rx[4], rx[8], list(rx[9:9 + n])

    def send_ping(self, sid: int) -> int:
        """PING (the status carries the model number and firmware)."""
        txpacket = [0] * 10
        txpacket[4], txpacket[5], txpacket[7] = sid, 3, 1
        return self._send_packet(txpacket, self.ping_size)

    def send_reboot(self, sid: int) -> int:
        """REBOOT (0x08)."""
        txpacket = [0] * 10
        txpacket[4], txpacket[5], txpacket[7] = sid, 3, 0x08
        return self._send_packet(txpacket, 0)

    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Send a SYNC READ."""
        if self._fast_arg:
            return int(self.pk.syncReadTx(self.port, addr, n, ids, len(ids), False))
        return int(self.pk.syncReadTx(self.port, addr, n, ids, len(ids)))

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Broadcast ping through the SDK (it waits its own fixed window)."""
        found, result = self.pk.broadcastPing(self.port)
        return {int(k): (int(v[0]), int(v[1])) for k, v in found.items()}, result


class Dxl1Sdk(DxlSdk):
    """Dynamixel Protocol 1.0 through ``dynamixel_sdk``: no Sync Read, Reboot or broadcast ping."""

    has_sync_read = False
    has_reboot = False
    ping_size = 0
    status_overhead = 6

    def __init__(self, port_name: str, latency_ms: float):
        super().__init__(port_name, latency_ms)
        self.pk = self._dxl.PacketHandler(1.0)
        self._fast_arg = False
        self._rx_arg = "fast_option" in inspect.signature(self.pk.rxPacket).parameters

    def status(self, rx: list[int]) -> Status:
        """``(id, error, data)``: LEN counts ERR, the data and the checksum."""
        return _short_status(rx)

    def send_ping(self, sid: int) -> int:
        """PING (an empty status; the model number is read separately)."""
        return self._send_packet([0, 0, sid, 2, 1, 0], 0)

    def send_reboot(self, sid: int) -> int:
        """Not in Protocol 1.0."""
        return int(self._dxl.COMM_NOT_AVAILABLE)

    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Not in Protocol 1.0."""
        return int(self._dxl.COMM_NOT_AVAILABLE)

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Not in Protocol 1.0 (scan pings ids one by one)."""
        return {}, int(self._dxl.COMM_NOT_AVAILABLE)


def _short_status(rx: list[int]) -> Status:
    """``(id, error, data)`` of a Protocol 1.0-style status packet (Feetech, Dynamixel 1.0)."""
    n = max(0, rx[3] - 2)
    return rx[2], rx[4], list(rx[5:5 + n])


class FeetechSdk(Sdk):
    """Feetech STS (little-endian) through ``scservo_sdk`` (feetech-servo-sdk)."""

    feetech = True

    def __init__(self, port_name: str, latency_ms: float):
        import scservo_sdk as scs

        self._scs = scs
        self._port_cls = _port_class(scs.PortHandler)
        self._sync_write_cls = scs.GroupSyncWrite
        super().__init__(port_name, latency_ms)
        self.pk = scs.PacketHandler(0)  # 0 = little-endian (STS/SMS); a process-wide setting
        self.SUCCESS, self.TIMEOUT, self.CORRUPT = (scs.COMM_SUCCESS, scs.COMM_RX_TIMEOUT,
                                                    scs.COMM_RX_CORRUPT)

    def result_text(self, result: int) -> str:
        """The SDK's text for a result code."""
        return str(self.pk.getTxRxResult(result))

    def receive(self) -> tuple[list[int], int]:
        """The next status packet."""
        rx, result = self.pk.rxPacket(self.port)
        return rx, int(result)

    def status(self, rx: list[int]) -> Status:
        """``(id, error, data)``: LEN counts ERR, the data and the checksum."""
        return _short_status(rx)

    def send_ping(self, sid: int) -> int:
        """PING (an empty status; the model number is read separately)."""
        return self._send_packet([0, 0, sid, 2, 1, 0], 0)

    def send_reboot(self, sid: int) -> int:
        """REBOOT (0x08, official INST.h); SDK-FT 1.0.0 has no helper, so build the packet."""
        return self._send_packet([0, 0, sid, 2, 0x08, 0], 0)

    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Send a SYNC READ."""
        return int(self.pk.syncReadTx(self.port, addr, n, ids, len(ids)))

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Broadcast ping: STS servos answer one after another; collect until the window ends.

        The model numbers are left 0: the caller reads them with matched reads.
        """
        result = self.pk.txPacket(self.port, [0, 0, 0xFE, 2, 1, 0])
        found: dict[int, tuple[int, int | None]] = {}
        if result != self.SUCCESS:
            self.port.is_using = False
            return found, result
        self.port.setPacketTimeoutMillis(window_ms)
        while True:
            rx, res = self.pk.rxPacket(self.port)
            if res != self.SUCCESS:
                break
            found[int(rx[2])] = (0, None)
            self.port.setPacketTimeoutMillis(window_ms)
        self.port.is_using = False
        return found, self.SUCCESS
