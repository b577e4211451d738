"""``move-to-pose --relative [base|tool]``: offsets from the present tool pose, read from the bus.

Checked on the simulated bus in simulated time: the tool pose before (FK of the plan's start,
which is the joints read from the bus) and after (FK of the joints read back) differ by the
offset, composed on the side the frame asks for, computed here with plain rotation matrices.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main

pytestmark = [pytest.mark.timeout(60), pytest.mark.usefixtures("simulated_time")]


def rot_z(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def rot_x(deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    """The rotation angle of ``a^T b`` [rad]."""
    return math.acos(max(-1.0, min(1.0, (float(np.trace(a.T @ b)) - 1.0) / 2.0)))


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, Any, str]:
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.strip() else None, err


def before_after(name: str, data: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Tool poses at the plan's start and at the joints read back at the end."""
    arm = load_arm(name)
    start = np.array([data["plan"]["start"][n] for n in arm.joint_names])
    final = np.array([data["final_joints"][n] for n in arm.joint_names])
    return arm.fk(start), arm.fk(final)


def test_up_5_cm_in_the_base_frame(capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "so101", "--relative", "--xyz", "0", "0",
                          "0.05")
    assert code == 0, err
    t0, t1 = before_after("so101", data)
    assert np.allclose(t1[:3, 3] - t0[:3, 3], [0.0, 0.0, 0.05], atol=1.5e-3)
    assert np.allclose(data["relative"]["from_xyz"], t0[:3, 3], atol=1e-9)
    assert data["relative"]["frame"] == "base"
    assert data["relative"]["goal_kind"] == "PositionGoal"  # 5 joints move the SO-101's tool


def test_a_translation_keeps_the_orientation_of_a_6_dof_arm(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "ur5e", "--relative", "--xyz", "0.04", "-0.03",
                          "0.02")
    assert code == 0, err
    t0, t1 = before_after("ur5e", data)
    assert np.allclose(t1[:3, 3] - t0[:3, 3], [0.04, -0.03, 0.02], atol=1e-3)
    assert angle_between(t0[:3, :3], t1[:3, :3]) < math.radians(0.2)
    assert data["relative"]["goal_kind"] == "PoseGoal"


def test_rotate_the_tool_30_deg_about_its_own_z(capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "ur5e", "--relative", "tool", "--rpy", "0",
                          "0", "30", "--deg")
    assert code == 0, err
    t0, t1 = before_after("ur5e", data)
    assert np.allclose(t1[:3, 3], t0[:3, 3], atol=1e-3)  # the tool point stays
    assert angle_between(t0[:3, :3] @ rot_z(30), t1[:3, :3]) < math.radians(0.2)
    assert abs(angle_between(t0[:3, :3], t1[:3, :3]) - math.radians(30)) < math.radians(0.2)


def test_a_rotation_about_a_base_axis_turns_through_the_tool_point(
        capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "ur5e", "--relative", "base", "--rpy", "10",
                          "0", "0", "--deg")
    assert code == 0, err
    t0, t1 = before_after("ur5e", data)
    assert np.allclose(t1[:3, 3], t0[:3, 3], atol=1e-3)
    assert angle_between(rot_x(10) @ t0[:3, :3], t1[:3, :3]) < math.radians(0.2)
    # not the same as the rotation about the tool's own x (unless the tool x is the base x)
    assert angle_between(t0[:3, :3] @ rot_x(10), t1[:3, :3]) > math.radians(1)


def test_a_translation_along_the_tool_axes(capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "ur5e", "--relative", "tool", "--xyz", "0",
                          "0", "0.03", "--linear")
    assert code == 0, err
    t0, t1 = before_after("ur5e", data)
    assert np.allclose(t1[:3, 3] - t0[:3, 3], 0.03 * t0[:3, 2], atol=1e-3)


@pytest.mark.parametrize(("argv", "words"), [
    (["--relative"], ["needs an offset", "--xyz"]),
    (["--relative", "--quat", "1", "0", "0", "0"], ["--rpy", "not --quat"]),
    (["--relative", "--frame", "tool", "--rpy", "0", "0", "30", "--deg"],
     ["--relative tool"]),
    (["--relative", "--rpy", "0", "0", "30"], ["did you mean --deg?"]),
    (["--relative", "--xyz", "0", "0", "0.05", "--frame", "nosuchframe"], ["nosuchframe"]),
])
def test_relative_combinations_that_make_no_sense(
        capsys: pytest.CaptureFixture[str], argv: list[str], words: list[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "ur5e", *argv)
    assert code == 2, err
    for w in words:
        assert w in data["error"]["message"]


def test_relative_refuses_other_goal_types(capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.ik import goal_classes

    flags = [a for c in goal_classes() for a in c.cli_arguments if a.numbers]
    assert flags
    arg = flags[0]
    values = ["0.1"] * len(arg.metavar) if not arg.choices else [arg.choices[0]]
    code, data, err = run(capsys, "move-to-pose", "ur5e", "--relative", arg.flag, *values)
    assert code == 2, err
    assert "--relative takes --xyz and --rpy offsets only" in data["error"]["message"]


def test_relative_frame_value_is_checked_by_argparse(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "ur5e", "--relative", "world", "--xyz", "0", "0", "0.01"])
    assert code == 2
    assert "invalid choice: 'world'" in capsys.readouterr().err
