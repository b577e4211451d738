"""``armctl gripper CONFIG open|close|VALUE`` on the simulated bus, in simulated time.

The expected ends are read from the config files with a plain YAML parser (not armctl's loader):
the lower limit of the ``role: gripper`` joint is the closed jaw, the upper the open one.
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest
import yaml
from armctl_testpaths import CONFIGS

from armctl.cli import main

pytestmark = [pytest.mark.timeout(60), pytest.mark.usefixtures("simulated_time")]

#: One tick of a 4096-tick servo [rad], and the servo's dead band around it.
TICK = 2 * math.pi / 4096


def gripper_of(name: str) -> dict[str, Any]:
    """The gripper joint of a bundled config, as written in its YAML file."""
    doc = yaml.safe_load((CONFIGS / f"{name}.yaml").read_text(encoding="utf-8"))
    (joint,) = [j for j in doc["joints"] if j.get("role") == "gripper"]
    return dict(joint)


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, Any, str]:
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.strip() else None, err


@pytest.mark.parametrize("name", ["so101", "koch_follower", "omx"])
@pytest.mark.parametrize("word", ["open", "close"])
def test_open_and_close_go_to_the_ends_of_the_gripper_range(
        capsys: pytest.CaptureFixture[str], name: str, word: str) -> None:
    joint = gripper_of(name)
    end = joint["limits"]["upper" if word == "open" else "lower"]
    code, data, err = run(capsys, "gripper", name, word)
    assert code == 0, err
    assert data["moved"] is True
    assert data["plan"]["target"][joint["name"]] == pytest.approx(end, abs=1e-9)
    # one servo tick, in the joint's unit (the OpenManipulator-X finger turns 87 rad per metre)
    tol = 2 * TICK / (87.0 if joint["type"] == "prismatic" else 1.0)
    assert abs(data["final_joints"][joint["name"]] - end) < tol
    start, final = data["plan"]["start"], data["final_joints"]
    others = [n for n in start if n != joint["name"]]
    assert others
    for n in others:  # only the gripper moved
        assert data["plan"]["target"][n] == start[n]
        assert abs(final[n] - start[n]) < 2 * TICK
    assert data["gripper"][joint["name"]]["goal"] == word


def test_a_value_in_degrees_or_radians(capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "gripper", "so101", "30", "--deg")
    assert code == 0, err
    assert data["plan"]["target"]["gripper"] == pytest.approx(math.radians(30))
    assert abs(data["final_joints"]["gripper"] - math.radians(30)) < 2 * TICK
    code, data, err = run(capsys, "gripper", "so101", "0.25")
    assert code == 0, err
    assert abs(data["final_joints"]["gripper"] - 0.25) < 2 * TICK


def test_a_prismatic_value_in_millimetres(capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "gripper", "omx", "12", "--mm")
    assert code == 0, err
    assert data["plan"]["target"]["gripper_left_joint"] == pytest.approx(0.012)
    assert abs(data["final_joints"]["gripper_left_joint"] - 0.012) < 2 * TICK / 87.0


def test_a_dry_run_moves_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "gripper", "so101", "close", "--dry-run")
    assert code == 0, err
    assert data["moved"] is False
    assert data["plan"]["target"]["gripper"] == pytest.approx(
        gripper_of("so101")["limits"]["lower"])


@pytest.mark.parametrize(("argv", "words"), [
    (["ur5e", "open"], ["has no gripper", "role: gripper", "shoulder_pan_joint"]),
    (["so101", "30"], ["outside its limits", "did you mean --deg?"]),
    (["so101", "200", "--deg"], ["outside its limits", "deg"]),
    (["omx", "12"], ["outside its limits", "did you mean --mm?"]),
    (["so101", "10", "--mm"], ["--mm", "rotary"]),
    (["omx", "5", "--deg"], ["--deg", "prismatic"]),
    (["so101", "opne"], ["neither 'open', 'close' nor a number"]),
    (["so101", "open", "--deg"], ["applies to a VALUE"]),
    (["so101", "nan"], ["not a finite number"]),
])
def test_bad_goals_are_refused_before_anything_moves(
        capsys: pytest.CaptureFixture[str], argv: list[str], words: list[str]) -> None:
    code, data, err = run(capsys, "gripper", *argv)
    assert code == 2, err
    message = data["error"]["message"]
    for w in words:
        assert w in message
    assert "plan" not in data


def test_the_text_output_shows_the_gripper_plan(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["gripper", "so101", "open"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "open the gripper" in out
    row = next(line for line in out.splitlines() if line.startswith("gripper "))
    assert float(row.split()[2]) == pytest.approx(
        np.degrees(gripper_of("so101")["limits"]["upper"]), abs=0.01)
