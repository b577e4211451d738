"""Present Position of a simulated X-series servo counts turns as the e-Manual says.

ROBOTIS e-Manual, X series control table, Present Position(132) (the same note is in the
Operating Mode(11) and Torque Enable(64) sections): "Present Position(132) represents a 4 byte
continuous range from -2,147,483,648 to 2,147,483,647 when Torque is turned off regardless of
Operating Mode(11). However, Present Position(132) will be reset to an absolute position value
within one full rotation in the following cases: 1. When the Operating Mode(11) is changed to
Position Control Mode. 2. When torque is turned on in Position Control Mode. 3. When the
actuator is turned on or when rebooted using a Reboot Instruction. Note that a Present
Position(132) value that has been reset to the absolute value within a single rotation will
still be affected by the configured Homing Offset(20) value."

Homing Offset(20): "Present Position(132) = Actual Position + Homing Offset(20)"; "In the case
of Reverse Mode bit is set in Drive Mode(10), the sign of Homing Offset value will not be
reversed." Drive Mode(10) bit 0: "Reverse Mode: CCW(Negative), CW(Positive)".

The shaft is turned "by hand" (torque off) by a constant external torque on the free shaft, so
the expected readings follow from the shaft's own motion, not from the simulator's frame code.
"""

from __future__ import annotations

from itertools import pairwise

import pytest
from sim_servo_helpers import Bench

from armctl.servo_tables import Register

R = Register
TURN = 4096  # ticks per revolution (e-Manual: 0.088 deg per value, 1 rev = 0-4,095)
POSITION, EXTENDED, CURRENT_POSITION = 3, 4, 5  # e-Manual Operating Mode values
ALL_MODES = (0, 1, 3, 4, 5, 16)
MODELS = ("xl330-m077", "xl330-m288", "xl430-w250", "xm430-w350", "xm540-w270")


def set_mode(b: Bench, mode: int) -> None:
    b.write(R.TORQUE_ENABLE, 0)
    b.write(R.OPERATING_MODE, mode)


def turn_by_hand(b: Bench, ticks: float) -> list[int]:
    """Turn the free shaft by about ``ticks`` (encoder direction) with a push, then let go.

    Returns the Present Position read every 5 ms on the way.
    """
    assert b.read(R.TORQUE_ENABLE) == 0
    start = b.servo.actual
    push = 0.03 * b.servo.drive.motor.stall_torque  # [N m], well above the dry friction
    b.servo.set_load(-push if ticks > 0 else push)  # (a load counts against the + direction)
    readings = []
    for _ in range(10_000):
        if abs(b.servo.actual - start) >= abs(ticks):
            break
        b.clock.advance(0.005)
        readings.append(b.read(R.PRESENT_POSITION))
    assert abs(b.servo.actual - start) >= abs(ticks), "the hand could not turn the shaft"
    b.servo.set_load(0.0)
    b.servo.actual = round(b.servo.actual)  # the hand holds it still on a tick
    b.servo.velocity = 0.0
    readings.append(b.read(R.PRESENT_POSITION))
    return readings


@pytest.mark.parametrize("mode", ALL_MODES)
def test_torque_off_counts_turns_in_every_mode(mode: int) -> None:
    b = Bench("xm430-w350", 3000)
    set_mode(b, mode)
    start = b.read(R.PRESENT_POSITION)
    readings = turn_by_hand(b, 2.5 * TURN)  # across 4095 -> 0 twice
    assert all(b2 >= a for a, b2 in pairwise(readings)), \
        "a continuous count: it never jumps back to 0"
    assert readings[-1] - start == round(b.servo.actual) - 3000  # tick for tick
    assert readings[-1] > 2 * TURN
    readings = turn_by_hand(b, -4.0 * TURN)  # and below 0
    assert all(b2 <= a for a, b2 in pairwise(readings))
    assert readings[-1] == round(b.servo.actual) < 0


@pytest.mark.parametrize("model", MODELS)
def test_torque_on_in_position_mode_comes_back_within_one_turn(model: str) -> None:
    b = Bench(model, 3000)
    assert b.read(R.OPERATING_MODE) == POSITION
    turn_by_hand(b, 2 * TURN + 500)
    raw = round(b.servo.actual)
    assert b.read(R.PRESENT_POSITION) == raw  # still counting turns with torque off
    b.write(R.TORQUE_ENABLE, 1)
    assert b.read(R.PRESENT_POSITION) == raw % TURN
    assert b.read(R.GOAL_POSITION) == raw % TURN  # it holds where it is
    b.run(0.3)
    assert b.servo.actual == pytest.approx(raw, abs=3), "the shaft did not move"


@pytest.mark.parametrize("mode", [EXTENDED, CURRENT_POSITION, 1, 0, 16])
def test_torque_on_in_other_modes_keeps_the_count(mode: int) -> None:
    b = Bench("xm430-w350", 1000)
    set_mode(b, mode)
    turn_by_hand(b, TURN + 1000)
    raw = round(b.servo.actual)
    b.write(R.TORQUE_ENABLE, 1)
    assert b.read(R.PRESENT_POSITION) == pytest.approx(raw, abs=3)
    assert b.read(R.PRESENT_POSITION) > TURN


def test_velocity_mode_with_torque_on_counts_turns() -> None:
    b = Bench("xm430-w350", 4000)
    set_mode(b, 1)
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.GOAL_VELOCITY, 100)  # 22.9 rev/min
    readings = [b.read(R.PRESENT_POSITION)]
    for _ in range(40):
        b.clock.advance(0.05)
        readings.append(b.read(R.PRESENT_POSITION))
    assert all(b2 >= a for a, b2 in pairwise(readings))
    assert readings[-1] > TURN  # past 4095 without coming back to 0
    assert readings[-1] - readings[0] == pytest.approx(100 * 0.229 / 60 * 2.0 * TURN, rel=0.05)


@pytest.mark.parametrize("mode", [EXTENDED, CURRENT_POSITION, 1, 0, 16])
def test_changing_to_position_mode_comes_back_within_one_turn(mode: int) -> None:
    b = Bench("xm430-w350", 2000)
    set_mode(b, mode)
    turn_by_hand(b, -(3 * TURN + 300))
    raw = round(b.servo.actual)
    assert b.read(R.PRESENT_POSITION) == raw < 0
    b.write(R.OPERATING_MODE, EXTENDED if mode != EXTENDED else 1)  # not Position Control
    assert b.read(R.PRESENT_POSITION) == raw
    b.write(R.OPERATING_MODE, POSITION)
    assert b.read(R.PRESENT_POSITION) == raw % TURN


@pytest.mark.parametrize("mode", ALL_MODES)
def test_reboot_comes_back_within_one_turn_in_every_mode(mode: int) -> None:
    b = Bench("xm430-w350", 2048)
    set_mode(b, mode)
    turn_by_hand(b, 5 * TURN + 77)
    raw = round(b.servo.actual)
    assert b.read(R.PRESENT_POSITION) == raw
    b.servo.reboot()
    assert b.read(R.PRESENT_POSITION) == raw % TURN
    assert b.read(R.OPERATING_MODE) == mode  # EEPROM kept


def test_power_on_reads_within_one_turn() -> None:
    b = Bench("xm430-w350", 3 * TURN + 1234)  # the shaft anywhere: the encoder is absolute
    assert b.read(R.PRESENT_POSITION) == 1234


@pytest.mark.parametrize("offset", [1000, -1000])
def test_the_reset_value_still_has_the_homing_offset(offset: int) -> None:
    b = Bench("xm430-w350", 3500)
    b.write(R.HOMING_OFFSET, offset)
    assert b.read(R.PRESENT_POSITION) == 3500 + offset  # Actual Position + Homing Offset
    turn_by_hand(b, TURN + 200)
    raw = round(b.servo.actual)
    assert b.read(R.PRESENT_POSITION) == raw + offset  # continuous with torque off
    b.write(R.TORQUE_ENABLE, 1)
    reset = b.read(R.PRESENT_POSITION)
    assert reset == raw % TURN + offset  # within one turn, then the offset: not wrapped again
    assert (reset >= TURN) if offset > 0 else (0 <= reset < TURN)  # 3700 + 1000 reads 4700


def test_reverse_mode_counts_the_other_way_and_keeps_the_offset_sign() -> None:
    b = Bench("xm430-w350", 1000)
    b.write(R.DRIVE_MODE, 0x01)  # Reverse Mode
    b.write(R.HOMING_OFFSET, 300)  # the sign of Homing Offset is not reversed
    assert b.read(R.PRESENT_POSITION) == TURN - 1000 + 300
    before = b.read(R.PRESENT_POSITION)
    turn_by_hand(b, 2 * TURN + 100)  # CCW turns count down in Reverse Mode
    moved = round(b.servo.actual) - 1000
    assert b.read(R.PRESENT_POSITION) == before - moved < 0
    b.write(R.TORQUE_ENABLE, 1)
    assert b.read(R.PRESENT_POSITION) == (-round(b.servo.actual)) % TURN + 300


def test_clear_instruction_comes_back_within_one_turn_without_moving() -> None:
    b = Bench("xm430-w350", 100)
    set_mode(b, EXTENDED)
    turn_by_hand(b, 3 * TURN)
    raw = round(b.servo.actual)
    assert b.servo.clear_multi_turn() == 0
    assert b.read(R.PRESENT_POSITION) == raw % TURN
    assert round(b.servo.actual) == raw  # only the count changed


def test_feetech_position_mode_still_reports_within_one_turn() -> None:
    # Feetech STS memory table: Present_Position 0-4095 in position mode (Operating_Mode 0).
    b = Bench("sts3215", 3000)
    turn_by_hand(b, TURN)
    assert 0 <= b.read(R.PRESENT_POSITION) < TURN
    assert b.read(R.PRESENT_POSITION) == round(b.servo.actual) % TURN


@pytest.mark.parametrize("mode", ALL_MODES)
def test_an_offset_beyond_1024_is_ignored_in_position_control_mode_only(mode: int) -> None:
    # e-Manual Homing Offset(20): "In case of the Position Control Mode(Joint Mode) that rotates
    # less than 360 degrees, any invalid Homing Offset(20) values will be ignored (valid range :
    # -1,024 ~ 1,024)."
    b = Bench("xm430-w350", 1500)
    set_mode(b, mode)
    b.write(R.HOMING_OFFSET, 2000)
    assert b.read(R.PRESENT_POSITION) == (1500 if mode == POSITION else 3500)
    b.write(R.HOMING_OFFSET, -1024)  # within the valid range: honoured in every mode
    assert b.read(R.PRESENT_POSITION) == 1500 - 1024
