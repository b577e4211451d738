"""The bundled figure through the arm tools: IK of a hand and a foot at once, render, info, bus.

IK answers are checked by an independent chain of matrices built from the arm file (scipy
rotations), not by armctl's FK.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from chain_truth import by_name, chain_poses
from PIL import Image
from scipy.spatial.transform import Rotation

import armctl
from armctl.cli import main
from armctl.config import bundled_configs_dir
from armctl.ik import IKOptions, PoseGoal, PositionGoal

#: A budget that does not depend on the machine's speed (restarts count, not seconds).
BUDGET = IKOptions(time_limit=60.0, restarts=20, seed=0)

FIGURE = bundled_configs_dir() / "figure.yaml"
WALK = Path(__file__).parent.parent.parent / "docs" / "examples" / "figure_walk.yaml"


def _frame_poses(arm: armctl.Arm, q: np.ndarray) -> dict[str, np.ndarray]:
    """Pose of every link and named frame of the bundled figure, by the independent chain."""
    return chain_poses(yaml.safe_load(FIGURE.read_text(encoding="utf-8")), by_name(arm, q))


def test_hand_and_feet_at_once_within_the_joint_limits():
    arm = armctl.load_arm("figure")
    q0 = arm.named_pose("stand")
    start = _frame_poses(arm, q0)
    hand = np.array([0.40, -0.25, 1.15])  # the right hand reaches forward at chest height
    step = start["left_sole"].copy()  # the left foot steps forward and up onto a stair
    step[0, 3] += 0.25
    step[2, 3] += 0.10
    goals = [PositionGoal(hand, frame="right_palm"), PoseGoal(step, frame="left_sole"),
             PoseGoal(start["right_sole"], frame="right_sole")]  # the right foot stays
    result = arm.ik(goals, q0, "dls", options=BUDGET)
    assert result.success, result.status
    assert arm.within_limits(result.q)
    assert _limits_hold(arm, result.q)
    got = _frame_poses(arm, result.q)
    assert np.linalg.norm(got["right_palm"][:3, 3] - hand) < 1e-5  # the goals' tolerance
    np.testing.assert_allclose(got["left_sole"], step, atol=1e-5)
    np.testing.assert_allclose(got["right_sole"], start["right_sole"], atol=1e-5)
    # the goal is out of reach without bending the knee: the answer uses the leg
    assert result.q[arm.q_index("left_knee")][0] > 0.2


def _limits_hold(arm: armctl.Arm, q: np.ndarray) -> bool:
    """Every joint inside its limits, checked apart from armctl: the swing of a ball joint is
    the angle of its bone from rest (scipy), its twist the turn left about the bone."""
    for j in arm.spec.actuated_joints:
        v = q[arm.q_index(j.name)]
        if j.type.value != "ball":
            if not j.limits.lower - 1e-9 <= v[0] <= j.limits.upper + 1e-9:
                return False
            continue
        rot = Rotation.from_quat([v[1], v[2], v[3], v[0]])
        axis = np.asarray(j.axis, float)
        moved = rot.apply(axis)
        swing = np.arccos(np.clip(moved @ axis, -1.0, 1.0))
        if swing > j.swing + 1e-9:
            return False
        # undo the swing (the shortest turn taking the axis back): what is left turns about it
        c = np.cross(moved, axis)
        back = (Rotation.from_rotvec(c / np.linalg.norm(c) * swing) if np.linalg.norm(c) > 1e-12
                else Rotation.identity())
        twist = (back * rot).as_rotvec() @ axis
        if not j.limits.lower - 1e-9 <= twist <= j.limits.upper + 1e-9:
            return False
    return True


def test_the_arm_passes_where_three_axes_locked():
    """The right hand straight forward at shoulder height, then overhead and down the side:
    the ball shoulder reaches each (three x-z-y axes lock at the first, middle angle 90 deg),
    and the answers hold in the independent chain."""
    arm = armctl.load_arm("figure")
    q0 = arm.named_pose("stand")
    shoulder = _frame_poses(arm, q0)["right_upper_arm"][:3, 3]
    reach = 0.326 + 0.256 + 0.08  # upper arm + forearm + palm [m]
    for direction in ([1, 0, 0], [0, 0, 1], [0.7, -0.7, 0]):
        target = shoulder + reach * 0.97 * np.asarray(direction) / np.linalg.norm(direction)
        result = arm.ik([PositionGoal(target, frame="right_palm")], q0, "dls", options=BUDGET)
        assert result.success, (direction, result.status)
        assert _limits_hold(arm, result.q)
        got = _frame_poses(arm, result.q)["right_palm"][:3, 3]
        assert np.linalg.norm(got - target) < 1e-5


def test_a_foot_below_the_floor_reach_is_not_reported_as_reached():
    arm = armctl.load_arm("figure")
    q0 = arm.named_pose("stand")
    far = np.array([0.0, 0.09, -0.5])  # half a metre under the floor: the leg is too short
    result = arm.ik([PositionGoal(far, frame="left_sole")], q0, "dls",
                    options=IKOptions(time_limit=60.0, restarts=3, seed=0))
    assert not result.success


def test_info_render_and_walk(tmp_path: Path, capsys: pytest.CaptureFixture[str]):
    assert main(["info", "figure", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    text = json.dumps(info)
    for frame in ("right_palm", "left_palm", "right_sole", "left_sole"):
        assert frame in text
    png = tmp_path / "stand.png"
    assert main(["render", "figure", "--pose", "stand", "-o", str(png), "--size", "2",
                 "--dpi", "40"]) == 0
    assert Image.open(png).size == (80, 80)
    gif = tmp_path / "walk.gif"
    assert main(["render", "figure", "--pose", "stand", "--keyframes", str(WALK), "-o",
                 str(gif), "--fps", "3", "--size", "2", "--dpi", "30"]) == 0
    frames = Image.open(gif)
    assert frames.n_frames >= 8
    capsys.readouterr()


def test_a_motion_verb_on_the_bus_refuses_clearly(capsys: pytest.CaptureFixture[str]):
    tpose = armctl.load_arm("figure").named_pose("tpose")
    code = main(["move-joints", "figure", *(f"{x:g}" for x in tpose)])
    err = capsys.readouterr().err
    assert code == 2
    assert "cannot be moved by servos" in err and "Traceback" not in err
    assert "armctl render figure --keyframes" in err
    for verb in (["home", "figure"], ["park", "figure"], ["jog", "figure"],
                 ["move-to-pose", "figure", "--xyz", "0.3", "0", "1.2"]):
        assert main(verb) == 2
        err = capsys.readouterr().err
        assert "multi-DOF joint(s) left_shoulder" in err and "Traceback" not in err, verb
    for verb in (["status", "figure", "--once"], ["calibrate", "figure"]):
        assert main(verb) == 2
        err = capsys.readouterr().err
        assert "draw its motions instead" in err and "--sim" not in err, verb
    code = main(["play", str(WALK), "figure"])
    err = capsys.readouterr().err
    assert code == 2 and "no 'bus:' section" in err and "Traceback" not in err
