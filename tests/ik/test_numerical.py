"""The numerical solvers on bundled and test arms: honest success, limits, goal types, restarts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.errors import InputError
from armctl.ik import (
    DirectionGoal,
    IKOptions,
    IKStatus,
    OrientationGoal,
    PoseGoal,
    PositionGoal,
    Tolerance,
    available_solvers,
)
from armctl.spatial import pose_error, rpy_to_matrix

DATA = Path(__file__).parent / "data"
NUMERICAL = ("pinv", "dls", "jt", "ccd", "ccd-jt", "auto")
TIGHT = Tolerance(1e-6, 1e-6)


def _arm(name: str) -> Arm:
    path = DATA / f"{name}.yaml"
    return load_arm(path if path.exists() else name)


def _goal(arm: Arm, q: np.ndarray, kind: str, tol: Tolerance = TIGHT, frame: str | None = None):
    t = arm.fk(q, frame)
    if kind == "pose":
        return PoseGoal(t, tolerance=tol, frame=frame)
    if kind == "position":
        return PositionGoal(t[:3, 3], tolerance=tol, frame=frame)
    if kind == "orientation":
        return OrientationGoal(t[:3, :3], tolerance=tol, frame=frame)
    return DirectionGoal(t[:3, 3], t[:3, 2], tolerance=tol, frame=frame)


def _independent_check(arm: Arm, goal, q: np.ndarray) -> bool:
    """Whether FK(q) meets the goal, computed without the goal's own code."""
    t = arm.fk(q, goal.frame)
    tol = goal.tolerance
    if isinstance(goal, PoseGoal):
        err = pose_error(t, goal.pose)
        return bool(np.linalg.norm(err[:3]) <= tol.position and np.linalg.norm(err[3:])
                    <= tol.rotation)
    if isinstance(goal, PositionGoal):
        return bool(np.linalg.norm(t[:3, 3] - goal.position) <= tol.position)
    if isinstance(goal, OrientationGoal):
        target = np.eye(4)
        target[:3, :3] = goal.rotation
        return bool(np.linalg.norm(pose_error(t, target)[3:]) <= tol.rotation)
    a = t[:3, :3] @ goal.axis
    ang = np.arccos(np.clip(a @ goal.direction, -1, 1))
    return bool(np.linalg.norm(t[:3, 3] - goal.position) <= tol.position and ang <= tol.rotation)


def _budget(solver: str) -> IKOptions:
    slow = solver in ("jt", "ccd", "ccd-jt")
    return IKOptions(max_iterations=300 if slow else 100, restarts=2 if slow else 30,
                     time_limit=1.0, seed=3)


def test_registry_lists_every_numerical_solver():
    assert set(NUMERICAL) <= set(available_solvers())


# bundled arms by name, test arms from tests/ik/data
CASES = [("ur5e", "pose"), ("panda", "pose"), ("wx250s", "pose"), ("so101", "direction"),
         ("omx", "position"), ("torso", "pose"), ("ur5e_dh", "pose"), ("panda_dh", "pose"),
         ("scara", "position"), ("arm5", "direction")]


@pytest.mark.parametrize("solver", NUMERICAL)
@pytest.mark.parametrize(("arm_name", "kind"), CASES)
def test_success_is_never_claimed_falsely(solver: str, arm_name: str, kind: str):
    arm = _arm(arm_name)
    rng = np.random.default_rng(11)
    qs = arm.sample(rng, 12)
    wins = 0
    for q in qs:
        goal = _goal(arm, q, kind)
        res = arm.ik(goal, solver=solver, options=_budget(solver))
        assert arm.within_limits(res.q)
        assert res.success == _independent_check(arm, goal, res.q)
        assert res.success == (res.status is IKStatus.CONVERGED)
        wins += res.success
    if solver in ("dls", "auto"):
        assert wins >= 11, f"{solver} reached only {wins}/12 reachable goals on {arm_name}"
    elif solver == "pinv":
        assert wins >= 9, f"pinv reached only {wins}/12 reachable goals on {arm_name}"
    elif kind == "position":
        assert wins >= 6, f"{solver} reached only {wins}/12 position goals on {arm_name}"


@pytest.mark.parametrize("kind", ["position", "orientation", "direction", "pose"])
@pytest.mark.parametrize("arm_name", ["ur5e", "panda"])
def test_every_goal_type_with_dls(arm_name: str, kind: str):
    arm = _arm(arm_name)
    rng = np.random.default_rng(5)
    for q in arm.sample(rng, 15):
        goal = _goal(arm, q, kind)
        res = arm.ik(goal, solver="dls")
        assert res.success, res.message
        assert _independent_check(arm, goal, res.q)


def test_goal_for_another_frame_and_two_hands_at_once():
    arm = _arm("torso")
    rng = np.random.default_rng(2)
    hands = arm.end_effectors
    assert len(hands) == 2
    for q in arm.sample(rng, 10):
        goals = [_goal(arm, q, "pose", frame=h) for h in hands]
        res = arm.ik(goals, solver="dls", options=IKOptions(seed=1))
        assert res.success, res.message
        assert all(_independent_check(arm, g, res.q) for g in goals)
        assert len(res.goal_errors) == 2
    # a goal for an intermediate link frame
    arm2 = _arm("ur5e")
    q = arm2.sample(rng)
    goal = _goal(arm2, q, "position", frame="wrist_1_link")
    res = arm2.ik(goal, solver="dls")
    assert res.success and _independent_check(arm2, goal, res.q)


def test_unreachable_position_is_reported_with_the_closest_q():
    arm = _arm("ur5e")
    res = arm.ik(PositionGoal([3.0, 0.0, 0.5]), solver="dls",
                 options=IKOptions(restarts=5, time_limit=5.0))
    assert not res.success
    assert res.status is IKStatus.UNREACHABLE
    assert arm.within_limits(res.q)
    reach = np.linalg.norm(arm.fk(res.q)[:3, 3])
    assert res.position_error == pytest.approx(np.linalg.norm(arm.fk(res.q)[:3, 3]
                                                              - [3.0, 0, 0.5]))
    assert reach > 0.9  # the closest configuration stretches towards the goal


@pytest.mark.parametrize("solver", ["dls", "auto", "pinv"])
def test_orientation_impossible_for_a_five_joint_arm(solver: str):
    arm = _arm("arm5")
    rng = np.random.default_rng(4)
    q = arm.sample(rng)
    t = arm.fk(q)
    # keep the position, turn the tool about the base's vertical axis: a 5-joint arm cannot
    # both keep the tool axis and change the heading without moving the point
    bad = t.copy()
    bad[:3, :3] = rpy_to_matrix([0.0, 0.0, 0.9]) @ t[:3, :3]
    res = arm.ik(PoseGoal(bad), solver=solver, options=IKOptions(restarts=10, time_limit=5.0))
    assert not res.success
    assert res.status is IKStatus.UNREACHABLE
    # the same position with the 5-DOF goal is reachable
    ok = arm.ik(DirectionGoal(t[:3, 3], t[:3, 2]), solver=solver)
    assert ok.success


def test_same_seed_same_answer_and_restarts_are_used():
    arm = _arm("panda")
    rng = np.random.default_rng(8)
    q = arm.sample(rng)
    goal = _goal(arm, q, "pose")
    start = arm.lower + 1e-3  # a corner of the joint box: the first attempt rarely converges
    opts = IKOptions(max_iterations=12, restarts=100, seed=42, time_limit=5.0)
    a = arm.ik(goal, start, solver="dls", options=opts)
    b = arm.ik(goal, start, solver="dls", options=opts)
    assert a.success and b.success
    assert np.array_equal(a.q, b.q)
    assert a.restarts == b.restarts >= 1
    c = arm.ik(goal, start, solver="dls", options=IKOptions(max_iterations=12, restarts=100,
                                                             seed=43, time_limit=5.0))
    assert c.success


def test_gripper_joints_keep_their_start_value():
    arm = _arm("so101")
    rng = np.random.default_rng(9)
    q = arm.sample(rng)
    grip = arm.joint_index("gripper")
    start = arm.lower + 0.01  # a corner: the first attempt fails, restarts follow
    start[grip] = 0.3
    res = arm.ik(_goal(arm, q, "direction"), start, solver="dls",
                 options=IKOptions(max_iterations=8, restarts=300, time_limit=5.0))
    assert res.success and res.restarts >= 1
    assert res.q[grip] == start[grip]


def test_continuous_joints_are_wrapped():
    arm = _arm("scara")
    rng = np.random.default_rng(1)
    for q in arm.sample(rng, 5):
        res = arm.ik(_goal(arm, q, "pose"), solver="dls")
        assert res.success
        assert -np.pi <= res.q[3] < np.pi


def test_constraints_are_refused_by_numerical_solvers():
    arm = _arm("ur5e")
    for solver in NUMERICAL:
        with pytest.raises(InputError, match="nlp"):
            arm.ik(PositionGoal([0.3, 0.2, 0.3]), solver=solver, constraints=[object()])


def test_time_limit_status():
    arm = _arm("ur5e")
    res = arm.ik(PositionGoal([3.0, 0.0, 0.5]), solver="dls",
                 options=IKOptions(max_iterations=2, restarts=10**8, time_limit=0.02))
    assert res.status is IKStatus.TIME_LIMIT
    assert not res.success


def test_error_trace_of_the_first_attempt():
    from armctl.ik.numerical import run_method

    arm = _arm("ur5e")
    rng = np.random.default_rng(6)
    goal = _goal(arm, arm.middle() + rng.uniform(-0.4, 0.4, arm.dof), "pose")  # near the start
    trace = np.empty((60, 2))
    res = run_method("dls", arm, (goal,), arm.middle(), IKOptions(restarts=0), (), trace=trace)
    assert res.success
    done = trace[~np.isnan(trace[:, 0])]
    assert len(done) == res.iterations + 1  # the error before each step and at the end
    assert done[-1, 0] <= TIGHT.position and done[-1, 1] <= TIGHT.rotation
    assert done[0, 0] == pytest.approx(np.linalg.norm(arm.fk(arm.middle())[:3, 3]
                                                      - goal.position))


@pytest.mark.parametrize("solver", ["pinv", "jt", "ccd", "ccd-jt"])
def test_orientation_goals_for_every_method(solver: str):
    arm = _arm("ur5e")
    rng = np.random.default_rng(12)
    loose = Tolerance(1e-4, 1e-4)
    wins = 0
    for q in arm.sample(rng, 6):
        goal = _goal(arm, q, "orientation", loose)
        res = arm.ik(goal, solver=solver, options=IKOptions(max_iterations=500, restarts=3,
                                                            time_limit=2.0))
        assert res.success == _independent_check(arm, goal, res.q)
        wins += res.success
    assert wins >= 4, f"{solver} reached {wins}/6 orientation goals"


def test_auto_falls_back_to_the_closed_form():
    arm = _arm("ur5e")
    rng = np.random.default_rng(3)
    goal = _goal(arm, arm.sample(rng), "pose")
    starved = IKOptions(max_iterations=1, restarts=0)  # too little for the numerical search
    assert not arm.ik(goal, solver="dls", options=starved).success
    res = arm.ik(goal, solver="auto", options=starved)
    assert res.success and res.solver == "auto"
    assert _independent_check(arm, goal, res.q)
