"""Units on the command line: values that can only be degrees or millimetres, NaN and inf."""

from __future__ import annotations

import json
import math

import pytest

from armctl.arm import load_arm
from armctl.cli import main

XYZ = ["--xyz", "0.2", "0", "0.1"]


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


@pytest.mark.parametrize("argv", [
    ["fk", "so101", "0", "0", "180", "0", "0", "0"],
    ["fk", "so101", "0", "0", "-90", "0", "0", "0"],
    ["move-joints", "so101", "0", "0", "180", "0", "0", "0", "--dry-run"],
    ["ik", "so101", *XYZ, "--from", "0", "45", "0", "0", "0", "0"],
    ["render", "so101", "0", "0", "0", "0", "0", "30", "-o", "unused.png"],
    ["ik", "ur5e", *XYZ, "--rpy", "180", "0", "0"],
    ["move-to-pose", "so101", *XYZ, "--rpy", "0", "90", "0", "--dry-run"],
    ["render", "so101", "-o", "unused.png", "--target-xyz", "0.2", "0", "0.1",
     "--target-rpy", "0", "0", "-45"],
])
def test_an_angle_that_can_only_be_degrees_asks_for_deg(capsys: pytest.CaptureFixture[str],
                                                        argv: list[str]) -> None:
    code, _, err = run(capsys, *argv)
    assert code == 2
    assert "did you mean --deg?" in err
    assert "SIMULATED BUS" not in err  # refused before the bus opened


def test_the_same_values_with_deg_are_accepted(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "fk", "so101", "0", "0", "90", "0", "0", "0", "--deg", "--json")
    assert code == 0
    q = json.loads(out)["q"]
    assert q[2] == pytest.approx(math.pi / 2)
    code, out, _ = run(capsys, "ik", "ur5e", "--xyz", "0.3", "0.2", "0.4", "--rpy", "180", "0",
                       "0", "--deg", "--solver", "analytic", "--json")
    assert code == 0 and json.loads(out)["success"]


def test_a_continuous_joint_takes_values_beyond_a_turn(capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    """Only a value the joint cannot take is 'only degrees': the UR5e's joints span +-2 pi."""
    arm = load_arm("ur5e")
    assert arm.upper[0] > 6.2
    code, _, err = run(capsys, "fk", "ur5e", "6.2", "0", "0", "0", "0", "0")
    assert code == 0, err
    code, _, err = run(capsys, "fk", "ur5e", "7", "0", "0", "0", "0", "0")
    assert code == 2 and "did you mean --deg?" in err


def test_a_prismatic_value_in_millimetres_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "fk", "omx", "0", "0", "0", "0", "10")
    assert code == 2 and "did you mean 0.01 m (10 mm)?" in err
    code, _, err = run(capsys, "fk", "omx", "0", "0", "0", "0", "0.01")
    assert code == 0, err


@pytest.mark.parametrize("argv", [
    ["fk", "so101", "0", "0", "nan", "0", "0", "0"],
    ["fk", "so101", "0", "0", "-inf", "0", "0", "0"],
    ["fk", "so101", "0", "0", "inf", "0", "0", "0", "--json"],
    ["move-joints", "so101", "0", "0", "NaN", "0", "0", "0", "--dry-run"],
    ["ik", "so101", "--xyz", "0.2", "nan", "0.1"],
    ["ik", "ur5e", *XYZ, "--quat", "1", "0", "inf", "0"],
    ["ik", "so101", *XYZ, "--direction", "z", "0", "0", "nan"],
    ["ik", "so101", *XYZ, "--tol-pos", "nan"],
    ["move-to-pose", "so101", *XYZ, "--speed", "nan", "--dry-run"],
    ["move-joints", "so101", "0", "0", "0", "0", "0", "0", "--speed", "inf", "--dry-run"],
    ["view", "so101", "--duration", "nan"],
    ["render", "so101", "-o", "unused.png", "--azim", "inf"],
])
def test_nan_and_inf_are_refused(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert "finite" in err, err
    if "--json" in argv:
        assert json.loads(out)["error"]["exit_code"] == 2


def test_fk_of_nan_is_no_longer_computed(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = run(capsys, "fk", "so101", "0", "0", "nan", "0", "0", "0", "--json")
    assert code == 2
    doc = json.loads(out)
    assert doc["ok"] is False and "matrix" not in doc
    assert "elbow_flex" in doc["error"]["message"]
