"""Keyframe files of arms with ball and universal joints: values, units, errors, round trip.

Rotations written as rpy or rotation vectors are checked against scipy.spatial.transform.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy.spatial.transform import Rotation

import armctl
from armctl.cli import main
from armctl.errors import ConfigError
from armctl.motion import load_keyframes, parse_keyframes, save_keyframes
from armctl.motion.keyframes import AngleUnit

BALL_ARM = Path(__file__).resolve().parents[1] / "data" / "ball_arm.yaml"

HEAD = """armctl_keyframes: 1
arm: ball_arm
units: {angle: deg}
joints: [shoulder, elbow, wrist]
keyframes:
"""


@pytest.fixture(scope="module")
def arm() -> armctl.Arm:
    return armctl.load_arm(BALL_ARM)


def _quat(r: Rotation) -> np.ndarray:
    q = np.roll(r.as_quat(), 1)
    return q if q[0] >= 0 else -q


def test_quaternions_rpy_and_rotation_vectors(arm: armctl.Arm) -> None:
    program = parse_keyframes(HEAD + """\
- {name: a, q: [[0.7071, 0, 0.7071, 0], 30, [10, -5]]}
- {name: b, q: [{rpy: [30, 20, 10]}, '0.5 rad', [0, '0.25 rad']]}
- {name: c, q: [{rotvec: [0, 0, 90]}, 0, [0, 0]]}
""", arm)
    assert program.widths == (4, 1, 2)
    a, b, c = (np.array(kf.q) for kf in program.keyframes)
    # the quaternion takes no unit (the file is in degrees) and is normalised
    assert np.allclose(a[:4], [math.sqrt(0.5), 0, math.sqrt(0.5), 0], atol=1e-9)
    assert np.allclose(a[4:], np.radians([30, 10, -5]))
    assert np.allclose(b[:4], _quat(Rotation.from_euler("xyz", [30, 20, 10], degrees=True)))
    assert np.allclose(b[4:], [0.5, 0, 0.25])
    assert np.allclose(c[:4], _quat(Rotation.from_rotvec([0, 0, math.pi / 2])))


def test_save_and_load_round_trip(arm: armctl.Arm, tmp_path: Path) -> None:
    src = tmp_path / "src.yaml"
    src.write_text(HEAD + """\
- {name: a, q: [[1, 0, 0, 0], 0, [0, 0]], dwell: 0.5}
- {name: b, q: [{rpy: [30, 20, 10]}, 30, [10, 5]], interpolation: linear}
- {name: c, pose: {xyz: [0.2, 0.1, 0.4], rpy: [0, 90, 0]}}
""", encoding="utf-8")
    program = load_keyframes(src, arm)
    out = save_keyframes(program, tmp_path / "out.yaml", arm)
    text = out.read_text(encoding="utf-8")
    assert "q: [[0.951548525, 0.239298338, 0.189307857, 0.038134576], 30.0, [10.0, 5.0]]" in text
    again = load_keyframes(out, arm)
    assert again.angle_unit is AngleUnit.DEG and again.widths == program.widths
    for k1, k2 in zip(program.keyframes, again.keyframes, strict=True):
        assert (k1.name, k1.dwell, k1.interpolation) == (k2.name, k2.dwell, k2.interpolation)
        if k1.q is None:
            assert k2.pose is not None and np.allclose(k1.pose, k2.pose, atol=1e-6)
        else:
            assert np.allclose(k1.q, k2.q, atol=1e-8)


@pytest.mark.parametrize(("value", "message"), [
    ("[[1, 0, 0], 0, [0, 0]]", "'shoulder' takes a unit quaternion [w, x, y, z], found a list "
                               "of 3 numbers"),
    ("[[1, 1, 0, 0], 0, [0, 0]]", "has norm 1.41421, not 1; normalised it is [0.707107"),
    ("[[1, 0, 0, '5 deg'], 0, [0, 0]]", "quaternion entry 3 is '5 deg', not a finite number (a "
                                        "quaternion has no unit)"),
    ("[{rpy: [1, 2]}, 0, [0, 0]]", "'rpy' takes 3 angles"),
    ("[{euler: [1, 2, 3]}, 0, [0, 0]]", "expected {rpy: [...]} or {rotvec: [...]}"),
    ("[[1, 0, 0, 0], 0, 5]", "universal joint 'wrist' takes a list of its 2 angles"),
    ("[[1, 0, 0, 0], [0, 1], [0, 0]]", "joint 'elbow' (revolute) takes one value"),
    ("[[1, 0, 0, 0], 0]", "expected a list of 3 joint values (one per joint in 'joints': "
                          "shoulder, elbow, wrist)"),
])
def test_bad_values_name_the_file_line_keyframe_and_joint(arm: armctl.Arm, tmp_path: Path,
                                                          value: str, message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(HEAD + f"- {{name: a, q: {value}}}\n", encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        load_keyframes(path, arm)
    text = str(err.value)
    assert message in text
    assert f"{path}:6: keyframes[0] (a).q" in text
    assert err.value.fix


def test_a_keyframe_outside_the_twist_range_is_refused_in_the_files_unit(
        arm: armctl.Arm, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "twist.yaml"
    path.write_text(HEAD + "- {name: a, q: [{rotvec: [0, 0, 170]}, 0, [0, 0]]}\n",
                    encoding="utf-8")
    gif = tmp_path / "x.gif"
    assert main(["render", str(BALL_ARM), "--keyframes", str(path), "-o", str(gif)]) == 2
    err = capsys.readouterr().err
    assert "the twist of ball joint 'shoulder' would be 170 deg, outside its limits [-150, " \
           "150] deg" in err
    assert "twist.yaml:6: keyframes[0] (a)" in err and "Traceback" not in err
    assert not gif.exists()


def test_render_keyframes_of_an_arm_with_ball_joints(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "walk.yaml"
    path.write_text(HEAD + """\
- {name: a, q: [[1, 0, 0, 0], 20, [0, 0]]}
- {name: b, q: [{rpy: [30, 20, 10]}, 30, [10, 5]]}
- {name: c, q: [{rotvec: [0, 60, 0]}, 60, [-10, 20]]}
- {name: d, pose: {xyz: [0.2, 0.1, 0.45]}}
""", encoding="utf-8")
    gif = tmp_path / "walk.gif"
    assert main(["render", str(BALL_ARM), "--keyframes", str(path), "-o", str(gif), "--fps",
                 "3", "--size", "2", "--dpi", "30"]) == 0
    out = capsys.readouterr().out
    assert "playback of walk.yaml" in out and "planned only; nothing moved" in out
    assert Image.open(gif).n_frames >= 4
    # the pose keyframe, solved by IK (seeded with the one before), is where the playback ends
    from armctl.render.motions import plan_keyframes

    arm = armctl.load_arm(BALL_ARM)
    plan = plan_keyframes(arm, path, arm.named_pose("home"))
    assert np.allclose(arm.fk(plan.goal)[:3, 3], [0.2, 0.1, 0.45], atol=1e-3)


def test_a_joint_move_refuses_quaternions_that_are_not_unit() -> None:
    import armctl
    from armctl.errors import InputError
    from armctl.motion import MotionLimits, plan_joint_move

    fig = armctl.load_arm("figure")
    limits = MotionLimits.from_model(fig)
    good = fig.named_pose("stand")
    bad = good.copy()
    bad[fig.q_index("left_hip")] = [2.0, 0.0, 0.0, 0.0]
    with pytest.raises(InputError, match=r"goal of the move: ball joint 'left_hip'.*norm 2"):
        plan_joint_move(good, bad, limits)
    with pytest.raises(InputError, match=r"start of the move: ball joint 'left_hip'"):
        plan_joint_move(bad, good, limits)


def test_degrees_in_a_file_of_radians_are_named(arm: armctl.Arm, tmp_path: Path) -> None:
    path = tmp_path / "rad.yaml"
    path.write_text(HEAD.replace("units: {angle: deg}\n", "")
                    + "- {name: a, q: [{rpy: [0, 30, 0]}, 0, [0, 0]]}\n", encoding="utf-8")
    with pytest.raises(ConfigError) as err:
        load_keyframes(path, arm)
    text = str(err.value)
    assert "more than a full turn" in text and "can only be degrees" in text, text
    assert "units: {angle: deg}" in (err.value.fix or "")
    path.write_text(HEAD.replace("units: {angle: deg}\n", "")
                    + "- {name: a, q: [{rpy: [0, 0.5, 0]}, 0, [0, 0]]}\n", encoding="utf-8")
    program = load_keyframes(path, arm)  # radians that fit a turn are radians
    assert np.allclose(program.keyframes[0].q[:4], _quat(Rotation.from_euler("xyz", [0, 0.5, 0])))
