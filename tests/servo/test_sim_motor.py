"""The simulated servos' motor model against the makers' specification tables.

The expected figures are the makers' (transcribed here, independently of
armctl/servo_tables/motors.py): ROBOTIS e-Manual specification tables of XL330-M077, XL330-M288,
XL430-W250, XM430-W350 and XM540-W270 (stall torque and current, no-load speed at the
recommended supply; Present Current unit 1 mA on XL330, about 2.69 mA on XM430/XM540; Present
Load 0.1 % on XL430), and the Feetech STS3215 (7.4 V) specification (1.91 N m, 2.7 A stall,
52 rev/min no load; Present_Current unit 6.5 mA). Everything runs in simulated time.
"""

from __future__ import annotations

import math

import pytest
from sim_servo_helpers import Bench

from armctl.servo_tables import Register
from armctl.servo_tables.motors import motor_for

R = Register
RPM_UNIT = 0.229  # [rev/min] per Dynamixel velocity count

# model: (stall torque [N m], stall current [A], no-load speed [rev/min], current unit [A])
MAKER = {
    "xl330-m077": (0.215, 1.47, 383.0, 0.001),
    "xl330-m288": (0.52, 1.47, 103.0, 0.001),
    "xl430-w250": (1.4, 1.3, 57.0, None),
    "xm430-w350": (4.1, 2.3, 46.0, 0.00269),
    "xm540-w270": (10.6, 4.4, 30.0, 0.00269),
    "sts3215": (1.91, 2.7, 52.0, 0.0065),
}


def full_pwm(b: Bench) -> None:
    """Open loop at full duty (Dynamixel PWM mode, Feetech mode 2)."""
    if b.table.vendor.feetech:
        b.mode(2)
        b.write(R.GOAL_TIME, 1000)
    else:
        b.mode(16)
        b.write(R.GOAL_PWM, 885)


def speed_rpm(b: Bench) -> float:
    """Present velocity [rev/min]."""
    v = b.read(R.PRESENT_VELOCITY)
    return v * 60.0 / 4096 if b.table.vendor.feetech else v * RPM_UNIT


def amps(b: Bench, model: str) -> float:
    """Present current [A] (the load fraction times the stall current on the XL430)."""
    _, stall, _, unit = MAKER[model]
    if b.table.vendor.feetech:
        return b.read(R.PRESENT_CURRENT) * 0.0065
    if unit is None:
        return b.read(R.PRESENT_LOAD) / 1000.0 * stall
    return b.read(R.PRESENT_LOAD) * unit


@pytest.mark.parametrize("model", list(MAKER))
def test_no_load_speed_at_full_pwm(model: str) -> None:
    b = Bench(model)
    full_pwm(b)
    b.run(1.0, every=0.05)
    assert speed_rpm(b) == pytest.approx(MAKER[model][2], rel=0.03)


@pytest.mark.parametrize("model", list(MAKER))
def test_stall_current_at_stall(model: str) -> None:
    b = Bench(model)
    b.servo.block_at(None)  # the shaft is held where it is
    full_pwm(b)
    b.run(0.2)
    assert b.read(R.PRESENT_VELOCITY) == 0
    assert amps(b, model) == pytest.approx(MAKER[model][1], rel=0.02)


@pytest.mark.parametrize("model", list(MAKER))
def test_stall_torque_balances_full_pwm(model: str) -> None:
    torque = MAKER[model][0]
    for load, forward in ((0.9 * torque, True), (1.1 * torque, False)):
        b = Bench(model)
        b.servo.set_load(load)
        full_pwm(b)
        start = b.servo.actual
        b.run(0.3)
        assert (b.servo.actual > start) is forward, f"{load:.3f} N m"


def test_current_mode_accelerates_the_free_shaft_at_kt_i_over_j() -> None:
    torque, stall, _, unit = MAKER["xm430-w350"]
    b = Bench("xm430-w350")
    b.mode(0)
    b.write(R.GOAL_CURRENT, 200)  # 0.538 A
    b.clock.advance(0.02)
    motor = motor_for("xm430-w350")  # the inertia is the model's (the maker publishes none)
    accel = (torque / stall * 200 * unit - motor.coulomb_friction) / motor.inertia  # [rad/s^2]
    v = b.read(R.PRESENT_VELOCITY) * RPM_UNIT * 2 * math.pi / 60  # [rad/s] after 20 ms
    assert v == pytest.approx(accel * 0.02, rel=0.05)  # viscous friction still negligible
    assert b.read(R.PRESENT_LOAD) == pytest.approx(200, abs=1)  # Present Current = Goal Current


def test_present_current_under_load_and_zero_with_torque_off() -> None:
    torque, stall, _, unit = MAKER["xm430-w350"]
    b = Bench("xm430-w350")
    b.write(R.TORQUE_ENABLE, 1)
    b.servo.set_load(1.0)  # [N m] e.g. an arm's weight on the joint
    b.run(1.0)
    holding = b.read(R.PRESENT_LOAD)
    assert holding * unit == pytest.approx(1.0 / (torque / stall), rel=0.05)  # i = T / Kt
    assert b.read(R.PRESENT_PWM) > 0
    assert 2048 - 60 < b.read(R.PRESENT_POSITION) < 2048 - 5  # sags until P x error holds it
    loaded = b.read(R.PRESENT_VOLTAGE)  # Present Input Voltage
    b.write(R.TORQUE_ENABLE, 0)
    b.clock.advance(0.01)
    assert b.read(R.PRESENT_LOAD) == 0 and b.read(R.PRESENT_PWM) == 0
    assert b.read(R.PRESENT_VOLTAGE) >= loaded


def test_gravity_callback_load_draws_current_by_angle() -> None:
    b = Bench("xm430-w350", 1024)  # a quarter turn: the link horizontal
    b.servo.set_load(lambda q, w, t: 1.2 * math.sin(q))  # [N m], 0 rad hanging down
    b.write(R.TORQUE_ENABLE, 1)
    b.run(0.5)
    horizontal = b.read(R.PRESENT_LOAD)
    b.write(R.GOAL_POSITION, 0)  # hanging down: no torque needed
    b.run(2.0)
    assert abs(b.read(R.PRESENT_LOAD)) < 0.1 * horizontal
    assert horizontal * 0.00269 == pytest.approx(1.2 / (4.1 / 2.3), rel=0.05)


def test_temperature_rises_under_load_and_overheating_cuts_torque() -> None:
    b = Bench("xm430-w350")
    b.servo.block_at(None)
    b.write(R.TEMPERATURE_LIMIT, 60)
    full_pwm(b)
    t0 = b.read(R.PRESENT_TEMPERATURE)
    b.clock.advance(10.0)
    warmer = b.read(R.PRESENT_TEMPERATURE)
    assert warmer > t0 + 3
    for _ in range(600):
        b.clock.advance(1.0)
        if b.read(R.HARDWARE_ERROR) & 0x04:
            break
    assert b.read(R.HARDWARE_ERROR) & 0x04  # overheating (e-Manual Hardware Error Status)
    assert b.read(R.TORQUE_ENABLE) == 0 and b.read(R.PRESENT_LOAD) == 0
    hot = b.servo.drive.temperature
    b.clock.advance(300.0)
    b.read(R.PRESENT_POSITION)
    assert b.servo.drive.temperature < hot - 10  # cooling with the torque off


def test_input_voltage_sags_under_stall_current() -> None:
    b = Bench("xm430-w350")
    idle = b.read(R.PRESENT_VOLTAGE)
    b.servo.block_at(None)
    full_pwm(b)
    b.run(0.1)
    assert b.read(R.PRESENT_VOLTAGE) < idle


# ---- Feetech torque limit and protection --------------------------------------------------------
def feetech_pressing(torque_limit: int = 1000, **eeprom: int) -> Bench:
    """An STS3215 pressing on an obstacle; ``eeprom``: register name -> value, set first."""
    b = Bench("sts3215")
    b.write(R.LOCK, 0)  # EEPROM items are written with torque off and the lock open
    for name, value in eeprom.items():
        b.write(Register.parse(name), value)
    b.write(R.TORQUE_LIMIT, torque_limit)
    b.servo.block_at(None)
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.GOAL_POSITION, 3048)  # far beyond the obstacle: the loop saturates
    return b


def test_feetech_torque_limit_scales_the_stall_torque() -> None:
    full, half = feetech_pressing(), feetech_pressing(500)
    for b in (full, half):
        b.run(0.3)
    assert full.read(R.PRESENT_LOAD) == pytest.approx(1000, abs=5)
    assert half.read(R.PRESENT_LOAD) == pytest.approx(500, abs=5)
    assert half.read(R.PRESENT_CURRENT) * 0.0065 == pytest.approx(0.5 * 2.7, rel=0.03)
    moved = Bench("sts3215")  # half the torque cannot lift 0.6 of the stall torque
    moved.write(R.TORQUE_LIMIT, 500)
    moved.servo.set_load(0.6 * 1.91)
    moved.write(R.TORQUE_ENABLE, 1)
    moved.run(0.5)
    assert moved.read(R.PRESENT_POSITION) < 2048 - 50


def test_feetech_overload_protection_cuts_torque_after_protection_time() -> None:
    b = feetech_pressing(overload_torque=50, protection_time=50)  # 50 %, 0.5 s
    b.run(0.45)
    assert b.read(R.HARDWARE_ERROR) == 0 and b.read(R.TORQUE_ENABLE) == 1
    b.run(0.1)
    assert b.read(R.HARDWARE_ERROR) & 0x20  # overload
    assert b.read(R.TORQUE_ENABLE) == 0 and b.read(R.PRESENT_LOAD) == 0


def test_feetech_overload_without_unloading_limits_to_protective_torque() -> None:
    b = feetech_pressing(unloading_condition=0, protection_time=20)  # no release; 0.2 s
    b.run(0.5)
    assert b.read(R.HARDWARE_ERROR) & 0x20
    assert b.read(R.TORQUE_ENABLE) == 1
    assert b.read(R.PRESENT_LOAD) == pytest.approx(200, abs=5)  # Protective_Torque 20 %


def test_feetech_overcurrent_protection() -> None:
    # 1.3 A (below the 2.7 A stall current) for 0.2 s
    b = feetech_pressing(protection_current=200, overcurrent_protection_time=20)
    b.run(0.15)
    assert b.read(R.HARDWARE_ERROR) == 0
    b.run(0.1)
    assert b.read(R.HARDWARE_ERROR) & 0x08  # overcurrent (Feetech status bit 3)
    assert b.read(R.TORQUE_ENABLE) == 0  # Unloading_Condition 44 includes it
