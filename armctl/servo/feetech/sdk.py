"""Adapter over ``scservo_sdk`` (feetech-servo-sdk, SDK-FT 1.0.0) for STS servos.

The status packet's error byte is a bit field of live alarms (SDK-FT ``ERRBIT_*``); a servo
never refuses with it (it stays silent on a bad request) and still returns the data.
"""

from __future__ import annotations

import functools
from typing import Any

from armctl.servo.port import port_class
from armctl.servo.sdk import Sdk, Status, protocol1_seal, short_status
from armctl.servo_tables import Alarm, alarms_from_bits

__all__ = ["FeetechSdk"]

_BROADCAST_PING = [0, 0, 0xFE, 2, 1, 0]


@functools.cache
def _alarms(bits: int) -> tuple[Alarm, ...]:
    return alarms_from_bits(bits, True)


class FeetechSdk(Sdk):
    """Feetech STS (little-endian) through ``scservo_sdk`` (feetech-servo-sdk)."""

    sync_ids_at = 7  # header (2), ID, LEN, INST, start address, data length

    def __init__(self, port_name: str, latency_ms: float):
        import scservo_sdk as scs

        self._scs = scs
        self._port_cls = port_class(scs.PortHandler)
        self._sync_write_cls = scs.GroupSyncWrite
        super().__init__(port_name, latency_ms)
        self.pk = scs.PacketHandler(0)  # 0 = little-endian (STS/SMS); a process-wide setting
        self.SUCCESS, self.TIMEOUT, self.CORRUPT = (scs.COMM_SUCCESS, scs.COMM_RX_TIMEOUT,
                                                    scs.COMM_RX_CORRUPT)
        self.PORT_BUSY, self.TX_FAIL, self.NOT_AVAILABLE = (
            scs.COMM_PORT_BUSY, scs.COMM_TX_FAIL, scs.COMM_NOT_AVAILABLE)

    @classmethod
    def refusal(cls, error: int) -> tuple[str, bool] | None:
        """Never: the byte holds alarms only."""
        return None

    @classmethod
    def alarms_in(cls, error: int) -> tuple[Alarm, ...] | None:
        """The alarm bits."""
        return _alarms(error & 0xFF)

    def result_text(self, result: int) -> str:
        """The SDK's text for a result code."""
        return str(self.pk.getTxRxResult(result))

    def receive(self) -> tuple[list[int], int]:
        """The next status packet."""
        rx, result = self.pk.rxPacket(self.port)
        return rx, int(result)

    def status(self, rx: list[int]) -> Status:
        """``(id, error, data)``: LEN counts ERR, the data and the checksum."""
        return short_status(rx)

    def send_ping(self, sid: int) -> int:
        """PING (an empty status; the model number is read separately)."""
        return self._send_packet([0, 0, sid, 2, 1, 0], 0)

    def send_reboot(self, sid: int) -> int:
        """REBOOT (0x08, official INST.h); SDK-FT 1.0.0 has no helper, so build the packet."""
        return self._send_packet([0, 0, sid, 2, 0x08, 0], 0)

    def _sync_read_tx(self, port: Any, addr: int, n: int, ids: list[int]) -> int:
        return int(self.pk.syncReadTx(port, addr, n, ids, len(ids)))

    def _seal(self, packet: bytearray) -> bool:
        return protocol1_seal(packet)

    def broadcast_ping(self, window_ms: float) -> tuple[dict[int, tuple[int, int | None]], int]:
        """Broadcast ping: STS servos answer one after another; collect until the window ends.

        The model numbers are left 0: the caller reads them with matched reads.
        """
        result = self.pk.txPacket(self.port, list(_BROADCAST_PING))
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
