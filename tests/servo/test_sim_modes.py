"""Operating modes of the simulated servos: each moves the shaft as the maker's manual describes.

Everything runs in simulated time (a :class:`~armctl.clock.SimulatedClock` per servo). Units and
bits are the makers': ROBOTIS e-Manual X series (Operating Mode 11, Drive Mode 10, Profile
Velocity 112 / Acceleration 108, Moving 122, Moving Status 123, Goal PWM 100 in 0.113 %, Goal
Current 102, velocity in 0.229 rev/min); Feetech STS memory table (Operating_Mode 33: 0
position, 1 wheel, 2 PWM, 3 step; Goal_Time 44 as PWM in mode 2; Torque_Limit 48).
"""

from __future__ import annotations

import pytest
from sim_servo_helpers import Bench

from armctl.servo_tables import Register

R = Register
RPM_UNIT = 0.229  # [rev/min] per velocity count (e-Manual)
TICKS_PER_REV = 4096


def counts_to_tick_s(counts: float) -> float:
    """Velocity counts (0.229 rev/min) in [tick/s]."""
    return counts * RPM_UNIT / 60.0 * TICKS_PER_REV


# ---- Dynamixel position modes ---------------------------------------------------------------
@pytest.mark.parametrize("model", ["xl330-m077", "xl330-m288", "xl430-w250", "xm430-w350",
                                   "xm540-w270"])
def test_position_step_reaches_the_goal_and_stops(model: str) -> None:
    b = Bench(model)
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.GOAL_POSITION, 2648)
    trace = b.run(1.5)  # the XL330-M077's integral gain takes a while to creep in
    positions = [s[R.PRESENT_POSITION] for _, s in trace]
    assert positions[0] > 2048, "it starts towards the goal at once"
    assert max(positions) <= 2648 + 0.25 * 600, "no large overshoot at the default gains"
    assert abs(positions[-1] - 2648) <= 2
    assert b.read(R.MOVING) == 0 and b.read(R.PRESENT_VELOCITY) == 0
    assert b.read(R.MOVING_STATUS) & 0x01  # in position
    assert not b.read(R.MOVING_STATUS) & 0x02  # no profile ongoing


def test_profile_velocity_limits_the_speed_and_sets_the_profile_type() -> None:
    b = Bench("xm430-w350")
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.PROFILE_VELOCITY, 50)  # 11.45 rev/min
    b.write(R.PROFILE_ACCELERATION, 20)
    b.write(R.GOAL_POSITION, 3048)
    assert b.read(R.MOVING_STATUS) & 0x30 == 0x30  # trapezoidal: the move is long enough
    trace = b.run(2.0)
    speeds = [s[R.PRESENT_VELOCITY] for _, s in trace]
    assert 45 <= max(speeds) <= 53  # the profile's 50 counts (the loop lags a little)
    assert max(b.read(R.VELOCITY_TRAJECTORY) for _ in range(1)) == 0  # profile over
    assert abs(trace[-1][1][R.PRESENT_POSITION] - 3048) <= 2
    b.write(R.GOAL_POSITION, 3058)  # a short move cannot reach the profile velocity
    assert b.read(R.MOVING_STATUS) & 0x30 == 0x20  # triangular
    b.run(0.5)
    b.write(R.PROFILE_ACCELERATION, 0)
    b.write(R.GOAL_POSITION, 3000)
    assert b.read(R.MOVING_STATUS) & 0x30 == 0x10  # rectangular
    b.run(0.5)
    b.write(R.PROFILE_VELOCITY, 0)
    b.write(R.GOAL_POSITION, 2900)
    assert b.read(R.MOVING_STATUS) & 0x30 == 0x00  # no profile: a step


def test_profile_trajectory_and_moving_follow_the_trapezoid() -> None:
    b = Bench("xm430-w350")
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.PROFILE_VELOCITY, 100)  # 22.9 rev/min = 1563 tick/s
    b.write(R.PROFILE_ACCELERATION, 10)  # 2146 rev/min^2 = 2441 tick/s^2
    b.write(R.GOAL_POSITION, 4000)
    vmax, amax = counts_to_tick_s(100), 10 * 214.577 / 3600.0 * TICKS_PER_REV
    b.clock.advance(0.2)
    traj = b.read(R.POSITION_TRAJECTORY)
    assert traj - 2048 == pytest.approx(0.5 * amax * 0.2**2, abs=3)  # still accelerating
    assert b.read(R.VELOCITY_TRAJECTORY) == pytest.approx(amax * 0.2 / counts_to_tick_s(1),
                                                         abs=1)
    assert b.read(R.MOVING) == 1 and b.read(R.MOVING_STATUS) & 0x02
    duration = 1952 / vmax + vmax / amax  # distance / v + v / a for a trapezoid
    b.clock.advance(duration - 0.2 - 0.05)
    assert b.read(R.POSITION_TRAJECTORY) < 4000
    b.clock.advance(0.1)
    assert b.read(R.POSITION_TRAJECTORY) == 4000
    b.run(0.5)
    assert b.read(R.MOVING) == 0 and abs(b.read(R.PRESENT_POSITION) - 4000) <= 2


def test_time_based_profile_reaches_the_goal_in_the_given_time() -> None:
    b = Bench("xm430-w350")
    b.write(R.DRIVE_MODE, 0x04)  # time-based profile (e-Manual Drive Mode bit 2)
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.PROFILE_VELOCITY, 1500)  # the whole move in 1500 ms
    b.write(R.PROFILE_ACCELERATION, 400)  # accelerating for 400 ms
    b.write(R.GOAL_POSITION, 2448)
    b.clock.advance(1.4)
    assert 2300 < b.read(R.POSITION_TRAJECTORY) < 2448
    b.clock.advance(0.11)
    assert b.read(R.POSITION_TRAJECTORY) == 2448
    peak = 400 / (1.5 - 0.4)  # [tick/s]: distance / (t3 - t1)
    b.write(R.GOAL_POSITION, 2048)
    b.clock.advance(0.7)  # mid-move, at the peak velocity
    assert abs(b.read(R.VELOCITY_TRAJECTORY)) == pytest.approx(peak / counts_to_tick_s(1), abs=1)
    b.run(1.2)
    assert abs(b.read(R.PRESENT_POSITION) - 2048) <= 2


def test_reverse_drive_mode_mirrors_position_and_motion() -> None:
    fwd, rev = Bench("xm430-w350", 1000), Bench("xm430-w350", 1000)
    rev.write(R.DRIVE_MODE, 0x01)
    assert rev.read(R.PRESENT_POSITION) == TICKS_PER_REV - 1000  # the same shaft, mirrored
    assert rev.servo.actual == fwd.servo.actual
    for b in (fwd, rev):
        b.write(R.TORQUE_ENABLE, 1)
        b.write(R.GOAL_POSITION, b.read(R.PRESENT_POSITION) + 300)
        b.run(1.0)
    assert fwd.read(R.PRESENT_POSITION) == pytest.approx(1300, abs=2)
    assert rev.read(R.PRESENT_POSITION) == pytest.approx(TICKS_PER_REV - 1000 + 300, abs=2)
    assert fwd.servo.actual == pytest.approx(1300, abs=2)  # the shafts turned opposite ways
    assert rev.servo.actual == pytest.approx(700, abs=2)


def test_extended_position_mode_counts_turns() -> None:
    b = Bench("xm430-w350")
    b.mode(4)
    b.write(R.GOAL_POSITION, 2048 + 3 * TICKS_PER_REV)
    b.run(5.0, every=0.05)
    assert b.read(R.PRESENT_POSITION) == pytest.approx(2048 + 3 * TICKS_PER_REV, abs=2)


@pytest.mark.parametrize(("mode", "limited"), [(5, True), (3, False)])
def test_current_based_position_limits_the_current_to_goal_current(mode: int,
                                                                   limited: bool) -> None:
    b = Bench("xm430-w350")
    b.mode(mode)
    b.write(R.GOAL_CURRENT, 100)  # 269 mA
    b.servo.block_at(2148)  # something in the way
    b.write(R.GOAL_POSITION, 2548)
    trace = b.run(0.5)
    assert trace[-1][1][R.PRESENT_POSITION] == 2148
    currents = [s[R.PRESENT_LOAD] for _, s in trace]
    if limited:  # pressing with Goal Current, never more
        assert max(currents) <= 100 and currents[-1] == pytest.approx(100, abs=2)
    else:  # position control presses with all the PWM it has: the stall current, 2.3 A
        assert currents[-1] == pytest.approx(2300 / 2.69, rel=0.03)


def test_position_mode_respects_pwm_limit_and_goal_pwm() -> None:
    b = Bench("xm430-w350")
    b.write(R.PWM_LIMIT, 300)
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.GOAL_POSITION, 3548)
    pwms = []
    for _ in range(50):
        b.clock.advance(0.01)
        pwms.append(b.read(R.PRESENT_PWM))
    assert max(pwms) == 300  # saturated at the limit, never above
    b.write(R.GOAL_PWM, 150)  # Goal PWM limits the controller output further
    b.clock.advance(0.05)
    assert 0 < b.read(R.PRESENT_PWM) <= 150


# ---- Dynamixel velocity, current and PWM modes ------------------------------------------------
@pytest.mark.parametrize(("drive_mode", "sign"), [(0, 1), (1, -1)])
def test_velocity_mode_holds_goal_velocity(drive_mode: int, sign: int) -> None:
    b = Bench("xm430-w350")
    b.write(R.DRIVE_MODE, drive_mode)
    b.mode(1)
    b.write(R.GOAL_VELOCITY, 100)  # 22.9 rev/min
    trace = b.run(1.0)
    assert [s[R.PRESENT_VELOCITY] for _, s in trace[-20:]] == pytest.approx([100] * 20, abs=2)
    start = b.servo.actual
    b.run(1.0)
    turned = b.servo.actual - start  # [tick] in one second, shaft direction
    assert turned == pytest.approx(sign * counts_to_tick_s(100), rel=0.03)


def test_velocity_mode_ramps_with_profile_acceleration() -> None:
    b = Bench("xm430-w350")
    b.mode(1)
    b.write(R.PROFILE_ACCELERATION, 10)  # 2146 rev/min^2: 100 counts (22.9 rpm) in 0.64 s
    b.write(R.GOAL_VELOCITY, 100)
    b.clock.advance(0.32)
    assert b.read(R.VELOCITY_TRAJECTORY) == pytest.approx(50, abs=2)


@pytest.mark.parametrize(("drive_mode", "sign"), [(0, 1), (1, -1)])
def test_pwm_mode_drives_open_loop(drive_mode: int, sign: int) -> None:
    b = Bench("xm430-w350")
    b.write(R.DRIVE_MODE, drive_mode)
    b.mode(16)
    b.write(R.GOAL_PWM, 442)  # 50 %
    b.run(0.5)
    assert b.read(R.PRESENT_PWM) == 442
    speed = b.read(R.PRESENT_VELOCITY)
    no_load = 46.0 / RPM_UNIT  # e-Manual XM430-W350: 46 rev/min at 12 V, full PWM
    assert 0.4 * no_load < speed < 0.5 * no_load  # half the voltage, less the friction
    start = b.servo.actual
    b.run(0.5)
    assert (b.servo.actual - start) * sign > 0


def test_goal_pwm_above_pwm_limit_is_refused() -> None:
    b = Bench("xm430-w350")
    b.write(R.PWM_LIMIT, 200)
    b.mode(16)
    spec = b.table.spec(R.GOAL_PWM)
    assert b.servo.write(spec.address, (300).to_bytes(2, "little")) != 0  # range error
    b.write(R.GOAL_PWM, 200)
    b.run(0.2)
    assert b.read(R.PRESENT_PWM) == 200


# ---- Feetech STS3215 --------------------------------------------------------------------------
def test_feetech_position_mode_follows_goal_speed_and_acceleration() -> None:
    b = Bench("sts3215")
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.PROFILE_ACCELERATION, 50)  # Acceleration: 5000 tick/s^2
    b.write(R.PROFILE_VELOCITY, 800)  # Goal_Speed [tick/s]
    b.write(R.GOAL_POSITION, 3048)
    trace = b.run(2.0)
    speeds = [s[R.PRESENT_VELOCITY] for _, s in trace]
    assert 760 <= max(speeds) <= 840
    assert speeds[1] < 200  # accelerating at 5000 tick/s^2: 100 tick/s after 20 ms
    assert abs(trace[-1][1][R.PRESENT_POSITION] - 3048) <= 2


def test_feetech_wheel_mode_turns_at_goal_speed() -> None:
    b = Bench("sts3215")
    b.mode(1)
    b.write(R.PROFILE_VELOCITY, -1000)  # Goal_Speed, sign bit 15: backwards
    trace = b.run(1.0)
    assert [s[R.PRESENT_VELOCITY] for _, s in trace[-10:]] == pytest.approx([-1000] * 10,
                                                                            abs=15)


def test_feetech_pwm_mode_and_torque_limit() -> None:
    b = Bench("sts3215")
    b.mode(2)
    b.write(R.GOAL_TIME, 500)  # 50 % duty (Goal_Time is the PWM in mode 2)
    b.run(0.5)
    half = b.read(R.PRESENT_VELOCITY)
    no_load = 52.0 / 60.0 * TICKS_PER_REV  # [tick/s] 52 rev/min at 7.4 V (maker)
    assert 0.4 * no_load < half < 0.5 * no_load
    b.write(R.TORQUE_LIMIT, 250)  # the duty is limited to 25 %
    b.run(0.5)
    assert b.read(R.PRESENT_VELOCITY) < 0.25 * no_load
    assert b.read(R.PRESENT_LOAD) <= 250


def test_feetech_step_mode_moves_by_the_goal() -> None:
    b = Bench("sts3215")
    b.mode(3)
    b.write(R.GOAL_POSITION, 500)
    b.run(1.0)
    first = b.read(R.PRESENT_POSITION)
    assert first == pytest.approx(2548, abs=2)  # within the dead zone and friction
    b.write(R.GOAL_POSITION, 300)  # relative to where the shaft is
    b.run(1.0)
    assert b.read(R.PRESENT_POSITION) == pytest.approx(first + 300, abs=2)


def test_feetech_dead_zone_ignores_small_errors() -> None:
    b = Bench("sts3215")
    b.write(R.LOCK, 0)
    b.write(R.CW_DEAD_ZONE, 16)
    b.write(R.CCW_DEAD_ZONE, 16)
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.GOAL_POSITION, 2058)  # 10 ticks away: inside the dead zone
    b.run(0.5)
    assert b.read(R.PRESENT_POSITION) == 2048 and b.read(R.PRESENT_LOAD) == 0
    b.write(R.GOAL_POSITION, 2248)  # outside it: the servo moves, and stops within it
    b.run(1.0)
    assert 2248 - 16 <= b.read(R.PRESENT_POSITION) <= 2248 + 16


def test_moving_status_reports_a_following_error_at_an_obstacle() -> None:
    b = Bench("xm430-w350")
    b.write(R.TORQUE_ENABLE, 1)
    b.servo.block_at(2148)
    b.write(R.PROFILE_VELOCITY, 100)
    b.write(R.PROFILE_ACCELERATION, 50)
    b.write(R.GOAL_POSITION, 3048)
    b.run(2.0)
    status = b.read(R.MOVING_STATUS)
    assert status & 0x08 and not status & 0x01  # following error, not in position
    assert b.read(R.MOVING) == 0  # the shaft stands still against it


def test_velocity_mode_time_based_acceleration_time() -> None:
    b = Bench("xm430-w350")
    b.write(R.DRIVE_MODE, 0x04)  # time-based: Profile Acceleration is t1 [ms] (e-Manual)
    b.mode(1)
    b.write(R.PROFILE_ACCELERATION, 500)
    b.write(R.GOAL_VELOCITY, 100)
    b.clock.advance(0.25)
    assert b.read(R.VELOCITY_TRAJECTORY) == pytest.approx(50, abs=1)
    b.clock.advance(0.3)
    assert b.read(R.VELOCITY_TRAJECTORY) == 100


def test_reverse_drive_mode_hand_guiding_and_obstacles_use_the_register_frame() -> None:
    b = Bench("xm430-w350", 1000)
    b.write(R.DRIVE_MODE, 0x01)
    b.servo.set_present_position(2000)  # moved by hand until it reads 2000
    assert b.read(R.PRESENT_POSITION) == 2000
    b.servo.block_at(2100)
    b.write(R.TORQUE_ENABLE, 1)
    b.write(R.GOAL_POSITION, 2500)
    b.run(1.0)
    assert b.read(R.PRESENT_POSITION) == 2100  # stopped at the obstacle, in its own frame
