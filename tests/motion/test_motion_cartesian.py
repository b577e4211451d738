"""Straight-line moves: the tool stays on the line; failures say where along the path."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.ik import PoseGoal, PositionGoal
from armctl.motion import MotionLimits, PathError, check_trajectory
from armctl.motion.cartesian import interpolate_goal, plan_line
from armctl.spatial import make_transform, pose_error, rpy_to_matrix

ARM3G = Path(__file__).parent / "data" / "arm3g.yaml"  # planar 3R + prismatic gripper


@pytest.fixture(scope="module")
def arm3g() -> Arm:
    return load_arm(ARM3G)


@pytest.fixture(scope="module")
def limits3g(arm3g: Arm) -> MotionLimits:
    return MotionLimits.from_model(arm3g)


def test_line_is_followed_with_continuous_joints(arm3g: Arm, limits3g: MotionLimits) -> None:
    q0 = np.array([0.3, 0.8, 0.6, 0.0])
    p0 = arm3g.fk(q0)[:3, 3]
    goal = PositionGoal(p0 + np.array([0.1, -0.12, 0.0]))
    plan = plan_line(arm3g, q0, goal, limits3g, speed=0.8)
    check_trajectory(plan.trajectory, limits3g)
    ts = np.linspace(0.0, plan.duration, 500)
    q, _, _ = plan.trajectory.sample_many(ts)
    pts = arm3g.fk_batch(q)[:, :3, 3]
    d = goal.position - p0
    u = (pts - p0) @ d / (d @ d)
    off = np.linalg.norm(pts - (p0 + u[:, None] * d), axis=1)
    assert np.max(off) < 1e-3 and np.all(np.diff(u) >= -1e-9)  # on the line, never backwards
    assert np.linalg.norm(pts[-1] - goal.position) < 1e-4
    assert np.max(np.abs(np.diff(q, axis=0))) < 0.05  # no jumps between 500 samples
    assert np.allclose(q[:, 3], 0.0)  # the gripper does not move


def test_orientation_is_slerped() -> None:
    start = make_transform(rpy_to_matrix([0.0, 0.0, 0.0]), [0.0, 0.0, 0.0])
    end = make_transform(rpy_to_matrix([0.0, 0.0, 1.0]), [1.0, 0.0, 0.0])
    mid = interpolate_goal(start, PoseGoal(end), 0.5)
    assert isinstance(mid, PoseGoal)
    assert np.allclose(pose_error(start, mid.pose), [0.5, 0, 0, 0, 0, 0.5], atol=1e-12)


def test_out_of_reach_line_reports_the_fraction(arm3g: Arm, limits3g: MotionLimits) -> None:
    q0 = np.array([0.0, 0.5, 0.5, 0.0])
    p0 = arm3g.fk(q0)[:3, 3]
    # reach is 0.6 m: the line towards x = 1.0 leaves the workspace part of the way
    with pytest.raises(PathError) as info:
        plan_line(arm3g, q0, PositionGoal([1.0, p0[1], 0.0]), limits3g)
    err = info.value
    d_total = 1.0 - p0[0]
    reach_frac = (np.sqrt(0.6**2 - p0[1] ** 2) - p0[0]) / d_total
    assert 0.0 < err.fraction <= reach_frac + 0.02
    assert "planned to" in str(err) and "nothing was moved" in str(err)
