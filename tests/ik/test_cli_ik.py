"""The ``armctl ik`` command."""

from __future__ import annotations

import json

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.spatial import matrix_to_rpy


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_full_pose_json(capsys):
    arm = load_arm("ur5e")
    q = np.array([0.3, -1.2, 1.4, -1.0, -1.5, 0.4])
    t = arm.fk(q)
    rpy = matrix_to_rpy(t[:3, :3])
    code, out, _ = _run(capsys, "ik", "ur5e", "--xyz", *map(str, t[:3, 3]), "--rpy",
                        *map(str, rpy), "--json")
    assert code == 0
    data = json.loads(out)
    assert data["ok"] and data["success"] and data["status"] == "converged"
    reached = arm.fk(np.array(data["q"]))
    assert np.allclose(reached[:3, 3], t[:3, 3], atol=1e-5)
    assert data["frames"][0]["position_error"] <= 1e-5


def test_direction_goal_text_in_degrees(capsys):
    arm = load_arm("so101")
    q = arm.middle()
    q[1] += 0.3
    t = arm.fk(q)
    code, out, _ = _run(capsys, "ik", "so101", "--xyz", *map(str, t[:3, 3]), "--direction", "z",
                        *map(str, t[:3, 2]), "--deg", "--solver", "dls")
    assert code == 0
    assert "converged" in out and "deg" in out and "residual" in out


def test_unreachable_exits_3_with_the_closest_pose(capsys):
    code, out, err = _run(capsys, "ik", "ur5e", "--xyz", "3", "0", "0.5", "--json")
    assert code == 3
    data = json.loads(out)
    assert not data["ok"]
    details = data["error"]["details"]
    assert details["status"] == "unreachable"
    assert details["position_error"] > 1.0
    assert len(details["q"]) == 6
    assert "closest configuration" in err


@pytest.mark.parametrize("argv", [
    ["ik", "ur5e", "--xyz", "0.3", "0.1", "0.3", "--direction", "w", "0", "0", "1"],
    ["ik", "ur5e", "--xyz", "0.3", "0.1", "0.3", "--solver", "nope"],
    ["ik", "ur5e", "--xyz", "0.3", "0.1", "0.3", "--from", "0", "0"],
    ["ik", "ur5e"],
])
def test_bad_input_exits_2(capsys, argv):
    code, _, err = _run(capsys, *argv)
    assert code == 2
    assert "error" in err
