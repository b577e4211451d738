"""What simulated servos do with an instruction packet, and the status packets they answer.

Protocol rules (e-Manual Protocol 2.0; Feetech SCS/STS as implemented by ``scservo_sdk``):
broadcast gets replies only to Ping and Sync/Bulk Read; Sync/Bulk Read replies follow the order
of the instruction's id list; Status Return Level decides which instructions are answered (the
level before the instruction); a reply to an id change carries the old id; a Dynamixel read
outside the table is an access error without parameters; a Fast Sync Read is answered with one
combined packet.
"""

from __future__ import annotations

from armctl.servo.sim.servo import ERR_ACCESS, ERR_CRC, ERR_INSTRUCTION, SimServo
from armctl.servo.sim.wire import BROADCAST, DxlWire, FeetechWire, Instruction
from armctl.servo_tables import Register

__all__ = ["Dispatcher"]

PING, READ, WRITE, REG_WRITE, ACTION, FACTORY_RESET, REBOOT, CLEAR = 1, 2, 3, 4, 5, 6, 8, 0x10
SYNC_READ, SYNC_WRITE, FAST_SYNC_READ, BULK_READ, BULK_WRITE = 0x82, 0x83, 0x8A, 0x92, 0x93
Reply = tuple[SimServo | None, bytes]


# Dynamixel Protocol 1.0 status error bits (e-Manual Protocol 1.0 "Status Packet"), for the
# Protocol 2.0 error numbers the servos produce.
_P1_ERRORS = {ERR_INSTRUCTION: 0x40, ERR_CRC: 0x10}
_P1_RANGE = 0x08
_P1_ALARMS = 0x25  # input voltage, overheating, overload: the same bits as Hardware Error Status


class Dispatcher:
    """Carries out instructions on the simulated servos.

    Args:
        wire: The protocol's framing (builds the status packets).
        protocol1: Dynamixel servos speaking Protocol 1.0 (Feetech-style framing, an error
            bit field instead of error numbers, no Sync Read).
    """

    def __init__(self, wire: DxlWire | FeetechWire, protocol1: bool = False):
        self.wire = wire
        self.p1 = protocol1
        self._live: dict[int, SimServo] = {}

    def _error(self, servo: SimServo, number: int) -> int:
        """The status error byte for an error number of :mod:`.servo` (0 = none)."""
        if not self.p1:
            return number | servo.error_byte
        bits = _P1_ERRORS.get(number, _P1_RANGE) if number else 0
        return bits | (servo.get(Register.HARDWARE_ERROR) & _P1_ALARMS)

    def _listeners(self, sid: int) -> list[SimServo]:
        if sid == BROADCAST:
            return list(self._live.values())
        s = self._live.get(sid)
        return [] if s is None else [s]

    def _replies(self, servo: SimServo, inst: int) -> bool:
        level = servo.get(Register.STATUS_RETURN_LEVEL)
        if inst == PING:
            return True
        if servo.feetech:
            return level >= 1 or inst == READ
        return level >= 2 or (level == 1 and inst in (READ, SYNC_READ, BULK_READ))

    def handle(self, ins: Instruction, live: dict[int, SimServo]
               ) -> list[Reply]:
        """Act on one instruction.

        Args:
            ins: The instruction.
            live: The servos that hear it, by id (present on the bus, at the host's baud rate).

        Returns:
            ``(servo, status packet)`` in the order they go on the wire (``servo`` is ``None``
            for a combined Fast Sync Read reply).
        """
        self._live = live
        w = self.wire
        targets = self._listeners(ins.servo_id)
        if ins.inst in (SYNC_READ, FAST_SYNC_READ, BULK_READ):
            return self._group_read(ins) if ins.valid and not self.p1 else []
        if ins.inst in (SYNC_WRITE, BULK_WRITE):
            if ins.valid:
                self._group_write(ins)
            return []
        unicast = ins.servo_id != BROADCAST
        out: list[Reply] = []
        for servo in sorted(targets, key=lambda s: s.id):
            if not ins.valid:
                if unicast and servo.vendor.reports_errors:
                    out.append((servo, w.status(servo.id, self._error(servo, ERR_CRC), b"")))
                continue
            answers = self._replies(servo, ins.inst)  # the level before this instruction
            sid = servo.id  # the reply to an id change still carries the old id
            err, params = self._single(servo, ins)
            if (unicast or ins.inst == PING) and answers:
                out.append((servo, w.status(sid, self._error(servo, err), params)))
            if ins.inst == REBOOT:
                servo.reboot()
        return out

    def _single(self, servo: SimServo, ins: Instruction) -> tuple[int, bytes]:
        w = self.wire
        p = ins.params
        if ins.inst == PING:
            if servo.feetech or self.p1:  # Protocol 1.0 style: the status has no parameters
                return 0, b""
            fw = servo.get(Register.FIRMWARE)
            return 0, servo.model_number.to_bytes(2, "little") + bytes([fw])
        if ins.inst == READ:
            addr, n, _ = w.addr_len(p)
            data = servo.read(addr, n)
            if data is None:
                return (ERR_ACCESS, b"") if servo.vendor.reports_errors else (0, bytes(n))
            return 0, data
        if ins.inst in (WRITE, REG_WRITE):
            k = w.addr_size
            addr = p[0] | (p[1] << 8 if k == 2 else 0)
            if ins.inst == REG_WRITE:
                servo.registered = (addr, bytes(p[k:]))
                return 0, b""
            return servo.write(addr, bytes(p[k:])), b""
        if ins.inst == ACTION:
            if servo.registered is None:
                return (ERR_INSTRUCTION if servo.vendor.reports_errors else 0), b""
            addr, data = servo.registered
            servo.registered = None
            return servo.write(addr, data), b""
        if ins.inst == REBOOT:
            return 0, b""
        if ins.inst == CLEAR and not servo.feetech:
            if p != b"\x01\x44\x58\x4c\x22":
                return ERR_INSTRUCTION, b""
            return servo.clear_multi_turn(), b""
        if ins.inst == FACTORY_RESET and not servo.feetech:
            servo.factory_reset(keep_id=p[:1] in (b"\x01", b"\x02"), keep_baud=p[:1] == b"\x02")
            return 0, b""
        return (ERR_INSTRUCTION if servo.vendor.reports_errors else 0), b""

    def _group_read(self, ins: Instruction) -> list[Reply]:
        w = self.wire
        p = ins.params
        if ins.inst == BULK_READ:
            items = [(p[i], p[i + 1] | p[i + 2] << 8, p[i + 3] | p[i + 4] << 8)
                     for i in range(0, len(p) - 4, 5)]
        else:
            addr, n, ids = w.addr_len(p)
            items = [(sid, addr, n) for sid in ids]
        out: list[Reply] = []
        segments = []
        for sid, addr, n in items:
            found = self._listeners(sid)
            if not found or sid == BROADCAST:
                continue
            servo = found[0]
            if not self._replies(servo, SYNC_READ):
                continue
            data = servo.read(addr, n)
            err = servo.error_byte
            if data is None:  # outside the table: an access error without params, or zeros
                if servo.vendor.reports_errors:
                    data, err = b"", err | ERR_ACCESS
                else:
                    data = bytes(n)
            if ins.inst == FAST_SYNC_READ:
                segments.append((servo.id, err, data.ljust(n, b"\0")))
            else:
                out.append((servo, w.status(servo.id, err, data)))
        if segments and isinstance(w, DxlWire):
            out.append((None, w.fast_status(segments)))
        return out

    def _group_write(self, ins: Instruction) -> None:
        p = ins.params
        if ins.inst == BULK_WRITE:
            i = 0
            while i + 5 <= len(p):
                sid, addr, n = p[i], p[i + 1] | p[i + 2] << 8, p[i + 3] | p[i + 4] << 8
                for servo in self._listeners(sid):
                    servo.write(addr, bytes(p[i + 5:i + 5 + n]))
                i += 5 + n
            return
        addr, n, rest = self.wire.addr_len(p)
        for i in range(0, len(rest) - n, n + 1):
            for servo in self._listeners(rest[i]):
                servo.write(addr, bytes(rest[i + 1:i + 1 + n]))
