from pathlib import Path

import numpy as np
import pytest

from armctl.errors import InputError
from armctl.ik import IKStatus, PoseGoal, PositionGoal, available_solvers
from armctl.ik.nlp import (
    AxisInCone,
    InBox,
    InHalfSpace,
    InSphere,
    KeepOutBox,
    KeepOutSphere,
    Method,
    NLPOptions,
    OnLine,
    OnPlane,
    build_count,
    clear_cache,
)
from armctl.kinematics.capsules import arm_capsules, segment_point_distance, world_segments


def load_arm_text(folder, text):
    from armctl.arm import load_arm

    path = folder / "arm.yaml"
    path.write_text(text)
    return load_arm(path)


def _pos(arm, q, frame=None):
    return arm.fk(q, frame)[:3, 3]


def _inside(arm, q):
    return bool(np.all(q >= arm.lower - 1e-12) and np.all(q <= arm.upper + 1e-12))


@pytest.mark.parametrize("name", ["ur5e", "panda"])
def test_reachable_pose_goals_agree_with_fk(name, request):
    arm = request.getfixturevalue(name)
    rng = np.random.default_rng(11)
    for _ in range(15):
        target = arm.fk(arm.sample(rng))
        res = arm.ik(PoseGoal(target), solver="nlp", options=NLPOptions(time_limit=1.0))
        assert res.success, res.message
        assert _inside(arm, res.q)
        reached = arm.fk(res.q)
        assert np.linalg.norm(reached[:3, 3] - target[:3, 3]) <= 1e-5
        assert np.abs(reached[:3, :3] - target[:3, :3]).max() <= 1e-4


def test_same_reachable_goals_as_dls(ur5e):
    assert "dls" in available_solvers()
    rng = np.random.default_rng(4)
    for _ in range(10):
        target = ur5e.fk(ur5e.sample(rng))
        dls = ur5e.ik(target, solver="dls")
        nlp = ur5e.ik(target, solver="nlp", options=NLPOptions(time_limit=1.0))
        if dls.success:
            assert nlp.success, nlp.message


def test_target_change_does_not_rebuild_and_warm_start_streams(panda):
    clear_cache()
    rng = np.random.default_rng(5)
    q = panda.sample(rng)
    res = panda.ik(PoseGoal(panda.fk(q)), q, solver="nlp")
    assert res.success
    builds = build_count()
    qt = q.copy()
    for _ in range(20):  # a moving target, each solve starting from the previous answer
        qt = np.clip(qt + 0.01 * rng.standard_normal(panda.dof), panda.lower, panda.upper)
        res = panda.ik(PoseGoal(panda.fk(qt)), res.q, solver="nlp")
        assert res.success, res.message
        assert res.restarts == 0
    assert build_count() == builds
    # a different goal structure does build
    panda.ik(PositionGoal(_pos(panda, qt)), res.q, solver="nlp")
    assert build_count() == builds + 1


def test_joint_limits_hold_for_unreachable_goals(ur5e):
    far = np.eye(4)
    far[:3, 3] = [2.0, 0.0, 0.5]
    res = ur5e.ik(far, solver="nlp", options=NLPOptions(time_limit=0.05))
    assert not res.success
    assert _inside(ur5e, res.q)
    assert res.status is not IKStatus.CONVERGED


def test_two_parallel_planes_are_infeasible(ur5e):
    target = _pos(ur5e, ur5e.middle())
    cons = [OnPlane([0, 0, 0.1], [0, 0, 1]), OnPlane([0, 0, 0.5], [0, 0, 1])]
    res = ur5e.ik(PositionGoal(target), solver="nlp", constraints=cons,
                  options=NLPOptions(time_limit=0.3))
    assert not res.success
    assert res.status is IKStatus.INFEASIBLE
    assert len(res.constraint_errors) == 2
    assert any(not e.satisfied and e.hard for e in res.constraint_errors)
    # the best compromise sits between the planes: neither violation exceeds their distance
    z = _pos(ur5e, res.q)[2]
    assert all(e.violation <= 0.4 + 1e-6 for e in res.constraint_errors)
    assert np.isclose(abs(z - 0.1) + abs(z - 0.5), 0.4, atol=1e-3) or z > 0.5 or z < 0.1
    assert _inside(ur5e, res.q)


def _check_hard(arm, q, cons):
    """Independent check of every hard constraint (FK and geometry written here)."""
    caps = arm_capsules(arm)
    a, b = world_segments(arm, q, caps)
    for c in cons:
        if not c.hard:
            continue
        p = _pos(arm, q, c.frame)
        tol = c.tolerance * 1.0001
        if isinstance(c, OnPlane):
            assert abs(c.normal @ (p - c.point)) <= tol
        elif isinstance(c, InHalfSpace):
            assert c.normal @ (p - c.point) >= -tol
        elif isinstance(c, OnLine):
            d = p - c.point
            assert np.linalg.norm(np.cross(d, c.direction)) <= tol
        elif isinstance(c, InBox):
            assert np.all(p >= c.lower - tol) and np.all(p <= c.upper + tol)
        elif isinstance(c, InSphere):
            assert np.linalg.norm(p - c.center) <= c.radius + tol
        elif isinstance(c, AxisInCone):
            axis = arm.fk(q, c.frame)[:3, :3] @ c.axis
            assert np.arccos(np.clip(axis @ c.direction, -1, 1)) <= c.half_angle + tol
        elif isinstance(c, KeepOutSphere):
            for k, cap in enumerate(caps):
                d = segment_point_distance(a[k], b[k], c.center)
                assert d >= c.radius + cap.radius - tol
        elif isinstance(c, KeepOutBox):
            for k, cap in enumerate(caps):
                ts = np.linspace(0, 1, 201)
                pts = a[k] + ts[:, None] * (b[k] - a[k])
                gap = np.linalg.norm(np.maximum(np.maximum(c.lower - pts, pts - c.upper), 0),
                                     axis=1)
                assert gap.min() >= cap.radius - tol


def _random_constraints(arm, rng, q_feasible):
    """Constraints that q_feasible satisfies (so the problem is feasible), drawn at random."""
    p = _pos(arm, q_feasible)
    rot = arm.fk(q_feasible)[:3, :3]
    out = []
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    kinds = rng.choice(6, size=2, replace=False)
    for k in kinds:
        if k == 0:
            out.append(OnPlane(p + 0.0 * n, n))
        elif k == 1:
            out.append(InHalfSpace(p - 0.05 * n, n))
        elif k == 2:
            out.append(OnLine(p, n))
        elif k == 3:
            out.append(InBox(p - 0.1, p + 0.1))
        elif k == 4:
            out.append(InSphere(p + 0.05 * n, 0.1))
        else:
            out.append(AxisInCone(rot[:, 2], 0.3))
    return out


def test_random_constrained_problems_never_claim_false_success(ur5e):
    rng = np.random.default_rng(21)
    claimed = 0
    for _ in range(12):
        q_feasible = ur5e.sample(rng)
        cons = _random_constraints(ur5e, rng, q_feasible)
        # q_feasible meets goal and constraints together; the solve starts elsewhere
        goal = PositionGoal(_pos(ur5e, q_feasible))
        res = ur5e.ik(goal, ur5e.sample(rng), solver="nlp", constraints=cons,
                      options=NLPOptions(time_limit=0.2))
        assert _inside(ur5e, res.q)
        if res.success:
            claimed += 1
            _check_hard(ur5e, res.q, cons)
        hard_errors = [e for e in res.constraint_errors if e.hard]
        if all(e.satisfied for e in hard_errors) and all(g.reached for g in res.goal_errors):
            assert res.success
    assert claimed >= 10


def test_constraints_reached_exactly_when_compatible(ur5e):
    rng = np.random.default_rng(8)
    q = ur5e.sample(rng)
    p = _pos(ur5e, q)
    rot = ur5e.fk(q)[:3, :3]
    cons = [OnPlane(p, [0, 0, 1]), AxisInCone(rot[:, 2], 0.2), InSphere(p, 0.3),
            KeepOutSphere(p + np.array([0, 0, 0.4]), 0.05)]
    res = ur5e.ik(PositionGoal(p), solver="nlp", constraints=cons,
                  options=NLPOptions(time_limit=1.0))
    assert res.success, res.message
    _check_hard(ur5e, res.q, cons)


def test_keep_out_moves_the_links_away(twoarm):
    # obstacles on the left elbow link and beside the forearm in the start posture (the middle
    # of the ranges); the goal: the tip position of a random posture that clears them
    middle = twoarm.middle()
    caps = arm_capsules(twoarm)
    a, b = world_segments(twoarm, middle, caps)
    k = [c.link for c in caps].index("la2")
    mid = (a[k] + b[k]) / 2
    obstacles = [KeepOutSphere(mid, 0.05), KeepOutBox(b[k] - 0.03, b[k] + 0.03)]
    assert all(c.violation(twoarm, middle) > 0.01 for c in obstacles)
    rng = np.random.default_rng(3)
    for _ in range(100):
        q = twoarm.sample(rng)
        if all(c.violation(twoarm, q) == 0 for c in obstacles):
            break
    _check_hard(twoarm, q, obstacles)
    target = _pos(twoarm, q, "left_tip")
    res = twoarm.ik(PositionGoal(target, frame="left_tip"), middle, solver="nlp",
                    constraints=obstacles, options=NLPOptions(time_limit=1.0))
    assert res.success, res.message
    _check_hard(twoarm, res.q, obstacles)


def test_soft_constraint_is_traded_against_the_goal(planar):
    # the planar arm's tip wants x = 0.5; a weighted plane x = 0.3 pulls it back
    goal = PositionGoal([0.5, 0.1, 0.0])
    plane = OnPlane([0.3, 0, 0], [1, 0, 0], weight=1.0)
    res = planar.ik(goal, solver="nlp", constraints=[plane], options=NLPOptions(restarts=0))
    x = _pos(planar, res.q)[0]
    assert 0.3 + 1e-3 < x < 0.5 - 1e-3  # in between: a compromise
    assert not res.success  # the goal itself is not met
    assert not res.constraint_errors[0].hard


def test_several_end_effectors_at_once(twoarm):
    rng = np.random.default_rng(9)
    q = twoarm.sample(rng)
    goals = [PositionGoal(_pos(twoarm, q, "left_tip"), frame="left_tip"),
             PositionGoal(_pos(twoarm, q, "right_tip"), frame="right_tip")]
    res = twoarm.ik(goals, solver="nlp", options=NLPOptions(time_limit=1.0))
    assert res.success, res.message
    for g in goals:
        assert np.linalg.norm(_pos(twoarm, res.q, g.frame) - g.position) <= 1e-5


def test_sqp_method_solves_pose_goals(ur5e):
    rng = np.random.default_rng(13)
    q = ur5e.sample(rng)
    start = np.clip(q + 0.05, ur5e.lower, ur5e.upper)
    res = ur5e.ik(ur5e.fk(q), start, solver="nlp",
                  options=NLPOptions(method=Method.SQP, time_limit=1.0))
    assert res.success, res.message


def test_bad_constraints_are_rejected(ur5e):
    with pytest.raises(InputError):
        ur5e.ik(np.eye(4), solver="nlp", constraints=["plane"])
    with pytest.raises(InputError):
        OnPlane([0, 0, 0], [0, 0, 0])
    with pytest.raises(InputError):
        InBox([1, 0, 0], [0, 1, 1])
    with pytest.raises(InputError, match="every moving link"):
        KeepOutSphere([0, 0, 0], 0.1, frame="flange")
    with pytest.raises(InputError):
        OnPlane([0, 0, 0], [0, 0, 1], weight=0.0)
    with pytest.raises(InputError):
        NLPOptions(regularization=-1)


@pytest.mark.parametrize("method", [Method.AUTO, Method.IPOPT])
def test_orientation_and_direction_goals(ur5e, method):
    from armctl.ik import DirectionGoal, OrientationGoal

    rng = np.random.default_rng(31)
    for _ in range(3):
        t = ur5e.fk(ur5e.sample(rng))
        goals = [OrientationGoal(t[:3, :3]), DirectionGoal(t[:3, 3], t[:3, 2])]
        for goal in goals:
            res = ur5e.ik(goal, solver="nlp", options=NLPOptions(method=method, time_limit=1.0))
            assert res.success, res.message
            reached = ur5e.fk(res.q)
            if isinstance(goal, OrientationGoal):
                assert np.abs(reached[:3, :3] - t[:3, :3]).max() <= 1e-4
            else:
                assert np.linalg.norm(reached[:3, 3] - t[:3, 3]) <= 1e-5
                assert np.arccos(min(1.0, reached[:3, 2] @ t[:3, 2])) <= 1e-4


def test_continuous_joints_and_soft_keep_out(tmp_path):
    text = (Path(__file__).parents[2] / "data" / "planar3r.yaml").read_text()
    arm = load_arm_text(tmp_path, text.replace("type: revolute, parent: base",
                                               "type: continuous, parent: base")
                        .replace("axis: [0, 0, 1], limits: {lower: -3, upper: 3}}\n  - {name: j2",
                                 "axis: [0, 0, 1]}\n  - {name: j2", 1))
    assert not np.isfinite(arm.lower[0])
    res = arm.ik(PositionGoal([-0.4, -0.3, 0.0]), solver="nlp")
    assert res.success, res.message
    # a weighted keep-out sphere around the elbow region: a cost, never a failure by itself
    soft = KeepOutSphere([0.0, 0.0, 0.0], 0.05, weight=1.0)
    res = arm.ik(PositionGoal([0.3, 0.3, 0.0]), solver="nlp", constraints=[soft])
    assert not soft.hard and res.constraint_errors[0].hard is False
    assert res.success == all(g.reached for g in res.goal_errors)


def test_hard_constraints_use_the_exact_hessian_and_skip_the_regularisation(ur5e, capfd):
    from armctl.ik.nlp.problem import get_problem

    rng = np.random.default_rng(5)
    q = ur5e.sample(rng)
    p = _pos(ur5e, q)
    cons = [InHalfSpace(p - 0.05 * np.array([0, 0, 1.0]), [0, 0, 1.0])]
    goal = PositionGoal(p)
    opts = NLPOptions(time_limit=1.0)
    assert get_problem(ur5e, (goal,), cons, opts).exact_hessian
    assert not get_problem(ur5e, (goal,), [], opts).exact_hessian  # goals alone: Gauss-Newton
    res = ur5e.ik(goal, ur5e.sample(rng), solver="nlp", constraints=cons, options=opts)
    assert res.success, res.message
    _check_hard(ur5e, res.q, cons)
    assert np.linalg.norm(_pos(ur5e, res.q) - p) <= 1e-5
    # a zero regularisation weight is a valid parameter (no NaN in CasADi's derivatives)
    res = ur5e.ik(goal, ur5e.sample(rng), solver="nlp", constraints=cons,
                  options=NLPOptions(time_limit=1.0, regularization=0.0, seed=3))
    assert res.success, res.message
    out, err = capfd.readouterr()
    assert "NaN" not in out + err


def test_preferred_posture_still_chooses_with_hard_constraints(panda):
    # the regularisation applies with hard constraints when a preferred posture is given
    q_pref = panda.middle()
    target = _pos(panda, q_pref)
    cons = [InSphere(target, 0.05)]
    start = np.clip(q_pref + 0.4, panda.lower, panda.upper)
    res = panda.ik(PositionGoal(target), start, solver="nlp", constraints=cons,
                   options=NLPOptions(preferred=tuple(q_pref), regularization=1e-3,
                                      time_limit=1.0))
    assert res.success, res.message
    _check_hard(panda, res.q, cons)
    assert np.linalg.norm(res.q - q_pref) < 0.05
