"""Keyframes that repeat the one before (a pause in a recording) are planned through."""

from __future__ import annotations

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.motion import MotionLimits
from armctl.motion.interpolate import Interpolation, plan_run


@pytest.mark.parametrize("kind", [Interpolation.CUBIC, Interpolation.MIN_JERK])
def test_repeats_pass_at_the_same_time(kind: Interpolation) -> None:
    limits = MotionLimits.from_model(load_arm("so101"))
    a = np.zeros(6)
    b = np.array([0.3, -0.2, 0.4, 0.1, 0.0, 0.2])
    c = np.array([-0.2, 0.1, 0.2, -0.3, 0.4, 0.1])
    q = np.array([a, a, b, b, b, c])
    traj, knots = plan_run(q, limits, kind)
    assert knots.shape == (6,)
    assert knots[0] == knots[1] and knots[2] == knots[3] == knots[4]
    assert np.all(np.diff(knots[[1, 4, 5]]) > 0)
    for t, want in zip(knots, q, strict=True):
        got, _, _ = traj.sample_many(np.array([t]))
        assert np.allclose(got[0], want, atol=1e-9)


def test_all_repeats_plan_a_run_that_does_not_move() -> None:
    limits = MotionLimits.from_model(load_arm("so101"))
    q = np.zeros((5, 6))
    traj, knots = plan_run(q, limits, Interpolation.CUBIC)
    ts = np.linspace(0.0, traj.duration, 7)
    got, _, _ = traj.sample_many(ts)
    assert np.allclose(got, 0.0) and knots.shape == (5,)
