"""A keyframe file's units apply to every value: rotary joints, grippers, prismatic joints, xyz."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.errors import ConfigError
from armctl.motion import (
    AngleUnit,
    Keyframe,
    KeyframeProgram,
    LengthUnit,
    MotionLimits,
    PlaybackOptions,
    load_keyframes,
    plan_program,
    save_keyframes,
)
from armctl.motion.keyframe_file import parse_keyframes

SO_JOINTS = "[shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]"


@pytest.fixture(scope="module")
def so101() -> Arm:
    return load_arm("so101")  # rotary gripper


@pytest.fixture(scope="module")
def omx() -> Arm:
    return load_arm("omx")  # prismatic gripper


def _so(units: str, item: str) -> str:
    return (f"armctl_keyframes: 1\narm: so101\nunits: {units}\njoints: {SO_JOINTS}\n"
            f"keyframes:\n- {item}\n")


def _omx(units: str, item: str) -> str:
    return (f"armctl_keyframes: 1\narm: omx\nunits: {units}\njoints: [joint1, joint2, joint3, "
            f"joint4]\nkeyframes:\n- {item}\n")


def test_a_rotary_gripper_follows_the_angle_unit(so101: Arm) -> None:
    deg = parse_keyframes(_so("{angle: deg}", "{q: [0, 10, 20, 0, 0], gripper: 30}"), so101)
    assert deg.keyframes[0].gripper == pytest.approx(math.radians(30))
    assert deg.keyframes[0].q == pytest.approx(tuple(np.radians([0, 10, 20, 0, 0])))
    rad = parse_keyframes(_so("{angle: rad}", "{q: [0, 0, 0, 0, 0], gripper: 0.5}"), so101)
    assert rad.keyframes[0].gripper == pytest.approx(0.5)
    text = parse_keyframes(_so("{angle: deg}", "{q: [0, 0, 0, 0, 0], gripper: '0.5 rad'}"),
                           so101)
    assert text.keyframes[0].gripper == pytest.approx(0.5)  # a string keeps its own unit


def test_a_prismatic_gripper_and_xyz_follow_the_length_unit(omx: Arm) -> None:
    mm = parse_keyframes(_omx("{angle: deg, length: mm}", "{q: [0, 10, 0, 0], gripper: 12}"), omx)
    assert mm.length_unit is LengthUnit.MM
    assert mm.keyframes[0].gripper == pytest.approx(0.012)
    assert mm.keyframes[0].q == pytest.approx(tuple(np.radians([0, 10, 0, 0])))
    metres = parse_keyframes(_omx("{angle: rad, length: m}", "{q: [0, 0, 0, 0], gripper: 0.012}"),
                             omx)
    assert metres.keyframes[0].gripper == pytest.approx(0.012)
    text = parse_keyframes(_omx("{length: m}", "{q: [0, 0, 0, 0], gripper: '12 mm'}"), omx)
    assert text.keyframes[0].gripper == pytest.approx(0.012)
    pose = parse_keyframes(_omx("{angle: deg, length: mm}", "{pose: {xyz: [200, 0, 150]}}"), omx)
    np.testing.assert_allclose(pose.keyframes[0].pose[:3, 3], [0.2, 0.0, 0.15])


@pytest.mark.parametrize(("make", "item", "words"), [
    (_so, "{q: [0, 0, 0, 0, 0], gripper: '3 mm'}", "wrong unit"),
    (_omx, "{q: [0, 0, 0, 0], gripper: '30 deg'}", "wrong unit"),
    (_so, "{q: [0, 0, '5 mm', 0, 0]}", "wrong unit"),
    (_so, "{q: [0, 0, 0, 0, 0], gripper: true}", r"expected a number \(in deg"),
    (_so, "{q: [0, 0, .inf, 0, 0]}", "finite"),
])
def test_values_in_the_wrong_unit_are_refused(so101: Arm, omx: Arm, make: object, item: str,
                                              words: str) -> None:
    arm = so101 if make is _so else omx
    with pytest.raises(ConfigError, match=words) as info:
        parse_keyframes(make("{angle: deg}", item), arm)  # type: ignore[operator]
    assert "keyframes[0]" in str(info.value)


@pytest.mark.parametrize("unit", list(AngleUnit))
def test_writing_uses_the_file_units_for_the_gripper(so101: Arm, tmp_path: Path,
                                                     unit: AngleUnit) -> None:
    grip = math.radians(30)
    prog = KeyframeProgram("so101", ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex",
                                     "wrist_roll"),
                           (Keyframe(q=(0.1, -0.2, 0.3, 0.0, 0.0), gripper=grip),),
                           angle_unit=unit)
    path = save_keyframes(prog, tmp_path / "g.yaml", so101)
    written = "gripper: 30" if unit is AngleUnit.DEG else f"gripper: {round(grip, 7)}"
    assert written in path.read_text()
    back = load_keyframes(path, so101)
    assert back.keyframes[0].gripper == pytest.approx(grip, abs=1e-7)


def test_writing_lengths_in_millimetres(omx: Arm, tmp_path: Path) -> None:
    prog = KeyframeProgram("omx", ("joint1", "joint2", "joint3", "joint4"),
                           (Keyframe(q=(0.0, 0.1, 0.0, 0.0), gripper=0.012),),
                           angle_unit=AngleUnit.DEG, length_unit=LengthUnit.MM)
    path = save_keyframes(prog, tmp_path / "mm.yaml", omx)
    text = path.read_text()
    assert "length: mm" in text and "gripper: 12" in text
    back = load_keyframes(path, omx)
    assert back.length_unit is LengthUnit.MM and back.keyframes[0].gripper == pytest.approx(0.012)


def test_a_degree_gripper_value_plays_in_radians(so101: Arm) -> None:
    prog = parse_keyframes(_so("{angle: deg}", "{q: [0, 10, 20, 0, 0], gripper: 30}"), so101)
    plan = plan_program(prog, so101, MotionLimits.from_model(so101), np.zeros(6),
                        PlaybackOptions())
    (event,) = [e for e in plan.events if e.kind == "gripper"]
    assert event.value == pytest.approx(math.radians(30))
    assert plan.goal[so101.joint_index("gripper")] == pytest.approx(math.radians(30))


def test_an_out_of_range_gripper_names_the_file_unit(so101: Arm) -> None:
    prog = parse_keyframes(_so("{angle: deg}", "{q: [0, 0, 0, 0, 0], gripper: 300}"), so101)
    with pytest.raises(ConfigError, match=r"gripper value for joint 'gripper' would be 300 deg"):
        plan_program(prog, so101, MotionLimits.from_model(so101), np.zeros(6), PlaybackOptions())
