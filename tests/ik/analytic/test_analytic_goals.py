"""Singular and unreachable goals, 4- and 5-DOF goals, position goals."""

from __future__ import annotations

import numpy as np
import pytest
from analytic_arms import PUMA560, dh_arm

from armctl.arm import Arm, load_arm
from armctl.ik import DirectionGoal, PositionGoal
from armctl.ik.analytic import Family, classify, ik_all
from armctl.ik.analytic.classify import GoalKind

TOL = 1e-9


def _wrapped(a: np.ndarray) -> np.ndarray:
    return np.abs((a + np.pi) % (2 * np.pi) - np.pi)


def _exact(arm: Arm, sols_q: np.ndarray, check: object) -> None:
    assert np.all(np.isfinite(sols_q))
    for q in sols_q:
        dp, dr = check(arm.fk(q))  # type: ignore[operator]
        assert dp <= TOL and dr <= TOL


@pytest.mark.parametrize("name", ["ur5e", "wx250s"])
@pytest.mark.parametrize("q5", [0.0, 1e-12, 1e-9, 1e-6, 1e-3, np.pi])
def test_wrist_singular_and_near_singular_goals(name: str, q5: float) -> None:
    arm = load_arm(name)
    rng = np.random.default_rng(8)
    wrist = 4  # the joint whose zero aligns the first and last wrist axes
    for q in arm.sample(rng, 30):
        q[wrist] = q5 if name == "ur5e" or q5 < 1 else 0.0
        goal = arm.fk(q)
        sols = ik_all(arm, goal, q_ref=q)
        assert len(sols) > 0
        assert sols.position_error.max() <= TOL and sols.rotation_error.max() <= TOL
        _exact(arm, sols.q, lambda t, g=goal: (np.linalg.norm(t[:3, 3] - g[:3, 3]),
                                               np.abs(t[:3, :3] - g[:3, :3]).max()))
        if q5 == 0.0 or (name == "ur5e" and q5 == np.pi):
            assert sols.singular  # a continuum: representatives, flagged
        if q5 >= 1e-6 and not sols.singular:
            gap = _wrapped(sols.q[:, :6] - q[:6]).max(axis=1).min()
            assert gap < 1e-5


def test_stretched_elbow_and_unreachable_goals() -> None:
    arm = load_arm("ur5e")
    rng = np.random.default_rng(9)
    for q in arm.sample(rng, 50):
        q[2] = 0.0  # elbow stretched: the workspace boundary (a double root)
        goal = arm.fk(q)
        sols = ik_all(arm, goal, q_ref=q)
        assert sols.position_error.max() <= TOL and sols.rotation_error.max() <= TOL
        assert _wrapped(sols.q - q).max(axis=1).min() < 1e-6
        far = goal.copy()
        far[:3, 3] *= 3.0 / np.linalg.norm(far[:3, 3])  # 3 m away: out of reach
        assert len(ik_all(arm, far)) == 0
        beyond = goal.copy()
        beyond[:3, 3] += 1e-4 * goal[:3, 3] / np.linalg.norm(goal[:3, 3])  # just past the edge
        nearly = ik_all(arm, beyond)
        assert np.all(np.isfinite(nearly.q)) and np.all(nearly.position_error <= TOL)


def test_spherical_wrist_singularity_on_a_puma() -> None:
    arm = dh_arm("puma", PUMA560)
    q = np.array([0.3, -0.4, 0.2, 1.0, 0.0, -0.5])
    sols = ik_all(arm, arm.fk(q), q_ref=q)
    assert sols.singular and len(sols) > 0
    assert sols.position_error.max() <= TOL and sols.rotation_error.max() <= TOL
    # representatives keep q4 at its reference and put the whole wrist turn on q6
    assert _wrapped(sols.q[:, 3:6:2].sum(axis=1) - (q[3] + q[5])).min() < 1e-9


@pytest.mark.parametrize("axis", [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0)])
def test_so101_position_and_tool_direction(axis: tuple[float, float, float]) -> None:
    arm = load_arm("so101")
    assert classify(arm, kind=GoalKind.DIRECTION).family is Family.PARALLEL_DIRECTION
    a = np.array(axis)
    rng = np.random.default_rng(12)
    chain = list(arm.chain())
    for q in arm.sample(rng, 200):
        t = arm.fk(q)
        goal = DirectionGoal(t[:3, 3], t[:3, :3] @ a, axis=a)
        sols = ik_all(arm, goal, q_ref=q)
        _exact(arm, sols.q, goal.errors)
        assert _wrapped(sols.q[:, chain] - q[chain]).max(axis=1).min() < 1e-6


def test_omx_position_and_reachable_direction() -> None:
    arm = load_arm("omx")
    assert classify(arm, kind=GoalKind.DIRECTION).family is Family.YAW_PARALLEL_DIRECTION
    a = np.array([1.0, 0.0, 0.0])
    rng = np.random.default_rng(13)
    chain = list(arm.chain())
    for q in arm.sample(rng, 200):
        t = arm.fk(q)
        goal = DirectionGoal(t[:3, 3], t[:3, :3] @ a, axis=a)
        sols = ik_all(arm, goal, q_ref=q)
        _exact(arm, sols.q, goal.errors)
        assert _wrapped(sols.q[:, chain] - q[chain]).max(axis=1).min() < 1e-6
        # a direction out of the arm's vertical plane cannot be reached: no false solution
        off = DirectionGoal(t[:3, 3], t[:3, :3] @ [0.0, 1.0, 0.0] * 0.3 + t[:3, :3] @ a,
                            axis=a)
        assert all(off.reached(arm.fk(qq)) for qq in ik_all(arm, off).q)


@pytest.mark.parametrize("name", ["so101", "omx", "ur5e", "wx250s", "panda"])
def test_position_goals_hold_the_other_joints(name: str) -> None:
    arm = load_arm(name)
    dec = classify(arm, kind=GoalKind.POSITION)
    rng = np.random.default_rng(14)
    for q in arm.sample(rng, 100):
        goal = PositionGoal(arm.fk(q)[:3, 3])
        sols = ik_all(arm, goal, q_ref=q)
        _exact(arm, sols.q, goal.errors)
        assert np.allclose(sols.q[:, list(dec.free)], q[list(dec.free)])  # held at q_ref
        solved = list(dec.solved)
        assert _wrapped(sols.q[:, solved] - q[solved]).max(axis=1).min() < 1e-6


def test_shoulder_singularity_wrist_centre_on_the_first_axis() -> None:
    from scipy.optimize import brentq

    # an anthropomorphic arm without shoulder offset: its wrist centre can lie on axis 1
    arm = dh_arm("anthropomorphic", [(0.3, 0.0, np.pi / 2), (0.0, 0.4, 0.0),
                                     (0.0, 0.0, np.pi / 2), (0.35, 0.0, -np.pi / 2),
                                     (0.0, 0.0, np.pi / 2), (0.1, 0.0, 0.0)])

    def centre_x(q3: float) -> float:
        t = arm.fk(np.array([0.0, 1.2, q3, 0.0, 0.0, 0.0]))
        return float((t[:3, 3] - 0.1 * t[:3, 2])[0])

    grid = np.linspace(-np.pi, np.pi, 200)
    k = next(i for i in range(199) if centre_x(grid[i]) * centre_x(grid[i + 1]) < 0)
    q3 = brentq(centre_x, grid[k], grid[k + 1], xtol=1e-15)
    for q1 in (0.7, -2.0):
        q = np.array([q1, 1.2, q3, 0.5, 0.8, -0.4])
        sols = ik_all(arm, arm.fk(q), q_ref=q)
        assert sols.singular and len(sols) > 0
        assert sols.position_error.max() <= TOL and sols.rotation_error.max() <= TOL
        assert _wrapped(sols.q - q).max(axis=1).min() < 1e-9  # q1 taken from q_ref
        assert np.allclose(_wrapped(ik_all(arm, arm.fk(q)).q[:, 0]), 0.0, atol=1e-9)
