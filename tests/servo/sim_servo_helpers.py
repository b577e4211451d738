"""A simulated servo on a simulated clock, driven through its control table (as the host does)."""

from __future__ import annotations

from armctl.clock import SimulatedClock
from armctl.servo.codec import decode, encode, from_le, to_le
from armctl.servo.sim.servo import SimServo
from armctl.servo_tables import Register, table_for


class Bench:
    """One simulated servo and its simulated clock.

    Args:
        model: Servo model name.
        position: Initial present position [tick].
    """

    def __init__(self, model: str, position: int = 2048):
        self.clock = SimulatedClock()
        self.table = table_for(model)
        baud = next(iter(self.table.vendor.baud_codes.values()))
        self.servo = SimServo(self.table, 1, baud, position, clock=self.clock)

    def write(self, reg: Register, value: int) -> None:
        """Write a register through the servo's access rules; the write must succeed."""
        spec = self.table.spec(reg)
        err = self.servo.write(spec.address, to_le(encode(spec, value), spec.size))
        assert err == 0, f"write of {value} to {reg.value} answered error {err}"
        if self.table.vendor.feetech:  # Feetech never reports errors: check the value took
            assert self.servo.get(reg) == value, f"write of {value} to {reg.value} ignored"

    def read(self, reg: Register) -> int:
        """Read a register as the host would (the motion is brought up to date)."""
        spec = self.table.spec(reg)
        raw = self.servo.read(spec.address, spec.size)
        assert raw is not None
        return decode(spec, from_le(raw))

    def run(self, seconds: float, every: float = 0.01) -> list[tuple[float, dict[Register, int]]]:
        """Let ``seconds`` pass, reading position, velocity and load every ``every`` [s]."""
        out = []
        n = round(seconds / every)
        for _ in range(n):
            self.clock.advance(every)
            out.append((self.clock.now(), {r: self.read(r) for r in (
                Register.PRESENT_POSITION, Register.PRESENT_VELOCITY, Register.PRESENT_LOAD)}))
        return out

    def mode(self, value: int) -> None:
        """Switch the Operating Mode (torque off first, as the servo requires) and torque on."""
        self.write(Register.TORQUE_ENABLE, 0)
        if self.table.vendor.feetech:
            self.write(Register.LOCK, 0)
        self.write(Register.OPERATING_MODE, value)
        self.write(Register.TORQUE_ENABLE, 1)
