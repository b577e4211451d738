"""Adapters over ``dynamixel_sdk``: Protocol 2.0 and Protocol 1.0, and their error bytes.

The status packet's error byte (ROBOTIS e-Manual, Protocol 2.0 and Protocol 1.0 "Status
Packet"):

* Protocol 2.0: bits 0-6 are an error *number* (1 result fail ... 7 access error); bit 7 is the
  Alert bit, a latched hardware alarm whose cause is in Hardware Error Status (address 70).
* Protocol 1.0: a bit field; input voltage, overheating and overload are alarms, angle limit,
  range, checksum and instruction are refusals.
"""

from __future__ import annotations

import functools
import inspect
from typing import Any

from armctl.servo.codec import crc16
from armctl.servo.port import port_class
from armctl.servo.sdk import Sdk, Status, protocol1_seal, short_status
from armctl.servo_tables import Alarm, alarms_from_bits

__all__ = ["Dxl1Sdk", "DxlSdk"]

_DXL2_ERRORS = {1: "result fail", 2: "instruction error", 3: "CRC error",
                4: "data range error (value outside the register's range)",
                5: "data length error", 6: "data limit error (outside the position limits)",
                7: "access error"}
_DXL1_ERRORS = {0x02: "angle limit error", 0x08: "range error", 0x10: "checksum error",
                0x40: "instruction error"}
_DXL1_ALARMS = 0x25  # input voltage (0x01), overheating (0x04), overload (0x20)
_STUFFED = b"\xff\xff\xfd"  # a header inside a packet: Protocol 2.0 stuffs a 0xFD after it


@functools.cache
def _dxl1_alarms(bits: int) -> tuple[Alarm, ...]:
    # Protocol 1.0 puts the alarms at the bits of the Feetech status byte.
    return alarms_from_bits(bits, True)


class DxlSdk(Sdk):
    """Dynamixel Protocol 2.0 through ``dynamixel_sdk``."""

    access_errors = True
    ping_size = 3  # model number (2), firmware (1)
    status_overhead = 11
    sync_ids_at = 12  # header (4), ID, LEN (2), INST, start address (2), data length (2)
    _check_size = 2  # CRC-16

    def __init__(self, port_name: str, latency_ms: float):
        import dynamixel_sdk as dxl

        self._dxl = dxl
        self._port_cls = port_class(dxl.PortHandler)
        self._sync_write_cls = dxl.GroupSyncWrite
        super().__init__(port_name, latency_ms)
        self.pk = dxl.PacketHandler(2.0)
        self.SUCCESS, self.TIMEOUT, self.CORRUPT = (dxl.COMM_SUCCESS, dxl.COMM_RX_TIMEOUT,
                                                    dxl.COMM_RX_CORRUPT)
        self.PORT_BUSY, self.TX_FAIL, self.NOT_AVAILABLE = (
            dxl.COMM_PORT_BUSY, dxl.COMM_TX_FAIL, dxl.COMM_NOT_AVAILABLE)
        self._fast_arg = "fast_option" in inspect.signature(self.pk.syncReadTx).parameters
        self._rx_arg = "fast_option" in inspect.signature(self.pk.rxPacket).parameters

    @classmethod
    def refusal(cls, error: int) -> tuple[str, bool] | None:
        """The error number in bits 0-6, if any; number 7 is an access error."""
        num = error & 0x7F
        return (_DXL2_ERRORS.get(num, f"error {num}"), num == 7) if num else None

    @classmethod
    def alarms_in(cls, error: int) -> tuple[Alarm, ...] | None:
        """``None`` for the Alert bit (the cause is in Hardware Error Status), else none."""
        return None if error & 0x80 else ()

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

    def _sync_read_tx(self, port: Any, addr: int, n: int, ids: list[int]) -> int:
        if self._fast_arg:
            return int(self.pk.syncReadTx(port, addr, n, ids, len(ids), False))
        return int(self.pk.syncReadTx(port, addr, n, ids, len(ids)))

    def _seal(self, packet: bytearray) -> bool:
        """CRC-16 into the last two bytes; False if the data needs byte stuffing."""
        if _STUFFED in packet[7:-2]:  # from INST to the last parameter
            return False
        crc = crc16(memoryview(packet)[:-2])
        packet[-2], packet[-1] = crc & 0xFF, crc >> 8
        return True

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Broadcast ping through the SDK (it waits its own fixed window)."""
        found, result = self.pk.broadcastPing(self.port)
        return {int(k): (int(v[0]), int(v[1])) for k, v in found.items()}, result


class Dxl1Sdk(DxlSdk):
    """Dynamixel Protocol 1.0 through ``dynamixel_sdk``: no Sync Read, Reboot or broadcast ping."""

    has_sync_read = False
    has_reboot = False
    has_broadcast_ping = False
    access_errors = False
    ping_size = 0
    status_overhead = 6
    sync_ids_at = 7  # header (2), ID, LEN, INST, start address, data length
    _check_size = 1

    def __init__(self, port_name: str, latency_ms: float):
        super().__init__(port_name, latency_ms)
        self.pk = self._dxl.PacketHandler(1.0)
        self._fast_arg = False
        self._rx_arg = "fast_option" in inspect.signature(self.pk.rxPacket).parameters

    @classmethod
    def refusal(cls, error: int) -> tuple[str, bool] | None:
        """The refusal bits.

        A range error is access-type: armctl range-checks values before sending, so the
        register could not be written.
        """
        bits = error & ~_DXL1_ALARMS & 0x7F
        if not bits:
            return None
        text = ", ".join(t for b, t in _DXL1_ERRORS.items() if bits & b) or f"bits 0x{bits:02x}"
        return text, bool(bits & 0x08)

    @classmethod
    def alarms_in(cls, error: int) -> tuple[Alarm, ...] | None:
        """The alarm bits (input voltage, overheating, overload)."""
        return _dxl1_alarms(error & _DXL1_ALARMS)

    def status(self, rx: list[int]) -> Status:
        """``(id, error, data)``: LEN counts ERR, the data and the checksum."""
        return short_status(rx)

    def send_ping(self, sid: int) -> int:
        """PING (an empty status; the model number is read separately)."""
        return self._send_packet([0, 0, sid, 2, 1, 0], 0)

    def send_reboot(self, sid: int) -> int:
        """Not in Protocol 1.0."""
        return int(self._dxl.COMM_NOT_AVAILABLE)

    def sync_read_tx(self, addr: int, n: int, ids: list[int]) -> int:
        """Not in Protocol 1.0."""
        return int(self._dxl.COMM_NOT_AVAILABLE)

    def _seal(self, packet: bytearray) -> bool:
        return protocol1_seal(packet)

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Not in Protocol 1.0 (scan pings ids one by one)."""
        return {}, int(self._dxl.COMM_NOT_AVAILABLE)
