"""The statuses SINGULAR and FAILED: produced where they are true, and only there."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.config.schema import (
    ArmSpec,
    FrameSpec,
    JointSpec,
    JointType,
    Limits,
    LinkSpec,
    Origin,
)
from armctl.ik import IKOptions, IKStatus, PositionGoal, solve_batch
from armctl.ik.result import finish
from armctl.ik.singular import (
    SINGULAR_THRESHOLD,
    goal_jacobian,
    goal_rank,
    singular_value,
    stuck_at_singularity,
)

SEARCHES = ("dls", "pinv", "jt", "ccd", "ccd-jt")


def planar(n: int = 2, length: float = 0.5, lower: float = -math.pi,
           upper: float = math.pi) -> Arm:
    """``n`` links of ``length`` [m] in the xy plane, joints about z; straight along x at 0."""
    links = [LinkSpec("base")] + [LinkSpec(f"l{i + 1}") for i in range(n)]
    joints = [JointSpec(f"j{i + 1}", JointType.REVOLUTE, "base" if i == 0 else f"l{i}",
                        f"l{i + 1}", Origin((0.0 if i == 0 else length, 0.0, 0.0), (0.0, 0.0, 0.0)),
                        (0.0, 0.0, 1.0), Limits(lower, upper)) for i in range(n)]
    frames = (FrameSpec("tool", f"l{n}", Origin((length, 0.0, 0.0), (0.0, 0.0, 0.0))),)
    return Arm(ArmSpec(f"planar{n}", "base", tuple(links), tuple(joints), frames, "tool",
                       ("tool",)))


def _nan_goal() -> PositionGoal:
    """A goal whose target holds a NaN (a construction check bypassed: a numerical fault)."""
    goal = PositionGoal([0.6, 0.2, 0.0])
    object.__setattr__(goal, "position", np.array([math.nan, 0.2, 0.0]))
    return goal


@pytest.mark.parametrize("solver", SEARCHES)
def test_a_search_stuck_at_a_stretched_arm_is_singular(solver: str) -> None:
    arm = planar()
    goal = PositionGoal([0.6, 0.0, 0.0])  # on the line of the links, 0.4 m closer: reachable
    assert np.allclose(arm.fk(np.zeros(2))[:3, 3], [1.0, 0.0, 0.0])
    res = arm.ik(goal, np.zeros(2), solver=solver, options=IKOptions(restarts=0))
    assert res.status is IKStatus.SINGULAR and not res.success
    assert np.allclose(res.q, 0.0)  # the error lies in Ker(J^T): no step moves the arm
    assert res.position_error == pytest.approx(0.4)
    assert "singular configuration" in res.message
    sigma = stuck_at_singularity(arm, (goal,), res.q)
    assert sigma is not None and sigma < 1e-12


def test_a_restart_leaves_the_singularity() -> None:
    arm = planar()
    goal = PositionGoal([0.6, 0.0, 0.0])
    for seed in range(5):
        res = arm.ik(goal, np.zeros(2), solver="dls", options=IKOptions(restarts=1, seed=seed))
        assert res.success and res.status is IKStatus.CONVERGED


def test_a_goal_beyond_reach_stays_unreachable_though_the_arm_is_singular() -> None:
    arm = planar()
    goal = PositionGoal([3.0, 0.0, 0.0])
    res = arm.ik(goal, np.zeros(2), solver="dls", options=IKOptions(restarts=0))
    assert res.status is IKStatus.UNREACHABLE
    assert singular_value(arm, (goal,), res.q) < SINGULAR_THRESHOLD  # stretched towards it
    assert stuck_at_singularity(arm, (goal,), res.q) is None


def test_goals_just_beyond_a_real_arms_workspace_stay_unreachable() -> None:
    # inside the loose reach bound (so no distance test settles it) but out of the workspace:
    # the closest configurations are stretched and singular, and minima of the error
    arm = load_arm("ur5e")
    chain = arm.chain(None)
    origin = arm.tree.joint_origin(chain[0])[:3, 3]
    reach = arm.reach(None, from_first_joint=True)
    rng = np.random.default_rng(3)
    points = arm.fk_batch(arm.sample(rng, 20))[:, :3, 3] - origin
    goals = [PositionGoal(origin + 0.97 * reach * p / np.linalg.norm(p)) for p in points]
    res = solve_batch(arm, goals, solver="dls", options=IKOptions(restarts=3, seed=0))
    assert set(res.status) == {IKStatus.UNREACHABLE} and res.position_error.min() > 0.01
    rank = goal_rank(arm, goals[:1])
    singular = [singular_value(arm, (g,), q, rank) < SINGULAR_THRESHOLD
                for g, q in zip(goals, res.q, strict=True)]
    assert sum(singular) >= 15  # most of them singular, yet not SINGULAR
    for g in goals[:3]:
        assert arm.ik(g, solver="pinv", options=IKOptions(restarts=3, seed=0)).status is (
            IKStatus.UNREACHABLE)


def test_a_failure_at_a_joint_limit_is_not_singular() -> None:
    arm = planar(lower=0.3, upper=1.0)
    goal = PositionGoal([0.5, -0.5, 0.0])  # needs the first joint below its limit
    for solver in ("dls", "pinv", "ccd"):
        res = arm.ik(goal, np.array([0.5, 0.5]), solver=solver)
        assert res.status is IKStatus.UNREACHABLE, solver
        assert singular_value(arm, (goal,), res.q) > SINGULAR_THRESHOLD


def test_the_goals_usual_rank_is_not_a_singularity() -> None:
    # a planar arm never moves its tool along z: the position goal's Jacobian has rank 2 of 3
    # everywhere, and a goal off the plane is unreachable, not singular
    arm = planar(3, 0.3)
    goal = PositionGoal([0.4, 0.3, 0.1])
    assert goal_rank(arm, (goal,)) == 2
    for solver in ("dls", "pinv", "jt", "ccd"):
        res = arm.ik(goal, np.array([0.3, 0.4, 0.5]), solver=solver)
        s = np.linalg.svd(goal_jacobian(arm, (goal,), res.q), compute_uv=False)
        assert s[2] < 1e-12 < SINGULAR_THRESHOLD < s[1], solver
        assert res.status is IKStatus.UNREACHABLE, solver
        assert res.position_error == pytest.approx(0.1, abs=1e-6)


def test_a_closed_form_verdict_is_never_made_singular() -> None:
    arm = planar()
    goal = PositionGoal([0.6, 0.0, 0.0])
    kw = {"solver": "x", "iterations": 0, "restarts": 0, "started": time.perf_counter()}
    closed = finish(arm, (goal,), np.zeros(2), status=IKStatus.UNREACHABLE, **kw)
    assert closed.status is IKStatus.UNREACHABLE
    searched = finish(arm, (goal,), np.zeros(2), status=IKStatus.UNREACHABLE, search=True, **kw)
    assert searched.status is IKStatus.SINGULAR
    budget = finish(arm, (goal,), np.zeros(2), status=IKStatus.TIME_LIMIT, search=True, **kw)
    assert budget.status is IKStatus.TIME_LIMIT


@pytest.mark.parametrize("solver", [*SEARCHES, "auto", "nlp"])
def test_a_nan_in_a_goal_fails_and_returns_the_start(solver: str) -> None:
    arm = planar()
    start = np.array([0.3, 0.2])
    res = arm.ik(_nan_goal(), start, solver=solver)
    assert res.status is IKStatus.FAILED and not res.success
    assert np.array_equal(res.q, start)
    assert math.isnan(res.position_error)
    assert "numerical failure" in res.message


def test_non_finite_joint_values_fail_and_the_start_is_returned() -> None:
    arm = planar()
    goal = PositionGoal([0.6, 0.2, 0.0])
    kw = {"solver": "x", "iterations": 3, "restarts": 0, "started": time.perf_counter()}
    res = finish(arm, (goal,), np.array([math.nan, 0.1]), status=IKStatus.MAX_ITERATIONS,
                 start=np.array([0.3, 0.2]), search=True, **kw)
    assert res.status is IKStatus.FAILED and not res.success
    assert np.array_equal(res.q, [0.3, 0.2]) and np.isfinite(res.position_error)
    assert "non-finite joint values; the start is returned" in res.message
    # without a start: the middle of the ranges
    res = finish(arm, (goal,), np.array([math.inf, 0.1]), status=IKStatus.MAX_ITERATIONS, **kw)
    assert res.status is IKStatus.FAILED and np.array_equal(res.q, arm.middle())


def test_a_batch_reports_singular_and_failed_per_problem() -> None:
    arm = planar()
    goals = [PositionGoal([0.6, 0.0, 0.0]), _nan_goal(), PositionGoal([0.3, 0.6, 0.0]),
             PositionGoal([3.0, 0.0, 0.0])]
    starts = np.array([[0.0, 0.0], [0.3, 0.2], [0.0, 0.0], [0.0, 0.0]])
    res = solve_batch(arm, goals, starts, options=IKOptions(restarts=0))
    assert res.status == (IKStatus.SINGULAR, IKStatus.FAILED, IKStatus.CONVERGED,
                          IKStatus.UNREACHABLE)
    assert list(res.success) == [False, False, True, False]
    assert np.array_equal(res.q[1], starts[1]) and np.allclose(res.q[0], 0.0)
