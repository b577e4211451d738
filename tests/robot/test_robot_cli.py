"""The motion commands, run in-process on the bundled simulated SO-101."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.spatial import rpy_to_matrix


def _json(capsys: pytest.CaptureFixture[str]) -> dict:
    return json.loads(capsys.readouterr().out)


def test_move_to_pose_reports_the_reached_pose(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "so101", "--xyz", "0.25", "0.05", "0.15", "--speed", "0.7",
                 "--json"])
    data = _json(capsys)
    assert code == 0 and data["ok"] and data["moved"]
    assert data["position_error"] < 2e-3
    arm = load_arm("so101")
    final = [data["final_joints"][n] for n in arm.joint_names]
    assert np.allclose(arm.fk(np.array(final))[:3, 3], data["reached_xyz"])
    # JSON is SI: the reached orientation in radians, equal to FK of the final joints
    assert "reached_rpy_deg" not in data
    assert np.allclose(rpy_to_matrix(np.array(data["reached_rpy"])), arm.fk(final)[:3, :3],
                       atol=1e-9)
    assert np.linalg.norm(np.array(data["reached_xyz"]) - [0.25, 0.05, 0.15]) < 2e-3


def test_move_to_pose_text_and_dry_run(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "so101", "--xyz", "0.25", "0.05", "0.15", "--dry-run"])
    out = capsys.readouterr()
    assert code == 0
    assert "IK solver" in out.out and "nothing moved" in out.out
    assert _plan_rows(out.out)["elbow_flex"][2] == "deg"
    assert "SIMULATED BUS" in out.err


def test_unreachable_exits_3(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "so101", "--xyz", "0.9", "0", "0.1", "--json"])
    data = _json(capsys)
    assert code == 3 and not data["ok"] and "cannot be reached" in data["error"]["message"]


def test_move_joints_and_limits(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-joints", "so101", "10", "-20", "30", "0", "0", "0", "--deg", "--json",
                 "--speed", "0.7"])
    data = _json(capsys)
    final = data["final_joints"]
    assert code == 0 and np.allclose(
        np.degrees([final["shoulder_pan"], final["shoulder_lift"], final["elbow_flex"]]),
        [10, -20, 30], atol=0.5)
    code = main(["move-joints", "so101", "0", "0", "200", "0", "0", "0", "--deg"])
    assert code == 2 and "elbow_flex" in capsys.readouterr().err


def test_play_dry_run_and_preview(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    prog = tmp_path / "p.yaml"
    prog.write_text(
        "armctl_keyframes: 1\narm: so101\nunits: {angle: deg}\n"
        "joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]\n"
        "keyframes:\n  - {name: a, q: [0, -20, 30, 10, 0], dwell: 0.2}\n"
        "  - {name: b, q: [20, -30, 40, 0, 0], gripper: '20 deg'}\n"
        "  - {name: c, pose: {xyz: [0.25, 0.0, 0.15]}}\n")
    png = tmp_path / "plan.png"
    code = main(["play", str(prog), "so101", "--preview", str(png), "--json", "--loop", "2"])
    data = _json(capsys)
    assert code == 0 and png.stat().st_size > 10_000
    assert [k["name"] for k in data["keyframes"]] == ["a", "b", "c"] * 2
    assert {e["kind"] for e in data["events"]} == {"dwell", "gripper"}
    assert data["moved"] is False


def test_play_moves_through_keyframes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    prog = tmp_path / "p.yaml"
    prog.write_text(
        "armctl_keyframes: 1\narm: so101\n"
        "joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]\n"
        "keyframes:\n  - {q: [0.05, -0.1, 0.1, 0.0, 0]}\n  - {q: [0.3, -0.4, 0.5, 0.2, 0.1]}\n")
    code = main(["play", str(prog), "so101", "--speed", "0.7", "--json"])
    data = _json(capsys)
    assert code == 0 and data["moved"]
    names = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll"]
    assert np.allclose([data["final_joints"][n] for n in names], [0.3, -0.4, 0.5, 0.2, 0.1],
                       atol=0.01)
    far = tmp_path / "far.yaml"
    far.write_text("armctl_keyframes: 1\narm: so101\njoints: [elbow_flex]\nkeyframes:\n"
                   "  - {q: [0.1]}\n  - {name: far, pose: {xyz: [0.9, 0, 0.1]}}\n")
    assert main(["play", str(far), "so101"]) == 3
    assert "keyframe 1 (far" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("armctl_keyframes: 1\narm: so101\njoints: [elbow]\nkeyframes: []\n")
    assert main(["play", str(bad), "so101"]) == 2
    assert "elbow_flex" in capsys.readouterr().err


def _plan_rows(out: str) -> dict[str, list[str]]:
    """The plan table printed by a motion command: joint -> [from, to, unit]."""
    lines = out.splitlines()
    head = next(i for i, line in enumerate(lines) if line.split()[:1] == ["joint"])
    rows = {}
    for line in lines[head + 2:]:
        cells = line.split()
        if len(cells) != 4 or cells[3] not in ("deg", "mm"):
            break
        rows[cells[0]] = cells[1:]
    return rows


@pytest.mark.parametrize(("argv", "joint", "goal_mm"), [
    (["move-joints", "omx", "0", "10", "20", "-30", "0.01", "--deg"], "gripper_left_joint", 10.0),
    (["park", "panda"], "panda_finger_joint1", None),
    (["move-to-pose", "wx250s", "--xyz", "0.3", "0", "0.2"], "left_finger", None),
])
def test_plan_tables_show_prismatic_joints_in_mm(argv: list[str], joint: str,
                                                 goal_mm: float | None,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.config.schema import JointType

    assert main([*argv, "--dry-run"]) == 0
    rows = _plan_rows(capsys.readouterr().out)
    arm = load_arm(argv[1])
    assert set(rows) == set(arm.joint_names)
    for name, kind in zip(arm.joint_names, arm.joint_types, strict=True):
        assert rows[name][2] == ("mm" if kind is JointType.PRISMATIC else "deg")
    assert rows[joint][2] == "mm"
    i = arm.joint_index(joint)
    assert arm.lower[i] * 1000 - 0.01 <= float(rows[joint][1]) <= arm.upper[i] * 1000 + 0.01
    if goal_mm is not None:
        assert float(rows[joint][1]) == pytest.approx(goal_mm)
        assert float(rows["joint4"][1]) == pytest.approx(-30.0)


def test_limit_errors_use_the_given_unit(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-joints", "so101", "0", "-130", "60", "20", "0", "0", "--deg", "--json"])
    data = _json(capsys)
    assert code == 2 and data["error"]["type"] == "JointValueError"
    msg = data["error"]["message"]
    assert "-130 deg" in msg and "[-100, 100] deg" in msg and "--deg?" not in msg
    assert data["error"]["details"]["value"] == pytest.approx(np.radians(-130))
    # without --deg, -30 is taken as radians: the hint asks about --deg
    assert main(["move-joints", "so101", "0", "-30", "60", "20", "0", "0"]) == 2
    err = capsys.readouterr().err
    assert "-30 rad" in err and "did you mean --deg?" in err
    # a value outside the limits in degrees too gets no such hint
    assert main(["move-joints", "so101", "0", "-300", "0", "0", "0", "0"]) == 2
    assert "forget --deg" not in capsys.readouterr().err


def test_keyframe_outside_limits_names_file_and_line(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    prog = tmp_path / "p.yaml"
    prog.write_text(
        "armctl_keyframes: 1\narm: so101\nunits: {angle: deg}\n"
        "joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]\n"
        "keyframes:\n  - {name: a, q: [0, -20, 30, 10, 0]}\n"
        "  - {name: b, q: [0, -130, 30, 10, 0]}\n")
    assert main(["play", str(prog), "so101", "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert f"{prog}:7" in err and "keyframes[1] (b)" in err
    assert "'shoulder_lift' would be -130 deg" in err and "[-100, 100] deg" in err


def test_play_with_swapped_arguments(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    prog = tmp_path / "p.yaml"
    prog.write_text("armctl_keyframes: 1\narm: so101\njoints: [elbow_flex]\n"
                    "keyframes:\n  - {q: [0.1]}\n")
    assert main(["play", "so101", str(prog)]) == 2
    assert "the arguments look swapped: use armctl play KEYFRAMES CONFIG" in \
        capsys.readouterr().err


def test_zero_length_moves_do_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    # the simulated SO-101 starts at its 'home' pose (all zero)
    assert np.allclose(load_arm("so101").named_pose("home"), 0.0)
    assert main(["home", "so101"]) == 0
    out = capsys.readouterr().out
    assert "already at the 'home' pose; nothing to do" in out and "streamed" not in out
    assert main(["move-joints", "so101", "0", "0", "0", "0", "0", "0", "--json"]) == 0
    data = _json(capsys)
    assert data["moved"] is False and data["nothing_to_do"] is True
    xyz = load_arm("so101").fk(np.zeros(6))[:3, 3]  # where the tool is at 'home'
    assert main(["move-to-pose", "so101", "--xyz", *(f"{v:.6f}" for v in xyz)]) == 0
    out = capsys.readouterr().out
    assert "already at the goal; nothing to do" in out and "streamed" not in out


def test_unreachable_position_goal_details(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "so101", "--xyz", "0.9", "0", "0.1", "--json"])
    error = _json(capsys)["error"]
    assert code == 3 and "orientation" not in error["message"]
    det = error["details"]
    arm = load_arm("so101")
    q = [det["closest_joints"][n] for n in arm.joint_names]
    assert np.allclose(q, det["closest_q"])
    reached = arm.fk(q)[:3, 3]
    assert np.allclose(reached, det["closest_xyz"])
    assert det["position_error"] == pytest.approx(np.linalg.norm(reached - [0.9, 0, 0.1]),
                                                  abs=1e-6)
    code = main(["move-to-pose", "so101", "--xyz", "0.9", "0", "0.1", "--direction", "z", "0",
                 "0", "-1"])
    assert code == 3 and "fewer orientation constraints" in capsys.readouterr().err
