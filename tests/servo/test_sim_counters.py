"""Counters the servo keeps roll over in their bytes instead of silencing the servo."""

from __future__ import annotations

from armctl.clock import SimulatedClock
from armctl.servo.codec import decode, from_le
from armctl.servo.sim.servo import SimServo
from armctl.servo_tables import Register, table_for


def test_present_position_rolls_over_after_many_turns() -> None:
    """ROBOTIS e-Manual, X series Present Position (132): a signed 4-byte count in extended
    position mode; past 2**31 - 1 it continues from -2**31 and the servo keeps answering."""
    table = table_for("xm430-w350")
    servo = SimServo(table, 1, 57_600, clock=SimulatedClock())
    spec = table.spec(Register.PRESENT_POSITION)
    mode = table.spec(Register.OPERATING_MODE)
    assert servo.write(mode.address, bytes([4])) == 0  # extended position, torque off
    servo.actual = float(2**31 + 100)
    data = servo.read(spec.address, spec.size)
    assert data is not None
    assert decode(spec, from_le(data)) == -(2**31) + 100


class _TickingClock(SimulatedClock):
    """A clock that moves on by 1 ms whenever it is read (as the wall clock does)."""

    def now(self) -> float:
        self.advance(1e-3)
        return super().now()


def test_overheating_latches_once_on_a_clock_that_moves_while_read() -> None:
    """An overheating servo raises its alarm and cuts torque (e-Manual Shutdown, bit 2), and keeps
    answering: latching the alarm must not run the motor loop again."""
    table = table_for("xl330-m288")
    servo = SimServo(table, 3, 1_000_000, clock=_TickingClock())
    limit = table.spec(Register.TEMPERATURE_LIMIT)
    torque = table.spec(Register.TORQUE_ENABLE)
    assert servo.write(torque.address, bytes([1])) == 0
    servo.set(Register.TEMPERATURE_LIMIT, 30)  # below the idle temperature
    error = table.spec(Register.HARDWARE_ERROR)
    data = servo.read(error.address, 1)
    assert data is not None and data[0] & 0x04
    assert servo.read(torque.address, 1) == b"\x00"
    assert limit.address < table.eeprom_end
