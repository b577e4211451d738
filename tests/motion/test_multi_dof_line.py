"""Straight-line tool moves of an arm with ball and universal joints.

Independent truth: the tool's pose from a chain of matrices built with scipy from the arm file
(not armctl's kinematics) at dense samples of the timed trajectory, its distance from the line,
its orientation against scipy's Slerp of the start and goal orientations, a ball joint's swing
and twist and its angular speed from scipy rotations, every rate by finite differences.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from chain_truth import by_name, chain_poses
from scipy.spatial.transform import Rotation, Slerp

import armctl
from armctl.cli import main
from armctl.ik import PoseGoal, PositionGoal
from armctl.motion import MotionLimits, PathError
from armctl.motion.cartesian import LineOptions, SpherePathTrajectory, plan_line
from armctl.render.motions import plan_straight_line

BALL_ARM = Path(__file__).resolve().parents[1] / "data" / "ball_arm.yaml"
DT = 0.004


@pytest.fixture(scope="module")
def arm() -> armctl.Arm:
    return armctl.load_arm(BALL_ARM)


@pytest.fixture(scope="module")
def doc() -> dict:
    return yaml.safe_load(BALL_ARM.read_text())


def tool_poses(doc: dict, arm: armctl.Arm, qs: np.ndarray) -> np.ndarray:
    """The tool's poses ``(n, 4, 4)``: the arm file's chain of joints, multiplied with scipy."""
    return np.array([chain_poses(doc, by_name(arm, q))[doc["tool"]] for q in qs])


def _samples(plan: object) -> tuple[np.ndarray, np.ndarray]:
    traj = plan.trajectory  # type: ignore[attr-defined]
    ts = np.arange(0.0, traj.duration, DT)
    ts = np.append(ts, traj.duration)
    return ts, traj.sample_many(ts)[0]


def _check_ball(arm: armctl.Arm, doc: dict, qs: np.ndarray, ts: np.ndarray) -> None:
    """Unit quaternions, inside the swing cone and twist range, speed under the limit."""
    sh = arm.q_index("shoulder")
    quats = qs[:, sh]
    assert np.allclose(np.linalg.norm(quats, axis=1), 1.0, atol=1e-9)
    rot = Rotation.from_quat(np.roll(quats, -1, axis=1))
    axis = np.array([0.0, 0.0, 1.0])
    moved = rot.apply(axis)
    swing = np.arccos(np.clip(moved @ axis, -1.0, 1.0))
    assert swing.max() <= math.radians(120.0) + 1e-9
    # twist: what is left of the rotation after the shortest swing that moves the axis there
    swing_rot = Rotation.from_rotvec(np.cross(axis, moved) / np.maximum(
        np.linalg.norm(np.cross(axis, moved), axis=1), 1e-12)[:, None] * swing[:, None])
    twist = (swing_rot.inv() * rot).as_rotvec() @ axis
    assert np.abs(twist).max() <= math.radians(150.0) + 1e-9
    # angular speed by differences of the sampled rotations, against the velocity limit (2)
    step = (rot[:-1].inv() * rot[1:]).magnitude() / np.diff(ts)
    assert step.max() <= 2.0 * 1.03


def _distance_from_line(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray,
                                                                              np.ndarray]:
    d = b - a
    u = np.clip((p - a) @ d / (d @ d), 0.0, 1.0)
    return np.linalg.norm(p - (a + u[:, None] * d), axis=1), u


def test_a_position_line_keeps_the_tool_on_the_line(arm: armctl.Arm, doc: dict) -> None:
    q0 = arm.named_pose("home")
    p0 = tool_poses(doc, arm, q0[None])[0][:3, 3]
    target = p0 + np.array([-0.1, 0.12, -0.15])
    limits = MotionLimits.from_model(arm)
    plan = plan_line(arm, q0, PositionGoal(target), limits)
    assert isinstance(plan.trajectory, SpherePathTrajectory)
    ts, qs = _samples(plan)
    poses = tool_poses(doc, arm, qs)
    dist, u = _distance_from_line(poses[:, :3, 3], p0, target)
    assert dist.max() <= LineOptions().path_tolerance + 1e-6
    assert plan.extra["line_deviation"] <= LineOptions().path_tolerance
    # it starts where the arm is, ends at the target, and goes one way along the line
    assert np.allclose(qs[0], q0, atol=1e-12)
    assert np.linalg.norm(poses[-1][:3, 3] - target) < 1e-4
    assert np.all(np.diff(u) >= -1e-6)
    _check_ball(arm, doc, qs, ts)
    # the scalar coordinates inside their limits and under their velocity limits
    sc = [i for i in range(arm.nq) if not arm.q_index("shoulder").start <= i < 4]
    assert np.all(qs[:, sc] >= arm.lower[sc] - 1e-9) and np.all(qs[:, sc] <= arm.upper[sc] + 1e-9)
    rates = np.abs(np.diff(qs[:, sc], axis=0)) / np.diff(ts)[:, None]
    vel = limits.velocity[[arm.v_index("elbow").start, *range(arm.v_index("wrist").start,
                                                             arm.v_index("wrist").stop)]]
    assert np.all(rates <= vel * 1.03)


def test_a_pose_line_slerps_the_orientation(arm: armctl.Arm, doc: dict) -> None:
    q0 = arm.named_pose("home")
    start = tool_poses(doc, arm, q0[None])[0]
    goal = start.copy()
    goal[:3, 3] += [-0.1, 0.1, -0.1]
    goal[:3, :3] = Rotation.from_rotvec([0.3, 0.2, -0.4]).as_matrix() @ start[:3, :3]
    plan = plan_line(arm, q0, PoseGoal(goal), MotionLimits.from_model(arm))
    ts, qs = _samples(plan)
    poses = tool_poses(doc, arm, qs)
    dist, u = _distance_from_line(poses[:, :3, 3], start[:3, 3], goal[:3, 3])
    assert dist.max() <= LineOptions().path_tolerance + 1e-6
    # the orientation where the tool is along the line is scipy's slerp there
    slerp = Slerp([0.0, 1.0], Rotation.from_matrix([start[:3, :3], goal[:3, :3]]))
    err = (slerp(u).inv() * Rotation.from_matrix(poses[:, :3, :3])).magnitude()
    assert err.max() < math.radians(0.5)
    assert err[-1] < 1e-3 and err[0] < 1e-9
    _check_ball(arm, doc, qs, ts)


def test_tcp_speed_limits_hold_on_such_an_arm(arm: armctl.Arm, doc: dict) -> None:
    q0 = arm.named_pose("home")
    p0 = tool_poses(doc, arm, q0[None])[0][:3, 3]
    target = p0 + np.array([-0.1, 0.12, -0.15])
    plan = plan_line(arm, q0, PositionGoal(target), MotionLimits.from_model(arm),
                     options=LineOptions(tcp_speed=0.05))
    ts, qs = _samples(plan)
    pts = tool_poses(doc, arm, qs)[:, :3, 3]
    speed = np.linalg.norm(np.diff(pts, axis=0), axis=1) / np.diff(ts)
    assert 0.045 < speed.max() <= 0.05 * 1.01


def test_a_line_that_cannot_be_kept_is_refused(arm: armctl.Arm, doc: dict) -> None:
    q0 = arm.named_pose("home")
    p0 = tool_poses(doc, arm, q0[None])[0][:3, 3]
    limits = MotionLimits.from_model(arm)
    # a tolerance no joint path between samples keeps
    with pytest.raises(PathError, match="leave the line"):
        plan_line(arm, q0, PositionGoal(p0 + np.array([0.0, 0.03, -0.03])), limits,
                  options=LineOptions(path_tolerance=1e-9))
    # out of reach: planned only part of the way
    with pytest.raises(PathError, match="no IK solution near the line"):
        plan_line(arm, q0, PositionGoal([1.0, 0.0, 0.3]), limits)


def test_render_draws_the_line_of_such_an_arm(arm: armctl.Arm, doc: dict, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    q0 = arm.named_pose("home")
    target = tool_poses(doc, arm, q0[None])[0][:3, 3] + [-0.1, 0.1, -0.15]
    planned = plan_straight_line(arm, q0, np.vstack([np.hstack([np.eye(3), target[:, None]]),
                                                     [0, 0, 0, 1]]), oriented=False)
    assert planned.samples.shape[1] == arm.nq
    dist, _ = _distance_from_line(tool_poses(doc, arm, planned.samples)[:, :3, 3], *planned.line)
    assert dist.max() < 1e-4  # the IK samples themselves lie on the line
    out = tmp_path / "line.png"
    code = main(["render", str(BALL_ARM), "--pose", "home", "--path", "--target-xyz",
                 *(f"{v:.6f}" for v in target), "-o", str(out), "--size", "2", "--dpi", "40"])
    assert code == 0 and out.is_file()
    assert "IK samples" in capsys.readouterr().out
