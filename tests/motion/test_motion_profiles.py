"""Joint moves: synchronisation, time optimality, speed factor, controlled stops."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.errors import InputError
from armctl.motion import LimitViolation, MotionLimits, check_trajectory, plan_joint_move
from armctl.motion.profiles import min_jerk_duration, ruckig_move, stop_trajectory


@pytest.fixture(scope="module")
def limits3g() -> MotionLimits:
    return MotionLimits.from_model(load_arm(Path(__file__).parent / "data" / "arm3g.yaml"))


def _limits(n: int, v: float = 1.0, a: float = 2.0, j: float = np.inf) -> MotionLimits:
    names = tuple(f"j{i}" for i in range(n))
    return MotionLimits(names, np.full(n, -3.0), np.full(n, 3.0), np.full(n, v), np.full(n, a),
                        np.full(n, j))


def test_single_joint_trapezoid_is_time_optimal() -> None:
    # Distance 1, v 1, a 2, unbounded jerk: 0.5 s ramps + 0.5 s cruise = 1.5 s (textbook).
    traj = ruckig_move([0.0], [1.0], _limits(1))
    assert traj.duration == pytest.approx(1.5, abs=1e-9)
    q, qd, _ = traj.sample(0.75)
    assert q[0] == pytest.approx(0.5, abs=1e-9)
    assert qd[0] == pytest.approx(1.0, abs=1e-9)


def test_joints_are_synchronised_on_a_straight_line() -> None:
    q0, q1 = np.array([0.0, 0.5, -1.0]), np.array([1.2, -0.3, -0.9])
    traj = ruckig_move(q0, q1, _limits(3, j=50.0))
    ts = np.linspace(0.0, traj.duration, 200)
    q, qd, _ = traj.sample_many(ts)
    direction = (q1 - q0) / np.linalg.norm(q1 - q0)
    off_line = (q - q0) - ((q - q0) @ direction)[:, None] * direction
    assert np.max(np.abs(off_line)) < 1e-9
    # every joint is still moving just before the end and stops exactly at it
    assert np.all(np.abs(traj.sample(traj.duration * 0.98)[1]) > 0)
    assert np.allclose(traj.sample(traj.duration)[0], q1, atol=1e-12)
    assert np.allclose(qd[-1], 0.0, atol=1e-12)
    # the slowest joint alone would take exactly as long (time-optimal synchronisation)
    alone = ruckig_move([0.0], [1.2], _limits(1, j=50.0)).duration
    assert traj.duration == pytest.approx(alone, rel=1e-9)


def test_speed_factor_scales_time(limits3g: MotionLimits) -> None:
    q0, q1 = np.zeros(4), np.array([1.0, -1.0, 0.5, 0.02])
    full = plan_joint_move(q0, q1, limits3g, 1.0)
    half = plan_joint_move(q0, q1, limits3g, 0.5)
    assert half.duration == pytest.approx(2.0 * full.duration, rel=1e-6)
    with pytest.raises(InputError, match="speed factor"):
        plan_joint_move(q0, q1, limits3g, 1.5)


def test_goal_outside_limits_is_refused(limits3g: MotionLimits) -> None:
    with pytest.raises(LimitViolation, match=r"'j3'.*nothing was moved"):
        plan_joint_move(np.zeros(4), [0.0, 0.0, 2.1, 0.0], limits3g)


def test_check_reports_joint_kind_and_time() -> None:
    lim = _limits(2)
    traj = ruckig_move([0.0, 0.0], [1.0, 0.5], _limits(2, v=2.0, a=4.0))
    with pytest.raises(LimitViolation) as info:
        check_trajectory(traj, lim)
    assert info.value.joint == "j0"
    assert info.value.kind in ("velocity", "acceleration")
    assert 0.0 <= info.value.time <= traj.duration


def test_check_uses_exact_extrema_of_overshooting_moves() -> None:
    # Moving at 1 rad/s at 0.9 with 1 rad/s^2 needs 0.5 rad to stop: the free Ruckig overshoots
    # the 1.0 limit (to 1.4) before coming back to 0.95, which sampling alone could miss.
    lim = MotionLimits(("j0",), np.array([-1.0]), np.array([1.0]), np.array([1.0]),
                       np.array([1.0]), np.array([np.inf]))
    traj = ruckig_move([0.9], [0.95], lim, v0=[1.0])
    with pytest.raises(LimitViolation, match="position"):
        check_trajectory(traj, lim, dt=10.0)  # two samples only: found by the exact extrema
    with pytest.raises(LimitViolation, match="position") as info:
        check_trajectory(traj, lim)
    assert info.value.value > 1.0


def test_stop_decelerates_within_limits() -> None:
    lim = _limits(3, v=2.0, a=4.0, j=40.0)
    stop = stop_trajectory([0.1, 0.2, 0.3], [1.5, -2.0, 0.5], [0.0, 1.0, 0.0], lim)
    ts = np.linspace(0.0, stop.duration, 400)
    _, qd, qdd = stop.sample_many(ts)
    assert np.allclose(qd[-1], 0.0, atol=1e-9) and np.allclose(qdd[-1], 0.0, atol=1e-9)
    assert np.all(np.abs(qd) <= lim.velocity + 1e-9)
    assert np.all(np.abs(qdd) <= lim.acceleration + 1e-9)
    # cannot stop faster than the acceleration limit allows for the fastest joint
    assert stop.duration >= 2.0 / 4.0


def test_min_jerk_duration_meets_limits() -> None:
    lim = _limits(2, v=1.0, a=2.0, j=20.0)
    d = np.array([0.8, -0.1])
    t = min_jerk_duration(d, lim)
    tau = np.linspace(0, 1, 2001)
    s_d = (30 * tau**2 - 60 * tau**3 + 30 * tau**4) / t
    s_dd = (60 * tau - 180 * tau**2 + 120 * tau**3) / t**2
    s_ddd = (60 - 360 * tau + 360 * tau**2) / t**3
    ratios = [np.max(np.abs(s_d)) * 0.8 / 1.0, np.max(np.abs(s_dd)) * 0.8 / 2.0,
              np.max(np.abs(s_ddd)) * 0.8 / 20.0]
    assert max(ratios) == pytest.approx(1.0, abs=1e-3)
