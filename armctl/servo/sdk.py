"""Thin adapters over the vendor SDKs: every packet armctl sends goes through them.

``dynamixel_sdk`` (Protocol 2.0) and ``scservo_sdk`` (feetech-servo-sdk) share a port-handler
design. armctl subclasses their ``PortHandler`` to fix what users suffer from
(``docs/bus.md``): input is flushed before every transmit (SDK-FT 1.0.0 and SDK-DXL 3.8.4 only
``flush()`` output, so a late reply would be read as the next answer), the reply timeout uses a
configurable adapter latency instead of the fixed 16 ms, waiting for bytes sleeps in ``select``
instead of spinning a core, and the port is locked against a second program.

The adapters expose one small, uniform surface (bytes in, bytes out, SDK result codes) that
:class:`armctl.servo.driver.ServoBus` builds its contract on.
"""

from __future__ import annotations

import inspect
import select
from abc import ABC, abstractmethod
from typing import Any

__all__ = ["Dxl1Sdk", "DxlSdk", "FeetechSdk", "Sdk"]


def _port_class(base: type) -> type:
    class Port(base):
        latency_ms = 16.0

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
    """The SDK calls armctl needs, with result codes left to the caller."""

    SUCCESS = 0
    TIMEOUT = 0
    CORRUPT = 0
    feetech = False
    has_sync_read = True
    has_reboot = True

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
        """Close the port."""
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

    @abstractmethod
    def result_text(self, result: int) -> str:
        """The SDK's text for a result code."""

    @abstractmethod
    def ping(self, sid: int) -> tuple[int, int | None, int, int]:
        """``(model_number, firmware or None, result, error)``."""

    def read(self, sid: int, addr: int, n: int) -> tuple[list[int], int, int]:
        """``(data, result, error)`` of a READ."""
        data, result, error = self.pk.readTxRx(self.port, sid, addr, n)
        return list(data or []), result, error

    def write(self, sid: int, addr: int, data: bytes) -> tuple[int, int]:
        """``(result, error)`` of a WRITE."""
        result, error = self.pk.writeTxRx(self.port, sid, addr, len(data), list(data))
        return int(result), int(error)

    @abstractmethod
    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Send a SYNC READ; returns the result code."""

    def read_rx(self, sid: int, n: int) -> tuple[list[int], int, int]:
        """``(data, result, error)`` of one status packet of a group read."""
        data, result, error = self.pk.readRx(self.port, sid, n)
        return list(data or []), result, error

    def sync_write(self, addr: int, n: int, items: dict[int, bytes]) -> int:
        """Send a SYNC WRITE (no reply); returns the result code."""
        group = self._sync_write_cls(self.port, self.pk, addr, n)
        for sid, data in items.items():
            group.addParam(sid, list(data))
        return int(group.txPacket())

    _sync_write_cls: Any

    @abstractmethod
    def reboot(self, sid: int) -> tuple[int, int]:
        """``(result, error)`` of a REBOOT."""

    @abstractmethod
    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """``({id: (model, firmware)}, result)`` of a broadcast ping."""


class DxlSdk(Sdk):
    """Dynamixel Protocol 2.0 through ``dynamixel_sdk``."""

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

    def result_text(self, result: int) -> str:
        """The SDK's text for a result code."""
        return str(self.pk.getTxRxResult(result))

    def ping(self, sid: int) -> tuple[int, int | None, int, int]:
        """``(model_number, firmware, result, error)``: the ping status carries both."""
        txpacket = [0] * 10
        txpacket[4], txpacket[5], txpacket[7] = sid, 3, 1
        rx, result, error = self.pk.txRxPacket(self.port, txpacket)
        if result != self.SUCCESS or rx is None or len(rx) < 14:
            return 0, None, result, error
        return rx[9] | (rx[10] << 8), rx[11], result, error

    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Send a SYNC READ."""
        if self._fast_arg:
            return int(self.pk.syncReadTx(self.port, addr, n, ids, len(ids), False))
        return int(self.pk.syncReadTx(self.port, addr, n, ids, len(ids)))

    def reboot(self, sid: int) -> tuple[int, int]:
        """Reboot a servo."""
        result, error = self.pk.reboot(self.port, sid)
        return result, error

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Broadcast ping through the SDK (it waits its own fixed window)."""
        found, result = self.pk.broadcastPing(self.port)
        return {int(k): (int(v[0]), int(v[1])) for k, v in found.items()}, result


class Dxl1Sdk(DxlSdk):
    """Dynamixel Protocol 1.0 through ``dynamixel_sdk``: no Sync Read, Reboot or broadcast ping."""

    has_sync_read = False
    has_reboot = False

    def __init__(self, port_name: str, latency_ms: float):
        super().__init__(port_name, latency_ms)
        self.pk = self._dxl.PacketHandler(1.0)
        self._fast_arg = False

    def ping(self, sid: int) -> tuple[int, int | None, int, int]:
        """``(model_number, None, result, error)``: a ping, then a read of the model number."""
        model, result, error = self.pk.ping(self.port, sid)
        return int(model), None, result, error

    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Not in Protocol 1.0."""
        return int(self._dxl.COMM_NOT_AVAILABLE)

    def reboot(self, sid: int) -> tuple[int, int]:
        """Not in Protocol 1.0."""
        return int(self._dxl.COMM_NOT_AVAILABLE), 0

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Not in Protocol 1.0 (scan pings ids one by one)."""
        return {}, int(self._dxl.COMM_NOT_AVAILABLE)


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

    def ping(self, sid: int) -> tuple[int, int | None, int, int]:
        """``(model_number, None, result, error)``: SDK-FT pings, then reads the model number."""
        model, result, error = self.pk.ping(self.port, sid)
        return int(model), None, result, error

    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Send a SYNC READ."""
        return int(self.pk.syncReadTx(self.port, addr, n, ids, len(ids)))

    def reboot(self, sid: int) -> tuple[int, int]:
        """REBOOT (0x08, official INST.h); SDK-FT 1.0.0 has no helper, so build the packet."""
        _, result, error = self.pk.txRxPacket(self.port, [0, 0, sid, 2, 0x08, 0])
        return result, error

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Broadcast ping: STS servos answer one after another; collect until the window ends."""
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
        for sid in list(found):
            data, res, _ = self.read(sid, 3, 2)
            if res == self.SUCCESS and len(data) == 2:
                found[sid] = (data[0] | data[1] << 8, None)
        return found, self.SUCCESS
