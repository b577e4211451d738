"""Pause, resume, speed override and stop through ``Robot.control`` during a motion.

The commanded stream (one goal per cycle, recorded with ``record=True``) is checked by finite
differences: the first, second and third differences over the cycle period are weighted means
of the commanded velocity, acceleration and jerk, so none may exceed the joint limits. They are
allowed :data:`TOL` (1 %) above them: the time scaling checks the plan's derivatives sampled
every 2 ms of plan time and interpolated between. The path is checked against a dense sampling
of the plan (brute-force nearest point), independent of the plan time the executor reports.

Motion runs in simulated time (tests/robot/conftest.py) except the ``realtime`` test, where
another thread calls the control during a short motion in wall-clock time.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections.abc import Callable

import numpy as np
import pytest

from armctl.config.motion import ExitPolicy
from armctl.errors import InputError
from armctl.motion import MotionPlan, plan_joint_move
from armctl.robot import CycleInfo, MotionControl, MotionStopped, Robot, StopReason, StreamResult
from armctl.robot.time_scaling import PlanTable, rate_change_pieces

pytestmark = pytest.mark.timeout(60)

#: Goal of the test moves: the first three joints travel 0.9-1.2 rad.
GOAL = np.array([1.2, -0.9, 0.9, 0.4, 0.0, 0.0])
#: Relative tolerance on the limits of the finite differences [-].
TOL = 0.01


def at_times(robot: Robot, events: dict[float, Callable[[], object]],
             seen: list[CycleInfo] | None = None) -> Callable[[CycleInfo], None]:
    """An ``on_cycle`` that calls each event once its time [s since the start] has come."""
    pending = dict(sorted(events.items()))

    def on_cycle(info: CycleInfo) -> None:
        if seen is not None:
            seen.append(info)
        for at in list(pending):
            if info.elapsed >= at - 1e-9:
                pending.pop(at)()

    return on_cycle


def differences(res: StreamResult, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """First, second and third finite differences of the commands over ``dt``."""
    c = res.log_cmd
    v = np.diff(c, axis=0) / dt
    a = np.diff(v, axis=0) / dt
    j = np.diff(a, axis=0) / dt
    return v, a, j


def assert_within_limits(robot: Robot, cmds: np.ndarray) -> dict[str, float]:
    """Every finite difference of ``cmds`` within the joint limits (+ :data:`TOL`)."""
    dt = 1.0 / robot.executor.rate_hz
    idx = robot.executor.idx
    lim = robot.limits
    v = np.diff(cmds, axis=0) / dt
    a = np.diff(v, axis=0) / dt
    j = np.diff(a, axis=0) / dt
    peaks = {}
    for name, values, bound in (("velocity", v, lim.velocity[idx]),
                                ("acceleration", a, lim.acceleration[idx]),
                                ("jerk", j, lim.jerk[idx])):
        ratio = np.abs(values) / bound
        peaks[name] = float(ratio.max(initial=0.0))
        assert peaks[name] <= 1.0 + TOL, (name, peaks[name], int(np.argmax(ratio.max(axis=1))))
    return peaks


def path_positions(robot: Robot, plan: MotionPlan, cmds: np.ndarray) -> np.ndarray:
    """For each command, the plan time of the nearest point of the plan's path (brute force).

    Asserts that every command lies on the path (within 0.3 mrad: the path is sampled every
    0.1 ms of plan time, at most 0.5 mrad apart at these speeds).
    """
    idx = robot.executor.idx
    ts = np.arange(0.0, plan.duration + 1e-4, 1e-4)
    path = plan.trajectory.sample_many(ts)[0][:, idx]
    found = []
    for c in cmds:
        d = np.max(np.abs(path - c), axis=1)
        k = int(np.argmin(d))
        assert d[k] < 3e-4, f"command {c} is {d[k]:.2e} rad off the plan's path"
        found.append(ts[k])
    return np.array(found)


@pytest.fixture
def robot() -> Robot:
    r = Robot.open("so101", sim=True, speed=0.5, exit_policy=ExitPolicy.HOLD)
    yield r
    r.control.resume()
    r.close_holding("test ended")


def test_pause_holds_then_resume_arrives_within_limits_on_the_path(robot: Robot) -> None:
    plan = robot.plan_joints(GOAL)
    seen: list[CycleInfo] = []
    res = robot.execute(plan, at_times(robot, {0.3: robot.pause, 1.5: robot.resume}, seen),
                        record=True)
    dt = 1.0 / robot.executor.rate_hz
    peaks = assert_within_limits(robot, np.vstack([plan.start[robot.executor.idx],
                                                   res.log_cmd]))
    assert peaks["acceleration"] > 0.1  # the check sees real motion
    # on the path, never backwards along it
    s = path_positions(robot, plan, res.log_cmd)
    assert np.all(np.diff(s) >= -2e-4)
    # held: one command for the whole pause, and the servos at rest there
    same = np.all(np.abs(np.diff(res.log_cmd, axis=0)) < 1e-12, axis=1)
    runs = np.flatnonzero(np.diff(np.concatenate([[0], same.astype(int), [0]])))
    longest = int(np.max(runs[1::2] - runs[::2]))
    assert longest * dt >= 0.9  # paused from ~0.55 s (after the deceleration) to 1.5 s
    start = int(runs[::2][np.argmax(runs[1::2] - runs[::2])])
    held_cmd = res.log_cmd[start]
    meas_late = res.log_meas[start + longest - 5: start + longest]
    assert np.max(np.abs(meas_late - held_cmd)) < robot.executor.settle_tolerance
    assert np.ptp(meas_late, axis=0).max() < 1e-3
    assert 0.0 < s[start] < plan.duration - 0.2  # held partway, not at the end
    # reported: paused while held, the plan time standing still, elapsed time running on
    held_infos = [i for i in seen if i.paused and i.rate == 0.0]
    assert len(held_infos) >= 40
    assert len({round(i.t, 9) for i in held_infos}) == 1
    at_rest = [i for i in seen if i.rate == 0.0 and not i.stopping]
    assert res.stats.held_time == pytest.approx(len(at_rest) * dt)
    assert np.all(np.diff(res.log_elapsed) > 0)
    # arrived
    assert np.allclose(res.final[robot.executor.idx], GOAL[robot.executor.idx], atol=0.02)
    assert res.stats.elapsed > plan.duration + 1.0


@pytest.mark.parametrize("name", ["omx", "koch_follower"])
def test_other_arms_stay_within_their_limits(name: str) -> None:
    """Other limits (OMX: jerk 100 rad/s^3, a 5 m/s^3 prismatic finger), other servos."""
    with Robot.open(name, sim=True, speed=0.5, exit_policy=ExitPolicy.HOLD) as robot:
        q = robot.joints()
        step = np.zeros_like(q)
        step[:2] = [0.6, 0.2]
        plan = robot.plan_joints(np.clip(q + step, robot.arm.lower, robot.arm.upper))
        d = plan.duration
        events = {0.25 * d: robot.pause, d: robot.resume, d + 0.2: lambda: robot.set_speed(3.0)}
        res = robot.execute(plan, at_times(robot, events), record=True)
        peaks = assert_within_limits(robot, np.vstack([plan.start[robot.executor.idx],
                                                       res.log_cmd]))
        path_positions(robot, plan, res.log_cmd)
    assert res.stats.held_time > 0.3
    assert peaks["jerk"] > 0.5  # the changes go as fast as the limits allow


def test_speed_half_doubles_the_duration(robot: Robot) -> None:
    plan = robot.plan_joints(GOAL)
    assert robot.set_speed(0.5) == 0.5
    res = robot.execute(plan, record=True)
    dt = 1.0 / robot.executor.rate_hz
    assert res.stats.elapsed == pytest.approx(2 * plan.duration, abs=1.5 * dt)
    assert_within_limits(robot, res.log_cmd)
    path_positions(robot, plan, res.log_cmd)
    # the same override during the motion: the rest of it takes twice as long
    robot.set_speed(1.0)
    back = robot.plan_joints(np.zeros(6))
    res2 = robot.execute(back, at_times(robot, {0.4: lambda: robot.set_speed(0.5)}),
                         record=True)
    s_at = 0.4
    expected = s_at + 2 * (back.duration - s_at)
    assert res2.stats.elapsed == pytest.approx(expected, abs=0.25)
    assert res2.stats.elapsed > back.duration + 0.5
    assert_within_limits(robot, np.vstack([back.start[robot.executor.idx], res2.log_cmd]))
    path_positions(robot, back, res2.log_cmd)


def test_speed_above_the_limits_is_capped_and_reported(robot: Robot,
                                                       caplog: pytest.LogCaptureFixture) -> None:
    plan = robot.plan_joints(GOAL)  # at half the joint limits
    fastest = plan_joint_move(plan.start, GOAL, robot.limits, 1.0)  # at the limits
    states = []
    robot.set_speed(5.0)
    with caplog.at_level(logging.WARNING, logger="armctl.robot.motion_control"):
        res = robot.execute(plan, lambda info: states.append(robot.control.state()),
                            record=True)
    st = states[len(states) // 2]
    assert st.capped and st.speed == 5.0
    assert st.cap == pytest.approx(2.0, rel=0.01)  # half the limits: twice as fast at most
    assert st.applied == st.cap
    assert "capped at x2.00" in caplog.text
    # as fast as a plan made at the limits, never faster
    dt = 1.0 / robot.executor.rate_hz
    assert res.stats.elapsed == pytest.approx(fastest.duration, abs=1.5 * dt)
    peaks = assert_within_limits(robot, res.log_cmd)
    assert max(peaks.values()) > 0.9  # at a limit: the cap is not needlessly low
    idle = robot.control.state()
    assert idle.moving is False and idle.cap is None and idle.rate is None
    assert robot.control.speed == 5.0  # kept for later motions


def test_stop_while_paused_holds_as_motion_stopped(robot: Robot) -> None:
    plan = robot.plan_joints(GOAL)
    with pytest.raises(MotionStopped) as err:
        robot.execute(plan, at_times(robot, {0.3: robot.pause, 1.0: robot.control.stop}),
                      record=True)
    assert err.value.reason is StopReason.USER
    assert "MotionControl.stop" in str(err.value)
    _, cmds, _ = robot.executor.last_log
    cmds_a = np.array(cmds)
    assert_within_limits(robot, np.vstack([plan.start[robot.executor.idx], cmds_a]))
    # from 0.7 s (held) to the end no command changed: the stop from rest held where it was
    k = int(0.7 * robot.executor.rate_hz)
    assert np.max(np.abs(cmds_a[k:] - cmds_a[k]), initial=0.0) < 1e-12
    assert np.allclose(np.asarray(err.value.held)[robot.executor.idx], cmds_a[-1])
    assert 0.2 < err.value.time < plan.duration - 0.2


def test_a_servo_alarm_while_paused_stops_the_held_motion(robot: Robot) -> None:
    """The loop keeps reading the servos while paused: a fault still ends the motion."""
    from armctl.servo.sim.faults import Alarm, HardwareAlarm

    sim = robot.bus.simulator  # type: ignore[attr-defined]
    plan = robot.plan_joints(GOAL)
    seen: list[CycleInfo] = []

    def alarm() -> None:
        assert seen[-1].paused and seen[-1].rate == 0.0  # held when the fault comes
        sim.inject(HardwareAlarm(3, Alarm.OVERLOAD))

    try:
        with pytest.raises(MotionStopped) as err:
            robot.execute(plan, at_times(robot, {0.3: robot.pause, 1.0: alarm}, seen))
    finally:
        sim.clear_faults()
    assert err.value.reason is StopReason.SERVO_ERROR
    assert err.value.servo_id == 3 and "overload" in str(err.value)
    assert 0.2 < err.value.time < plan.duration - 0.2  # where it was held


def test_stop_during_a_speed_change_decelerates_within_the_limits(robot: Robot) -> None:
    plan = robot.plan_joints(GOAL)
    events = {0.15: lambda: robot.set_speed(1.8), 0.3: robot.control.stop}
    with pytest.raises(MotionStopped):
        robot.execute(plan, at_times(robot, events), record=True)
    cmds = np.array(robot.executor.last_log[1])
    assert_within_limits(robot, np.vstack([plan.start[robot.executor.idx], cmds]))
    dt = 1.0 / robot.executor.rate_hz
    assert np.max(np.abs(cmds[-1] - cmds[-2])) / dt < 0.01  # [rad/s]: at rest at the end


def test_a_motion_started_paused_holds_until_resumed(robot: Robot) -> None:
    plan = robot.plan_joints(GOAL)
    robot.pause()
    res = robot.execute(plan, at_times(robot, {0.5: robot.resume}), record=True)
    k = int(0.45 * robot.executor.rate_hz)
    idx = robot.executor.idx
    assert np.max(np.abs(res.log_cmd[:k] - plan.start[idx])) < 1e-12
    assert_within_limits(robot, res.log_cmd)
    assert res.stats.elapsed > plan.duration + 0.4


def test_a_pause_too_late_to_stop_lets_the_plan_finish(robot: Robot) -> None:
    """A plan at the joint limits brakes at the acceleration limit: no pause fits then."""
    plan = robot.plan_joints(GOAL, speed=1.0)
    braking = 0.8 * plan.duration
    # (a resume long after the end keeps a wrong pause from holding forever)
    res = robot.execute(plan, at_times(robot, {braking: robot.pause, 5.0: robot.resume}),
                        record=True)
    dt = 1.0 / robot.executor.rate_hz
    assert res.stats.elapsed == pytest.approx(plan.duration, abs=1.5 * dt)
    assert res.stats.held_time == 0.0
    assert robot.control.paused  # still paused: the next motion starts held
    assert_within_limits(robot, res.log_cmd)


def test_cap_of_a_half_speed_plan_is_two() -> None:
    from armctl.arm import load_arm
    from armctl.motion import MotionLimits

    arm = load_arm("so101")
    lim = MotionLimits.from_model(arm)
    for speed in (0.5, 0.25):
        plan = plan_joint_move(np.zeros(6), GOAL, lim, speed)
        assert PlanTable.of(plan.trajectory, lim).cap == pytest.approx(1 / speed, rel=0.01)
    at_limits = plan_joint_move(np.zeros(6), GOAL, lim, 1.0)
    assert PlanTable.of(at_limits.trajectory, lim).cap == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize(("r0", "a0", "r1"), [(1.0, 0.0, 0.0), (0.0, 0.0, 1.3), (0.7, 3.0, 0.0),
                                              (0.4, -2.0, 1.5), (1.2, 4.0, 0.2),
                                              (0.5, 0.0, 0.5), (0.5, 1.0, 0.5)])
def test_rate_change_pieces_reach_the_target_smoothly(r0: float, a0: float, r1: float) -> None:
    """Integrated step by step (10 us): ends at (r1, 0), r' bounded, |r''| <= J."""
    amax, jmax = 4.0, 40.0
    pieces = rate_change_pieces(r0, a0, r1, amax, jmax)
    h = 1e-5
    r, a = r0, a0
    for dur, jerk in pieces:
        assert abs(jerk) <= jmax * (1 + 1e-12)
        for _ in range(round(dur / h)):
            r += a * h + jerk * h * h / 2
            a += jerk * h
            assert abs(a) <= max(amax, abs(a0)) * (1 + 1e-6)
        rest = dur - round(dur / h) * h
        r += a * rest + jerk * rest**2 / 2
        a += jerk * rest
    assert r == pytest.approx(r1, abs=1e-5)
    assert a == pytest.approx(0.0, abs=1e-5)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 0.0, -1.0, 0.001, 1e6, "fast",
                                 None, True])
def test_bad_speed_values_are_refused(bad: object) -> None:
    control = MotionControl()
    with pytest.raises(InputError) as err:
        control.set_speed(bad)  # type: ignore[arg-type]
    assert "use a factor from 0.01 to 100" in str(err.value)
    assert control.speed == 1.0


def test_bad_speed_on_the_robot_is_refused_and_changes_nothing(robot: Robot) -> None:
    robot.set_speed(0.8)
    with pytest.raises(InputError, match="must be positive"):
        robot.set_speed(-0.5)
    assert robot.control.speed == 0.8
    with pytest.raises(InputError):
        MotionControl(speed=math.nan)


def test_stop_without_a_motion_does_nothing() -> None:
    control = MotionControl()
    assert control.stop() is False
    st = control.state()
    # idle: no rate and no cap to report (None, not NaN: a JSON-safe "nothing runs")
    assert not st.moving and st.rate is None and st.cap is None and not st.held
    assert st.applied == st.speed and not st.capped


@pytest.mark.realtime
def test_another_thread_steers_a_real_time_motion() -> None:
    """Wall-clock time: a thread pauses, changes the speed and resumes during a short move."""
    with Robot.open("so101", sim=True, speed=0.8, exit_policy=ExitPolicy.HOLD) as robot:
        plan = robot.plan_joints(GOAL)
        calls: list[tuple[str, float]] = []
        states = []
        started = threading.Event()

        def steer() -> None:
            if not started.wait(10.0):  # timed from the motion's first cycle
                return
            t0 = time.perf_counter()
            for at, name, call in ((0.15, "pause", robot.pause),
                                   (0.25, "speed", lambda: robot.set_speed(0.6)),
                                   (0.45, "resume", robot.resume),
                                   (0.5, "speed", lambda: robot.set_speed(3.0)),
                                   (0.55, "speed", lambda: robot.set_speed(0.7))):
                time.sleep(max(0.0, t0 + at - time.perf_counter()))
                call()
                calls.append((name, time.perf_counter() - t0))
                states.append(robot.control.state())

        thread = threading.Thread(target=steer)
        thread.start()
        try:
            res = robot.execute(plan, lambda info: started.set(), record=True)
        finally:
            started.set()
            thread.join(5.0)
    assert [c[0] for c in calls] == ["pause", "speed", "resume", "speed", "speed"]
    assert all(s.moving for s in states)  # every call landed during the motion
    assert states[0].paused and not states[2].paused
    assert np.allclose(res.final[robot.executor.idx], GOAL[robot.executor.idx], atol=0.02)
    path_positions(robot, plan, res.log_cmd)
    held = res.stats.held_time
    assert res.stats.elapsed > plan.duration + held
    # overruns in wall-clock time skip cycles: the velocity over each real gap stays bounded
    gaps = np.diff(res.log_elapsed)[:, None]
    v = np.diff(res.log_cmd, axis=0) / gaps
    assert np.all(np.abs(v) <= robot.limits.velocity[robot.executor.idx] * (1 + TOL))
