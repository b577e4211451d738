"""The adapter contract over the vendor SDKs: every packet armctl sends is built by them.

Each servo family's package has its adapter in its ``sdk`` module (Dynamixel over
``dynamixel_sdk``, Feetech over ``scservo_sdk``); the port under both
is :mod:`armctl.servo.port` (exclusive, input flushed before every transmit, read ahead,
configurable adapter latency).

The adapters expose one small, uniform surface (send a request, receive one status packet as
``(id, error, data)``, SDK result codes, what a status packet's error byte means) that
:class:`armctl.servo.driver.ServoBus` builds its contract on; the driver matches every status
packet to its request.

Sync packets are built by the SDK once per address, length and servo ids and kept: a sync read
is then sent as is, a sync write gets its data bytes and checksum patched in (the SDK builds it
again whenever a patch is not enough, e.g. for Dynamixel byte stuffing). The packets are the
SDK's own, byte for byte.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from armctl.servo.codec import sum_checksum
from armctl.servo.port import IO_ERRORS
from armctl.servo_tables import Alarm

__all__ = ["IO_ERRORS", "Sdk", "Status", "SyncTemplate"]

#: ``(servo id, error byte, data bytes)`` of one status packet.
Status = tuple[int, int, list[int]]

#: Kept sync packets per adapter (address, length and ids); more are built again each time.
_KEEP = 64


class _Recorder:
    """Stands in for the port while an SDK builder runs, and keeps the packet it writes."""

    is_using = False
    tx_time_per_byte = 0.01

    def __init__(self) -> None:
        self.packet = b""

    def clearPort(self) -> None:
        """Nothing to clear."""

    def writePort(self, packet: list[int]) -> int:
        """Keep the packet instead of sending it."""
        self.packet = bytes(packet)
        return len(packet)

    def setPacketTimeout(self, packet_length: int) -> None:
        """No reply is awaited."""

    def setPacketTimeoutMillis(self, msec: float) -> None:
        """No reply is awaited."""


def built_by_sdk(build: Callable[[Any], Any]) -> tuple[bytes, int]:
    """The packet an SDK builder writes, without sending it.

    Args:
        build: Calls the SDK with the port it is given (e.g. ``lambda port:
            pk.syncReadTx(port, ...)``) and returns the SDK's result code.

    Returns:
        The packet's bytes (empty if the SDK refused to build it) and the result code.
    """
    recorder = _Recorder()
    result = build(recorder)
    return recorder.packet, int(result)


@dataclass(frozen=True)
class SyncTemplate:
    """A sync write packet as the SDK builds it with zero data, and where each servo's data goes.

    Attributes:
        packet: The packet's bytes.
        offsets: Index of each servo's first data byte, in the order of the ids.
    """

    packet: bytes
    offsets: tuple[int, ...]


class Sdk(ABC):
    """The SDK calls armctl needs, with result codes left to the caller.

    A transaction is a ``send_*`` call (which also starts the reply timeout) followed by
    :meth:`receive` calls, one status packet each, until the caller has matched its replies.
    The class attributes describe the protocol; the error-byte methods are class methods, so
    the driver can ask them before the port is open.
    """

    SUCCESS = 0
    TIMEOUT = 0
    CORRUPT = 0
    PORT_BUSY = 0
    TX_FAIL = 0
    NOT_AVAILABLE = 0
    has_sync_read = True
    has_reboot = True
    has_broadcast_ping = True
    #: Whether an access-type refusal is an access error (Dynamixel 2.0 error 7) rather than
    #: another rejection.
    access_errors = False
    #: Data bytes in a ping's status packet.
    ping_size = 0
    #: Bytes of a status packet around its data (header, id, length, error, checksum).
    status_overhead = 6
    #: Index of the first servo id in a sync packet's parameters.
    sync_ids_at = 7

    _port_cls: Any
    _sync_write_cls: Any

    def __init__(self, port_name: str, latency_ms: float):
        self.port: Any = self._port_cls(port_name)
        self.port.latency_ms = latency_ms
        self.pk: Any = None
        self._sync_reads: dict[tuple[int, int, tuple[int, ...]], bytes] = {}
        self._sync_writes: dict[tuple[int, int, tuple[int, ...]], SyncTemplate | None] = {}

    # ---- the error byte (per protocol) --------------------------------------------------------
    @classmethod
    @abstractmethod
    def refusal(cls, error: int) -> tuple[str, bool] | None:
        """What the servo refused, if anything.

        Returns:
            ``None``, or ``(text, access)`` where ``access`` marks an access-type refusal.
        """

    @classmethod
    @abstractmethod
    def alarms_in(cls, error: int) -> tuple[Alarm, ...] | None:
        """The hardware alarms an error byte reports.

        Returns:
            The alarms (empty when none), or ``None`` when the byte only says that there is
            one (its cause must be read from the servo's alarm register).
        """

    # ---- the port -----------------------------------------------------------------------------
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
        self.port.clearPort()
        self.port.is_using = False

    def waiting(self) -> int:
        """Bytes waiting in the input."""
        return int(self.port.unread()) + int(self.port.ser.in_waiting)

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

    # ---- requests -----------------------------------------------------------------------------
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
    def _sync_read_tx(self, port: Any, addr: int, n: int, ids: list[int]) -> int:
        """Let the SDK build and send a SYNC READ on ``port``."""

    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Send a SYNC READ (the SDK's packet, built once per address, length and ids).

        Returns:
            The result code.
        """
        key = (addr, n, tuple(ids))
        packet = self._sync_reads.get(key)
        if packet is None:
            packet, built = built_by_sdk(
                lambda port: self._sync_read_tx(port, addr, n, list(ids)))
            if not packet:  # the SDK refused to build it (e.g. too long)
                return built
            if len(self._sync_reads) >= _KEEP:
                self._sync_reads.clear()
            self._sync_reads[key] = packet
        result = self._transmit(packet)
        if result == self.SUCCESS:  # the replies' timeout, as the SDK sets it
            self.port.setPacketTimeout((self.status_overhead + n) * len(ids))
        return result

    def sync_write(self, addr: int, n: int, items: Mapping[int, bytes]) -> int:
        """Send a SYNC WRITE of ``n`` bytes at ``addr`` (no reply); returns the result code.

        The SDK's packet for these ids is kept with zero data; each call patches the data and
        the checksum in, or has the SDK build the packet when that is not enough.
        """
        ids = tuple(items)
        key = (addr, n, ids)
        if key in self._sync_writes:
            template = self._sync_writes[key]
        else:
            template = self._sync_template(addr, n, ids)
            if len(self._sync_writes) >= _KEEP:
                self._sync_writes.clear()
            self._sync_writes[key] = template
        packet: bytes | bytearray | None = None
        if template is not None:
            patched = bytearray(template.packet)
            for at, data in zip(template.offsets, items.values(), strict=True):
                if len(data) != n:
                    break
                patched[at:at + n] = data
            else:
                if self._seal(patched):
                    packet = patched
        if packet is None:
            packet, built = self._sdk_sync_write(addr, n, items)
            if not packet:  # the SDK refused to build it (no servos, too long)
                return built
        result = self._transmit(packet)
        if result == self.SUCCESS:
            self.port.is_using = False  # no reply: the port is free at once, as in the SDK
        return result

    def _sdk_sync_write(self, addr: int, n: int, items: Mapping[int, bytes]
                        ) -> tuple[bytes, int]:
        """The SYNC WRITE packet as the SDK's ``GroupSyncWrite`` builds it, and its result."""
        def build(port: Any) -> Any:
            group = self._sync_write_cls(port, self.pk, addr, n)
            for sid, data in items.items():
                group.addParam(sid, list(data))
            return group.txPacket()
        return built_by_sdk(build)

    def _sync_template(self, addr: int, n: int, ids: tuple[int, ...]) -> SyncTemplate | None:
        """The sync write packet with zero data, or ``None`` if it cannot be patched."""
        packet, _ = self._sdk_sync_write(addr, n, dict.fromkeys(ids, bytes(n)))
        offsets = tuple(self.sync_ids_at + k * (1 + n) + 1 for k in range(len(ids)))
        if not ids or len(packet) != offsets[-1] + n + self._check_size or any(
                packet[at - 1] != sid for at, sid in zip(offsets, ids, strict=True)):
            return None
        return SyncTemplate(packet, offsets)

    #: Bytes of the checksum at the end of a packet.
    _check_size = 1

    @abstractmethod
    def _seal(self, packet: bytearray) -> bool:
        """Write the checksum of a patched packet into it.

        Returns:
            False when the packet needs more than its checksum (then the SDK builds it).
        """

    def _transmit(self, packet: bytes | bytearray) -> int:
        """Send a packet as the SDK's ``txPacket`` does: the port must be free, input flushed.

        Leaves the port in use (a reply is awaited) on success.
        """
        port = self.port
        if port.is_using:
            return self.PORT_BUSY
        port.is_using = True
        port.clearPort()
        if port.writePort(packet) != len(packet):
            port.is_using = False
            return self.TX_FAIL
        return self.SUCCESS

    @abstractmethod
    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """``({id: (model or 0 when unknown, firmware)}, result)`` of a broadcast ping."""

    def _send_packet(self, txpacket: list[int], reply_size: int) -> int:
        result = int(self.pk.txPacket(self.port, txpacket))
        self.port.setPacketTimeout(self.status_overhead + reply_size)
        self.port.is_using = False
        return result


def short_status(rx: list[int]) -> Status:
    """``(id, error, data)`` of a Protocol 1.0-style status packet (Feetech, Dynamixel 1.0).

    LEN counts ERR, the data and the checksum.
    """
    n = max(0, rx[3] - 2)
    return rx[2], rx[4], list(rx[5:5 + n])


def protocol1_seal(packet: bytearray) -> bool:
    """Protocol 1.0-style checksum, ``~sum(ID..last param) & 0xFF``, into the last byte."""
    packet[-1] = sum_checksum(memoryview(packet)[2:-1])
    return True
