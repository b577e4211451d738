"""What simulated servos do with an instruction packet, and the status packets they answer.

Protocol rules (e-Manual Protocol 2.0; Feetech SCS/STS as implemented by ``scservo_sdk``):
broadcast gets replies only to Ping and the group reads; group read replies follow the order of
the instruction's id list, and a fast group read (Fast Sync Read, Fast Bulk Read) is answered
with one combined packet; Status Return Level decides which instructions are answered (the level
before the instruction); a reply to an id or baud rate change carries the old id and goes out
before the change takes effect; a servo also obeys Write, Reg Write and Action sent to its
Secondary ID, on the RAM area only, without replying. What differs between the families (error
byte, Ping contents, which instructions exist, how writes are checked) the servo's
:class:`~armctl.servo.sim.rules.ServoRules` decide.
"""

from __future__ import annotations

from armctl.servo.sim.rules import (
    ACTION,
    BULK_READ,
    BULK_WRITE,
    ERR_CRC,
    ERR_INSTRUCTION,
    FAST_BULK_READ,
    FAST_SYNC_READ,
    PING,
    READ,
    REBOOT,
    REG_WRITE,
    SYNC_READ,
    SYNC_WRITE,
    WRITE,
)
from armctl.servo.sim.servo import SimServo
from armctl.servo.sim.wire import BROADCAST, Instruction, Wire
from armctl.servo_tables import Register

__all__ = ["REBOOT", "Dispatcher", "Reply"]

Reply = tuple[SimServo | None, bytes]
_GROUP_READS = frozenset({SYNC_READ, FAST_SYNC_READ, BULK_READ, FAST_BULK_READ})
_BULK = frozenset({BULK_READ, FAST_BULK_READ})
_GROUP_WRITES = frozenset({SYNC_WRITE, BULK_WRITE})
_BY_SECONDARY = frozenset({WRITE, REG_WRITE, ACTION})  # what a Secondary ID may be sent


class Dispatcher:
    """Carries out instructions on the simulated servos.

    Args:
        wire: The protocol's framing (builds the status packets).
    """

    def __init__(self, wire: Wire):
        self.wire = wire
        self._live: dict[int, SimServo] = {}

    def _listeners(self, sid: int) -> list[SimServo]:
        if sid == BROADCAST:
            return list(self._live.values())
        s = self._live.get(sid)
        return [] if s is None else [s]

    def handle(self, ins: Instruction, live: dict[int, SimServo]) -> list[Reply]:
        """Act on one instruction.

        Args:
            ins: The instruction.
            live: The servos that hear it, by id (present on the bus, at the host's baud rate).

        Returns:
            ``(servo, status packet)`` in the order they go on the wire (``servo`` is ``None``
            for a combined fast group read reply).
        """
        self._live = live
        if ins.valid:
            for s in live.values():
                s.heard()
        if ins.inst in _GROUP_READS:
            return self._group_read(ins) if ins.valid else []
        if ins.inst in _GROUP_WRITES:
            if ins.valid:
                self._group_write(ins)
            return []
        unicast = ins.servo_id != BROADCAST
        out: list[Reply] = []
        w = self.wire
        for servo in sorted(self._listeners(ins.servo_id), key=lambda s: s.id):
            if not ins.valid:
                err = servo.rules.refuse(ERR_CRC)
                if unicast and err:
                    out.append((servo, w.status(servo.id, servo.status_error(err), b"")))
                continue
            answers = servo.rules.answers(servo.get(Register.STATUS_RETURN_LEVEL), ins.inst)
            sid = servo.id  # the reply to an id change still carries the old id
            err, params = self._single(servo, ins, secondary=False)
            if (unicast or ins.inst == PING) and answers:
                out.append((servo, w.status(sid, servo.status_error(err), params)))
            if ins.inst == REBOOT and REBOOT in servo.rules.basic:
                servo.reboot()
        if unicast and ins.valid and ins.inst in _BY_SECONDARY:
            for servo in live.values():
                if servo.secondary_id == ins.servo_id and servo.id != ins.servo_id:
                    self._single(servo, ins, secondary=True)  # obeyed, never answered
        return out

    def _single(self, servo: SimServo, ins: Instruction, secondary: bool) -> tuple[int, bytes]:
        w = self.wire
        rules = servo.rules
        p = ins.params
        if ins.inst not in rules.basic:
            done = rules.instruction(servo, ins.inst, bytes(p), ins.servo_id == BROADCAST)
            return (rules.refuse(ERR_INSTRUCTION), b"") if done is None else done
        if ins.inst == PING:
            return 0, rules.ping_params(servo)
        if ins.inst == READ:
            addr, n, _ = w.addr_len(p)
            data = servo.read(addr, n)
            return rules.read_outside(n) if data is None else (0, data)
        if ins.inst in (WRITE, REG_WRITE):
            k = w.addr_size
            addr = p[0] | (p[1] << 8 if k == 2 else 0)
            if ins.inst == REG_WRITE:
                servo.register_write(addr, bytes(p[k:]), secondary)
                return 0, b""
            return servo.write(addr, bytes(p[k:]), secondary=secondary), b""
        if ins.inst == ACTION:
            err = servo.action()
            return (rules.refuse(ERR_INSTRUCTION) if err is None else err), b""
        return 0, b""  # Reboot: carried out after the reply

    def _group_read(self, ins: Instruction) -> list[Reply]:
        w = self.wire
        p = ins.params
        if ins.inst in _BULK:
            items = [(p[i], p[i + 1] | p[i + 2] << 8, p[i + 3] | p[i + 4] << 8)
                     for i in range(0, len(p) - 4, 5)]
        else:
            addr, n, ids = w.addr_len(p)
            items = [(sid, addr, n) for sid in ids]
        out: list[Reply] = []
        segments = []
        for sid, addr, n in items:
            servo = self._live.get(sid) if sid != BROADCAST else None
            if servo is None or ins.inst not in servo.rules.group_reads:
                continue
            if not servo.rules.answers(servo.get(Register.STATUS_RETURN_LEVEL), ins.inst):
                continue
            data = servo.read(addr, n)
            err = 0
            if data is None:  # outside the table
                err, data = servo.rules.read_outside(n)
            if ins.inst in servo.rules.fast_reads:
                segments.append((servo.id, servo.status_error(err), data.ljust(n, b"\0")))
            else:
                out.append((servo, w.status(servo.id, servo.status_error(err), data)))
        if segments:
            out.append((None, w.fast_status(segments)))
        return out

    def _group_write(self, ins: Instruction) -> None:
        p = ins.params
        if ins.inst == BULK_WRITE:
            i = 0
            while i + 5 <= len(p):
                sid, addr, n = p[i], p[i + 1] | p[i + 2] << 8, p[i + 3] | p[i + 4] << 8
                for servo in self._listeners(sid):
                    if BULK_WRITE in servo.rules.group_writes:
                        servo.write(addr, bytes(p[i + 5:i + 5 + n]))
                i += 5 + n
            return
        addr, n, rest = self.wire.addr_len(p)
        for i in range(0, len(rest) - n, n + 1):
            for servo in self._listeners(rest[i]):
                if SYNC_WRITE in servo.rules.group_writes:
                    servo.write(addr, bytes(rest[i + 1:i + 1 + n]))
