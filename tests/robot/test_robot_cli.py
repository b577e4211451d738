"""The motion commands, run in-process on the bundled simulated SO-101."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main


def _json(capsys: pytest.CaptureFixture[str]) -> dict:
    return json.loads(capsys.readouterr().out)


def test_move_to_pose_reports_the_reached_pose(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "so101", "--xyz", "0.25", "0.05", "0.15", "--speed", "0.7",
                 "--json"])
    data = _json(capsys)
    assert code == 0 and data["ok"] and data["moved"]
    assert data["position_error"] < 2e-3
    arm = load_arm("so101")
    assert np.allclose(arm.fk(np.array(data["final_joints"]))[:3, 3], data["reached_xyz"])
    assert np.linalg.norm(np.array(data["reached_xyz"]) - [0.25, 0.05, 0.15]) < 2e-3


def test_move_to_pose_text_and_dry_run(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "so101", "--xyz", "0.25", "0.05", "0.15", "--dry-run"])
    out = capsys.readouterr()
    assert code == 0
    assert "IK solver" in out.out and "to [deg]" in out.out and "nothing moved" in out.out
    assert "SIMULATED BUS" in out.err


def test_unreachable_exits_3(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-to-pose", "so101", "--xyz", "0.9", "0", "0.1", "--json"])
    data = _json(capsys)
    assert code == 3 and not data["ok"] and "cannot be reached" in data["error"]["message"]


def test_move_joints_and_limits(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-joints", "so101", "10", "-20", "30", "0", "0", "0", "--deg", "--json",
                 "--speed", "0.7"])
    data = _json(capsys)
    assert code == 0 and np.allclose(np.degrees(data["final_joints"][:3]), [10, -20, 30],
                                     atol=0.5)
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
    assert np.allclose(data["final_joints"][:5], [0.3, -0.4, 0.5, 0.2, 0.1], atol=0.01)
    far = tmp_path / "far.yaml"
    far.write_text("armctl_keyframes: 1\narm: so101\njoints: [elbow_flex]\nkeyframes:\n"
                   "  - {q: [0.1]}\n  - {name: far, pose: {xyz: [0.9, 0, 0.1]}}\n")
    assert main(["play", str(far), "so101"]) == 3
    assert "keyframe 1 (far" in capsys.readouterr().err
    bad = tmp_path / "bad.yaml"
    bad.write_text("armctl_keyframes: 1\narm: so101\njoints: [elbow]\nkeyframes: []\n")
    assert main(["play", str(bad), "so101"]) == 2
    assert "elbow_flex" in capsys.readouterr().err
