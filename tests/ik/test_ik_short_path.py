"""One goal by the short path: the compiled solve that checks its own answer, the result built
from that check, the compiled check of a pose goal, and batches that answer as calls do.

Truth: :func:`armctl.ik.result.finish` (FK of the answer in Python, ``Goal.errors``, the
joint limits) on the same answer, the goal types' Python checks, and single calls for batches.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.errors import InputError, UnknownNameError
from armctl.ik import (
    DirectionGoal,
    IKOptions,
    IKStatus,
    LookAtGoal,
    PoseGoal,
    PositionGoal,
    Tolerance,
    finish,
    solve_batch,
)
from armctl.ik import goals as goals_module
from armctl.ik.errors import UnsupportedGoalError

TOL = Tolerance(1e-6, 1e-6)


@pytest.fixture(scope="module")
def arms() -> dict[str, Arm]:
    return {name: load_arm(name) for name in ("ur5e", "panda", "so101")}


def _goal(arm: Arm, pose: np.ndarray, tol: Tolerance = TOL) -> PoseGoal | DirectionGoal:
    if len(arm.chain()) < 6:
        return DirectionGoal(pose[:3, 3], pose[:3, 2], tolerance=tol)
    return PoseGoal(pose, tolerance=tol)


@pytest.mark.parametrize("name", ["ur5e", "panda", "so101"])
@pytest.mark.parametrize("solver", ["auto", "dls", "pinv"])
def test_a_short_path_result_is_the_one_finish_builds(arms: dict[str, Arm], name: str,
                                                      solver: str) -> None:
    arm = arms[name]
    rng = np.random.default_rng(11)
    poses = arm.fk_batch(arm.sample(rng, 25))
    starts = arm.sample(rng, 25)
    for pose, start in zip(poses, starts, strict=True):
        goal = _goal(arm, pose)
        res = arm.ik(goal, start, solver)
        ref = finish(arm, (goal,), res.q, solver=solver, status=IKStatus.CONVERGED,
                     iterations=res.iterations, restarts=res.restarts, started=0.0)
        assert res.success == ref.success
        if not res.success:
            continue
        for f in dataclasses.fields(res):
            if f.name == "time":
                continue
            mine, truth = getattr(res, f.name), getattr(ref, f.name)
            if isinstance(truth, np.ndarray):
                assert np.array_equal(mine, truth) and not mine.flags.writeable
            elif f.name in ("position_error", "rotation_error"):
                # compiled and Python arithmetic: the same numbers up to round-off
                assert mine == pytest.approx(truth, rel=1e-9, abs=1e-15), f.name
            elif f.name == "goal_errors":
                assert [(e.frame, e.reached) for e in mine] == [
                    (e.frame, e.reached) for e in truth]
                for e, t in zip(mine, truth, strict=True):
                    assert e.position == pytest.approx(t.position, rel=1e-9, abs=1e-15)
                    assert e.rotation == pytest.approx(t.rotation, rel=1e-9, abs=1e-15)
            else:
                assert mine == truth, f.name
        assert repr(res).startswith("IKResult(q=array(")


def test_a_start_is_checked_as_before(arms: dict[str, Arm]) -> None:
    arm = arms["ur5e"]
    goal = PoseGoal(arm.fk(arm.middle()), tolerance=TOL)
    bad = arm.middle()
    bad[2] = math.nan
    with pytest.raises(InputError, match="NaN or infinite"):
        arm.ik(goal, bad)
    with pytest.raises(InputError, match="must have 6 values"):
        arm.ik(goal, np.zeros(5))
    # a list, integers and values outside the limits are taken, clipped into the limits
    res = arm.ik(goal, [0, 0, 0, 0, 0, 100])
    assert res.success and arm.within_limits(res.q)
    with pytest.raises(UnknownNameError, match="frame 'nowhere'"):
        arm.ik(PositionGoal([0.3, 0.0, 0.3], frame="nowhere"))
    with pytest.raises(UnsupportedGoalError, match="ccd"):
        arm.ik(LookAtGoal([0.5, 0.0, 0.2]), solver="ccd")


def test_options_that_need_the_full_path_still_work(arms: dict[str, Arm]) -> None:
    from armctl.ik import NullSpace

    arm = arms["panda"]
    pose = arm.fk(arm.sample(np.random.default_rng(3)))
    res = arm.ik(PoseGoal(pose, tolerance=TOL), options=IKOptions(nullspace=NullSpace(
        joint_limits=1.0)))
    assert res.success
    assert finish(arm, (PoseGoal(pose, tolerance=TOL),), res.q, solver="x",
                  status=IKStatus.CONVERGED, iterations=0, restarts=0, started=0.0).success


def test_an_unreachable_goal_gets_its_status_from_finish(arms: dict[str, Arm]) -> None:
    arm = arms["ur5e"]
    far = np.eye(4)
    far[:3, 3] = (3.0, 0.0, 0.5)
    res = arm.ik(PoseGoal(far, tolerance=TOL), options=IKOptions(restarts=3))
    assert not res.success
    assert res.status in (IKStatus.UNREACHABLE, IKStatus.MAX_ITERATIONS, IKStatus.SINGULAR)
    assert res.position_error > 1.0
    assert "position error" in res.message


def _pose_goal_python(pose: np.ndarray) -> PoseGoal:
    """A pose goal checked by the Python code alone."""
    saved = goals_module._COMPILED.pose_row
    goals_module._COMPILED.pose_row = None
    try:
        return PoseGoal(pose)
    finally:
        goals_module._COMPILED.pose_row = saved


def test_the_compiled_pose_check_accepts_and_packs_as_the_python_check(
        arms: dict[str, Arm]) -> None:
    arm = arms["panda"]
    arm.ik(PoseGoal(arm.fk(arm.middle())))  # loads the compiled solvers (and their checks)
    assert goals_module._COMPILED.pose_row is not None
    rng = np.random.default_rng(5)
    cases = list(arm.fk_batch(arm.sample(rng, 20)))
    base = cases[0]
    for scale in (1e-14, 1e-12, 1e-10, 1e-7):  # round-off, repaired, refused
        p = base.copy()
        p[:3, :3] *= 1.0 + scale
        cases.append(p)
    p = base.copy()
    p[3] = (0.0, 0.0, 0.0, 2.0)  # a last row that is not a transform's
    cases.append(p)
    p = base.copy()
    p[:3, 0] *= -1.0  # a reflection
    cases.append(p)
    p = base.copy()
    p[1, 3] = math.inf
    cases.append(p)
    compiled_rows = 0
    for pose in cases:
        try:
            truth = _pose_goal_python(pose)
        except InputError as exc:
            with pytest.raises(InputError) as got:
                PoseGoal(pose)
            assert str(got.value) == str(exc)
            continue
        goal = PoseGoal(pose)
        assert np.array_equal(goal.pose, truth.pose) and not goal.pose.flags.writeable
        assert np.array_equal(goal.packed(), truth.packed())
        assert np.array_equal(goal.packed_row()[0], truth.packed())
        compiled_rows += "_row" in goal.__dict__
    assert compiled_rows >= 20  # the clean ones went the compiled way


@pytest.mark.parametrize("name", ["ur5e", "panda", "so101"])
def test_a_batch_answers_each_problem_as_a_call_does(arms: dict[str, Arm], name: str) -> None:
    arm = arms[name]
    rng = np.random.default_rng(21)
    n = 150
    poses = arm.fk_batch(arm.sample(rng, n))
    starts = arm.sample(rng, n)
    sets = [(_goal(arm, p),) for p in poses]
    for solver in ("auto", "dls"):
        res = solve_batch(arm, sets, starts, solver, options=IKOptions(time_limit=5.0))
        calls = [arm.ik(s[0], q0, solver, options=IKOptions(time_limit=5.0))
                 for s, q0 in zip(sets, starts, strict=True)]
        assert res.success.tolist() == [c.success for c in calls]
        for i, c in enumerate(calls):
            assert np.allclose(res.q[i], c.q, rtol=0.0, atol=1e-12), i
            assert res.iterations[i] == c.iterations and res.restarts[i] == c.restarts


def test_auto_batches_add_the_closed_form_as_calls_do(arms: dict[str, Arm]) -> None:
    arm = arms["ur5e"]
    rng = np.random.default_rng(4)
    poses = arm.fk_batch(arm.sample(rng, 12))
    starts = arm.sample(rng, 12)
    sets = [(PoseGoal(p, tolerance=TOL),) for p in poses]
    # one iteration and no restart: the search alone solves few of them
    opts = IKOptions(max_iterations=1, restarts=0)
    dls = solve_batch(arm, sets, starts, "dls", options=opts)
    auto = solve_batch(arm, sets, starts, "auto", options=opts)
    calls = [arm.ik(s, q0, options=opts) for s, q0 in zip(sets, starts, strict=True)]
    assert dls.success.sum() < len(sets)
    assert auto.success.all()
    assert all(c.success for c in calls)
    for i, c in enumerate(calls):
        assert np.allclose(auto.q[i], c.q, atol=1e-12)


def test_threads_share_a_batch_without_changing_an_answer(arms: dict[str, Arm]) -> None:
    arm = arms["ur5e"]
    rng = np.random.default_rng(8)
    poses = arm.fk_batch(arm.sample(rng, 300))
    starts = arm.sample(rng, 300)
    one = solve_batch(arm, poses, starts, tolerance=TOL, workers=1)
    three = solve_batch(arm, poses, starts, tolerance=TOL, workers=3)
    default = solve_batch(arm, poses, starts, tolerance=TOL)
    for res in (three, default):
        assert np.array_equal(res.q, one.q)
        assert res.success.tolist() == one.success.tolist()
        assert res.status == one.status
        assert np.array_equal(res.iterations, one.iterations)
    assert one.success.all()
    with pytest.raises(InputError, match="workers must be at least 1"):
        solve_batch(arm, poses[:2], starts[:2], tolerance=TOL, workers=0)


def test_every_form_of_start_and_options_gives_the_same_answer(arms: dict[str, Arm]) -> None:
    # the short path calls the compiled code directly for the types it has seen, and through
    # the dispatcher (which checks types) for anything else: the answers must not differ
    arm = arms["panda"]
    rng = np.random.default_rng(9)
    for pose, start in zip(arm.fk_batch(arm.sample(rng, 8)), arm.sample(rng, 8), strict=True):
        goal = PoseGoal(pose, tolerance=TOL)
        ref = arm.ik(goal, start.copy())
        frozen = start.copy()
        frozen.setflags(write=False)
        wide = np.zeros((arm.dof, 2))
        wide[:, 0] = start
        forms = [frozen, wide[:, 0], start.tolist(), np.asfortranarray(start)]
        runs = [arm.ik(goal, f) for f in forms]
        runs.append(arm.ik(goal, start, options=IKOptions(max_iterations=100, restarts=50)))
        runs.append(arm.ik(goal, start, options=IKOptions(time_limit=1)))  # an int: dispatched
        for res in runs:
            assert res.success == ref.success
            assert np.array_equal(res.q, ref.q)
            assert res.iterations == ref.iterations


def test_a_pose_array_batch_is_checked_and_packed_as_its_goals(arms: dict[str, Arm]) -> None:
    arm = arms["ur5e"]
    rng = np.random.default_rng(12)
    poses = arm.fk_batch(arm.sample(rng, 40))
    starts = arm.sample(rng, 40)
    as_goals = solve_batch(arm, [PoseGoal(p, tolerance=TOL) for p in poses], starts,
                           tolerance=TOL)
    for variant in (poses, poses.copy()):
        if variant is not poses:
            variant[5, :3, :3] *= 1.0 + 1e-11  # a rotation the goal repairs: the slow way
        res = solve_batch(arm, variant, starts, tolerance=TOL)
        assert res.success.all()
        if variant is poses:
            assert np.array_equal(res.q, as_goals.q)
    bad = poses.copy()
    bad[3, :3, 0] *= -1.0  # a reflection: refused as a pose goal refuses it
    with pytest.raises(InputError, match="not a rotation matrix"):
        solve_batch(arm, bad, starts, tolerance=TOL)
