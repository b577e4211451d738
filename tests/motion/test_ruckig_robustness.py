"""Ruckig on ordinary moves: every move on a coarse grid plans, and failures are clear errors.

Round joint values and speed factors put some moves exactly on the border between two of
Ruckig's profile shapes (e.g. a distance of exactly 2 a^3 / j^2 from rest), where ruckig 0.19
fails by rounding ("error in step 1"); the planner must still plan them, inside the limits.
"""

from __future__ import annotations

import numpy as np
import pytest
import ruckig

from armctl.arm import load_arm
from armctl.cli import main
from armctl.errors import InputError, PlanningError
from armctl.motion import MotionLimits, ruckig_move, stop_trajectory
from armctl.motion.profiles import _calculate, _input
from armctl.motion.trajectory import RuckigTrajectory


@pytest.fixture(scope="module")
def so101_limits() -> MotionLimits:
    return MotionLimits.from_model(load_arm("so101"))


def _raw_ruckig_fails(q0: np.ndarray, q1: np.ndarray, limits: MotionLimits) -> bool:
    """Whether Ruckig itself, called once as the planner first calls it, fails."""
    inp = _input(limits, q0, None, None)
    inp.target_position = q1.tolist()
    inp.target_velocity = [0.0] * limits.dof
    inp.target_acceleration = [0.0] * limits.dof
    inp.synchronization = ruckig.Synchronization.Phase
    return not isinstance(_calculate(inp, limits.dof), RuckigTrajectory)


def test_the_reported_move_plans(so101_limits: MotionLimits) -> None:
    q1 = np.array([0.4, -0.3, 0.3, 0.2, 0.3, 0.0])
    limits = so101_limits.scaled(0.3)
    assert _raw_ruckig_fails(np.zeros(6), q1, limits)  # the case is one ruckig fails on
    traj = ruckig_move(np.zeros(6), q1, limits)
    np.testing.assert_allclose(traj.end, q1, atol=1e-9)
    t = np.linspace(0.0, traj.duration, 400)
    _, qd, qdd = traj.sample_many(t)
    assert np.all(np.abs(qd) <= limits.velocity * (1 + 1e-9))
    assert np.all(np.abs(qdd) <= limits.acceleration * (1 + 1e-9))


def test_the_reported_command_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-joints", "so101", "0.4", "-0.3", "0.3", "0.2", "0.3", "0", "--speed",
                 "0.3", "--dry-run"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "Traceback" not in out + err and "dry run: nothing moved" in out


def test_3000_random_grid_moves_all_plan(so101_limits: MotionLimits) -> None:
    """Start, goal (0.1 rad grid inside the limits) and speed factor (0.1 grid) at random."""
    rng = np.random.default_rng(12)
    lo = np.ceil(so101_limits.lower / 0.1) * 0.1
    hi = np.floor(so101_limits.upper / 0.1) * 0.1
    steps = np.round((hi - lo) / 0.1).astype(int)
    raw_failures = 0
    for _ in range(3000):
        q0 = np.round(lo + 0.1 * rng.integers(0, steps + 1), 10)
        q1 = np.round(lo + 0.1 * rng.integers(0, steps + 1), 10)
        limits = so101_limits.scaled(round(0.1 * int(rng.integers(1, 11)), 1))
        raw_failures += _raw_ruckig_fails(q0, q1, limits)
        traj = ruckig_move(q0, q1, limits)
        np.testing.assert_allclose(traj.start, q0, atol=1e-9)
        np.testing.assert_allclose(traj.end, q1, atol=1e-9)
        assert np.isfinite(traj.duration)
        if isinstance(traj, RuckigTrajectory):
            low, high = traj.position_extrema()
            assert np.all(low >= np.minimum(q0, q1) - 1e-9)  # rest to rest: no overshoot
            assert np.all(high <= np.maximum(q0, q1) + 1e-9)
    assert raw_failures > 20  # the grid does hit ruckig's failing inputs


def test_an_impossible_move_is_a_planning_error(so101_limits: MotionLimits) -> None:
    limits = so101_limits.scaled(0.5)
    too_fast = limits.velocity * 2.0  # a goal velocity beyond the limit: ruckig refuses it
    with pytest.raises(PlanningError, match="trajectory generator could not plan"):
        ruckig_move(np.zeros(6), np.full(6, 0.5), limits, v1=too_fast, straight=False)


def test_the_stop_falls_back_when_ruckig_fails(so101_limits: MotionLimits,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """RuckigError (an Exception, not a RuntimeError) gives the constant-deceleration stop."""

    class Failing:
        def __init__(self, dof: int):
            pass

        def calculate(self, inp: object, traj: object) -> None:
            raise ruckig.RuckigError("[ruckig] error in step 1, dof: 0 input:")

    monkeypatch.setattr(ruckig, "Ruckig", Failing)
    qd = np.array([0.5, -0.4, 0.3, 0.0, 0.1, 0.0])
    traj = stop_trajectory(np.zeros(6), qd, np.zeros(6), so101_limits)
    _, v_end, _ = traj.sample(traj.duration)
    np.testing.assert_allclose(v_end, 0.0, atol=1e-9)
    _, _, a = traj.sample_many(np.linspace(0.0, traj.duration, 50))
    assert np.all(np.abs(a) <= so101_limits.acceleration * (1 + 1e-9))
    with pytest.raises(PlanningError, match="step 1"):
        ruckig_move(np.zeros(6), np.full(6, 0.4), so101_limits)


@pytest.mark.parametrize("speed", [0.0, -0.5, float("nan"), float("inf"), 1e-6, 1.5])
def test_bad_speed_factors_are_refused_before_planning(so101_limits: MotionLimits,
                                                       speed: float) -> None:
    with pytest.raises(InputError, match=r"0\.01 to 1"):
        so101_limits.scaled(speed)
