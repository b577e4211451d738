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
    assert "closest configuration found" in details["closest"]
    assert "no solution" in err


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


def test_unreachable_message_is_one_line_with_a_reach_hint(capsys):
    arm = load_arm("so101")
    code, out, err = _run(capsys, "ik", "so101", "--xyz", "1.0", "0", "0.2", "--json")
    assert code == 3
    error = json.loads(out)["error"]
    message = error["message"]
    assert "\n" not in message
    assert message.count("unreachable") == 1
    assert "closest q" not in message
    # independent truth: the distance from the first joint's origin (its pose at q = 0)
    first = arm.joint_names[arm.chain()[0]]
    assert first == "shoulder_pan"
    reach = arm.reach(from_first_joint=True)
    assert 0.3 < reach < 0.7
    assert f"the arm reaches at most about {reach:.2f} m" in message
    details = error["details"]
    assert details["closest"].startswith("closest configuration found")
    assert "shoulder_pan" in details["closest"]
    assert len(details["q"]) == arm.dof
    assert "\n" not in err.strip()


def test_max_reach_bounds_the_reachable_positions():
    arm = load_arm("so101")
    reach = arm.reach(from_first_joint=True)
    rng = np.random.default_rng(3)
    origin = arm.fk(arm.middle(), arm.frame_names[0])[:3, 3]
    qs = arm.sample(rng, 500)
    first = arm.tree.joint_origin(arm.chain()[0])[:3, 3] + origin
    dists = np.linalg.norm(arm.fk_batch(qs)[:, :3, 3] - first, axis=1)
    assert dists.max() <= reach + 1e-9
    assert dists.max() > 0.8 * reach  # the bound is not loose


def test_unreachable_text_shows_the_status_once(capsys):
    code, out, err = _run(capsys, "ik", "so101", "--xyz", "1.0", "0", "0.2")
    assert code == 3 and out == ""
    assert err.count("unreachable") == 1
    assert "closest configuration found (" in err and "shoulder_lift" in err
    assert "goal is" in err and "from the base joint" in err


def test_full_pose_on_a_5_joint_arm_fails_fast(capsys, monkeypatch):
    from armctl.arm import Arm

    def no_solve(*a, **k):
        raise AssertionError("the solver must not run")

    monkeypatch.setattr(Arm, "ik", no_solve)
    code, _, err = _run(capsys, "ik", "so101", "--xyz", "0.2", "0", "0.2", "--rpy", "0", "1", "0")
    assert code == 2
    assert ("arm 'so101' moves its tool with 5 joints: a full 6-DOF pose is generally "
            "unreachable; give --direction AXIS DX DY DZ (5-DOF) or only --xyz") in err


def test_force_pose_solves_a_pose_on_the_5dof_manifold(capsys):
    arm = load_arm("so101")
    q = arm.middle()
    q[1] += 0.3
    t = arm.fk(q)
    code, out, _ = _run(capsys, "ik", "so101", "--xyz", *map(str, t[:3, 3]), "--rpy",
                        *map(str, matrix_to_rpy(t[:3, :3])), "--force-pose", "--json")
    assert code == 0
    reached = arm.fk(np.array(json.loads(out)["q"]))
    assert np.allclose(reached[:3, 3], t[:3, 3], atol=1e-5)


def test_the_solver_is_warmed_up_before_the_timed_solve(capsys, monkeypatch):
    from armctl.arm import Arm

    budgets = []
    real = Arm.ik

    def spy(self, goal, q0=None, solver="auto", *, options=None, constraints=()):
        budgets.append((options.max_iterations, options.restarts))
        return real(self, goal, q0, solver, options=options, constraints=constraints)

    monkeypatch.setattr(Arm, "ik", spy)
    code, out, _ = _run(capsys, "ik", "so101", "--xyz", "0.2", "0", "0.2", "--json")
    assert code == 0
    assert budgets == [(1, 0), (100, 50)]
    assert json.loads(out)["success"]
