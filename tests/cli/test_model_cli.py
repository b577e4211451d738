"""The model commands: output content, JSON schema and exit codes."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from armctl_testpaths import DATA

import armctl
from armctl.cli import main

PLANAR = str(DATA / "planar3r.yaml")


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_fk_text_and_json_agree_with_api(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "fk", PLANAR, "30", "45", "-20", "--deg")
    assert code == 0
    assert "x 0.368929" in out and "rpy [deg]" in out and "55.000" in out
    code, out, _ = run(capsys, "fk", PLANAR, "0.1", "0.2", "0.3", "--json")
    data = json.loads(out)
    assert data["ok"] and data["schema"] == "armctl/1" and data["command"] == "fk"
    arm = armctl.load_arm(PLANAR)
    np.testing.assert_allclose(data["matrix"], arm.fk([0.1, 0.2, 0.3]), atol=1e-15)
    assert data["frame"] == "tip" and data["within_limits"] is True


def test_fk_other_frame_and_bad_input(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "fk", PLANAR, "0", "0", "0", "--frame", "l2")
    assert code == 0 and "x 0.300000" in out
    code, _, err = run(capsys, "fk", PLANAR, "0", "0", "0", "--frame", "l22")
    assert code == 2 and "unknown frame 'l22'" in err and "did you mean 'l2'" in err
    code, _, err = run(capsys, "fk", PLANAR, "0", "0")
    assert code == 2 and "expected 3 values (j1, j2, j3), got 2" in err
    code, _, err = run(capsys, "fk", PLANAR, "0", "x", "0")
    assert code == 2 and "'x' (joint 'j2') is not a number" in err


def test_info_lists_joints_tree_and_json(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "info", PLANAR, "--deg")
    assert code == 0
    assert "3 DOF" in out and "-171.887" in out and "└─ [frame] tip" in out
    code, out, _ = run(capsys, "info", PLANAR, "--json")
    data = json.loads(out)
    assert [j["name"] for j in data["joints"]] == ["j1", "j2", "j3"]
    assert data["tool"] == "tip" and "l3" in data["frames"]


def test_bad_config_gives_exit_code_2_and_json_error(capsys: pytest.CaptureFixture[str],
                                                      tmp_path) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text("name: x\nbase: b\njoints: []\n")
    code, out, err = run(capsys, "info", str(p), "--json")
    assert code == 2
    data = json.loads(out)
    assert data["ok"] is False and data["error"]["type"] == "ConfigError"
    assert "bad.yaml" in err and "no joints" in err


def test_version_and_module_entry_point() -> None:
    out = subprocess.run([sys.executable, "-m", "armctl", "--version"], capture_output=True,
                         text=True, check=True).stdout
    assert out.strip() == f"armctl {armctl.__version__}"


def test_no_command_prints_help(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys)
    assert code == 2 and "usage: armctl" in out


def test_arms_lists_bundled_configs(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "arms", "--json")
    assert code == 0
    names = {a["name"] for a in json.loads(out)["arms"]}
    assert {"so101", "ur5e"} <= names


def test_fk_names_every_joint_outside_its_limits(capsys: pytest.CaptureFixture[str]) -> None:
    arm = armctl.load_arm(PLANAR)
    assert arm.upper[1] == 3 and arm.lower[2] == -3
    code, out, _ = run(capsys, "fk", PLANAR, "0.5", "3.5", "-4")
    assert code == 0
    assert "note: joint 'j2' = 3.5000 rad is outside its limits [-3.0000, 3.0000] rad" in out
    assert "note: joint 'j3' = -4.0000 rad is outside its limits [-3.0000, 3.0000] rad" in out
    assert "'j1'" not in out
    code, out, _ = run(capsys, "fk", PLANAR, "0.5", "3.5", "-4", "--json")
    data = json.loads(out)
    assert data["within_limits"] is False
    assert [(o["joint"], o["value"], o["upper"]) for o in data["outside_limits"]] == [
        ("j2", 3.5, 3.0), ("j3", -4.0, 3.0)]


def test_fk_never_prints_negative_zero(capsys: pytest.CaptureFixture[str]) -> None:
    arm = armctl.load_arm(PLANAR)
    q = [np.pi / 2, np.pi / 2, 0.0]
    # the pose has entries that the plain format would print as -0.000000
    assert any(f"{v:.6f}" == "-0.000000" for v in arm.fk(q).ravel())
    code, out, _ = run(capsys, "fk", PLANAR, *map(str, q))
    assert code == 0 and "matrix:" in out
    assert "-0.000000" not in out and "-0.000" not in out
    code, out, _ = run(capsys, "fk", PLANAR, *map(str, q), "--json")
    assert "-0.0," not in out and "-0.0\n" not in out


def test_negative_values_in_exponent_notation(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "fk", PLANAR, "-1e-3", "-2.5E-01", "0", "--json")
    assert code == 0
    np.testing.assert_allclose(json.loads(out)["q"], [-1e-3, -0.25, 0.0])
