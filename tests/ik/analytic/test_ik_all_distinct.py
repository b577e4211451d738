"""``ik --all``: distinct solutions by default, consistent with the single analytic answer."""

from __future__ import annotations

import json

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.config.schema import JointType
from armctl.ik import DirectionGoal, PoseGoal
from armctl.ik.analytic import acceptance, ik_all
from armctl.spatial import make_transform, rpy_to_matrix

SO101_GOAL = ["--xyz", "0.2", "0", "0.05", "--direction", "z", "0", "0", "-1",
              "--solver", "analytic"]
UR5E_GOAL = ["--xyz", "0.3", "0.2", "0.4", "--rpy", "3.1", "0", "0", "--solver", "analytic"]


def run_json(capsys: pytest.CaptureFixture[str], *argv: str) -> dict:
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    return json.loads(out)


def test_all_agrees_with_the_single_answer_on_the_so101(capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    """The tool pointing straight down is met only to ~6e-6 rad (the CAD's 1.5708 is not
    pi/2): both paths accept the goal's tolerance, so both find the in-limit solutions."""
    single = run_json(capsys, "ik", "so101", *SO101_GOAL)
    every = run_json(capsys, "ik", "so101", *SO101_GOAL, "--all")
    inside = [s for s in every["solutions"] if s["within_limits"]]
    assert single["success"] and inside
    np.testing.assert_allclose(inside[0]["q"], single["q"], atol=1e-12)  # nearest in limits
    assert every["distinct"] == len(every["solutions"])
    assert f"{len(inside)} of {every['distinct']} distinct solutions" in single_message(capsys)


def single_message(capsys: pytest.CaptureFixture[str]) -> str:
    assert main(["ik", "so101", *SO101_GOAL]) == 0
    return capsys.readouterr().out.splitlines()[0]


def test_ur5e_lists_8_distinct_solutions_and_256_variants_on_request(
        capsys: pytest.CaptureFixture[str]) -> None:
    distinct = run_json(capsys, "ik", "ur5e", *UR5E_GOAL, "--all")
    assert distinct["count"] == distinct["distinct"] == 8
    assert distinct["with_variants"] == 256 and distinct["variants_listed"] is False
    qs = np.array([s["q"] for s in distinct["solutions"]])
    wrapped = np.angle(np.exp(1j * qs))
    for i in range(8):  # no two rows are the same arm pose
        for j in range(i):
            diff = np.abs(np.angle(np.exp(1j * (wrapped[i] - wrapped[j]))))
            assert diff.max() > 1e-6
    assert all(s["within_limits"] for s in distinct["solutions"])
    variants = run_json(capsys, "ik", "ur5e", *UR5E_GOAL, "--all", "--variants")
    assert variants["count"] == 256 and variants["variants_listed"] is True
    single = run_json(capsys, "ik", "ur5e", *UR5E_GOAL)
    np.testing.assert_allclose(qs[0], single["q"], atol=1e-12)
    code = main(["ik", "ur5e", *UR5E_GOAL, "--all"])
    text = capsys.readouterr().out
    assert code == 0 and text.startswith("8 distinct solutions (8 inside the limits)")
    assert "--variants lists their 256 rows" in text


def test_distinct_prefers_the_variant_inside_the_limits_nearest_the_reference() -> None:
    arm = load_arm("ur5e")
    goal = PoseGoal(make_transform(rpy_to_matrix([3.1, 0.0, 0.0]), [0.3, 0.2, 0.4]))
    ref = np.array([5.0, -1.0, 1.0, 0.5, -5.0, 2.0])  # near the +2 pi / -2 pi ends
    every = ik_all(arm, goal, q_ref=ref, tol=acceptance(goal), variants=True)
    rotary = [t is not JointType.PRISMATIC for t in arm.joint_types]
    distinct = every.distinct(rotary)
    assert len(distinct) == 8 and len(every) == 256
    for q in distinct.q:
        same = [r for r in every.q
                if np.abs(np.angle(np.exp(1j * (r - q)))).max() < 1e-6]
        nearest = min(same, key=lambda r: float(np.linalg.norm(r - ref)))
        np.testing.assert_allclose(q, nearest)
    np.testing.assert_allclose(distinct.best, every.best)


def test_acceptance_follows_the_goal_tolerance() -> None:
    from armctl.ik import Tolerance

    goal = DirectionGoal(np.array([0.2, 0.0, 0.05]), np.array([0.0, 0.0, -1.0]),
                         np.array([0.0, 0.0, 1.0]), tolerance=Tolerance(1e-5, 1e-4))
    assert acceptance(goal) == 1e-5
    strict = DirectionGoal(goal.position, goal.direction, goal.axis,
                           tolerance=Tolerance(1e-12, 1e-12))
    assert acceptance(strict) == 1e-9
