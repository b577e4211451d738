"""CCD's closed-form joint step against a brute-force 1-D maximisation of its objective.

The objective is the one of the CCD derivation in the lecture (L. Kavan, *Metody skeletální
animace*, 2002).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.ik import DirectionGoal, IKOptions, OrientationGoal, PoseGoal, PositionGoal
from armctl.ik import _engine as E
from armctl.ik._pack import pack_goals

DATA = Path(__file__).parent / "data"
RHO2 = 0.04  # weight of the orientation term [m^2]


def _objective_by_fk(arm: Arm, goals, q: np.ndarray, j: int, theta: float,
                     w1: float = 1.0, w2: float = RHO2) -> float:
    """The lecture's g(theta) = sum_goals w1 g1 + w2 g2, evaluated by forward kinematics."""
    qt = q.copy()
    qt[j] += theta
    child = arm.spec.joint(arm.joint_names[j]).child
    o = arm.fk(q, child)[:3, 3]  # a point on joint j's axis (its frame origin)
    total = 0.0
    for goal in goals:
        if j not in arm.chain(goal.frame):
            continue
        t = arm.fk(qt, goal.frame)
        if isinstance(goal, (PositionGoal, PoseGoal, DirectionGoal)):
            total += goal.weight * w1 * float((goal.position - o) @ (t[:3, 3] - o))
        if isinstance(goal, (OrientationGoal, PoseGoal)):
            total += goal.weight * w2 * float(np.sum(goal.rotation * t[:3, :3]))
        if isinstance(goal, DirectionGoal):
            total += goal.weight * w2 * float(goal.direction @ (t[:3, :3] @ goal.axis))
    return total


def _closed_form_step(arm: Arm, goals, q: np.ndarray, j: int, w1: float = 1.0,
                      w2: float = RHO2) -> float:
    ga = pack_goals(arm, goals)
    world = np.empty((arm.dof, 3, 4))
    E.joint_frames(q, arm.tree.joints, arm.tree.parent, world)
    w = world[j, :, :3] @ arm.tree.joint_axis(j)
    o = world[j, :, 3].copy()
    pose = np.array([arm.fk(q, g.frame) for g in goals])
    k1, k2, k3 = E.ccd_coefficients(w, o, ga.gt, ga.gd, ga.gw, ga.mask, j, pose, w2, w1)
    return E.ccd_angle(k1, k2, k3, arm.lower[j] - q[j], arm.upper[j] - q[j])


def _goals(arm: Arm, q: np.ndarray, kind: str):
    t = arm.fk(q)
    if kind == "position":
        return (PositionGoal(t[:3, 3]),)
    if kind == "orientation":
        return (OrientationGoal(t[:3, :3]),)
    if kind == "direction":
        return (DirectionGoal(t[:3, 3], t[:3, 0], axis=(1.0, 0.0, 0.0)),)
    return (PoseGoal(t, weight=2.0),)


@pytest.mark.parametrize("kind", ["position", "orientation", "direction", "pose"])
@pytest.mark.parametrize("arm_name", ["ur5e", "panda"])
def test_joint_step_is_the_brute_force_maximum(arm_name: str, kind: str):
    arm = load_arm(arm_name)
    rng = np.random.default_rng(7)
    chain = arm.chain()
    for _ in range(2):
        q_goal, q = arm.sample(rng), arm.sample(rng)
        goals = _goals(arm, q_goal, kind)
        for j in chain:
            step = _closed_form_step(arm, goals, q, j)
            lo, hi = arm.lower[j] - q[j], arm.upper[j] - q[j]
            assert lo - 1e-12 <= step <= hi + 1e-12
            grid = np.linspace(max(lo, -2 * np.pi), min(hi, 2 * np.pi), 1081)
            values = np.array([_objective_by_fk(arm, goals, q, j, t) for t in grid])
            best = grid[int(np.argmax(values))]
            g_step = _objective_by_fk(arm, goals, q, j, step)
            assert g_step >= values.max() - 1e-9
            # the maximiser itself (a sinusoid: one maximum per turn, so compare modulo 2 pi)
            spacing = grid[1] - grid[0]
            gap = abs((step - best + np.pi) % (2 * np.pi) - np.pi)
            assert gap <= spacing + 1e-9 or abs(values.max() - g_step) < 1e-9


@pytest.mark.parametrize("w1, w2", [(1.0, 0.0), (0.0, 0.3), (2.5, 0.004)])
@pytest.mark.parametrize("kind", ["pose", "direction"])
def test_weighted_joint_step_is_the_brute_force_maximum(kind: str, w1: float, w2: float):
    # CCDWeights(w1, w2): the closed form maximises w1 g1 + w2 g2 for any weights
    arm = load_arm("ur5e")
    rng = np.random.default_rng(11)
    q_goal, q = arm.sample(rng), arm.sample(rng)
    goals = _goals(arm, q_goal, kind)
    for j in arm.chain():
        step = _closed_form_step(arm, goals, q, j, w1, w2)
        lo, hi = arm.lower[j] - q[j], arm.upper[j] - q[j]
        grid = np.linspace(max(lo, -2 * np.pi), min(hi, 2 * np.pi), 1081)
        values = np.array([_objective_by_fk(arm, goals, q, j, t, w1, w2) for t in grid])
        assert _objective_by_fk(arm, goals, q, j, step, w1, w2) >= values.max() - 1e-9


def test_limits_pick_the_better_end():
    # g(t) = cos(t - 2): maximum at t = 2 outside [-1, 1]; the better end is 1
    k1, k2, k3 = 0.0, np.cos(2.0), np.sin(2.0)
    assert E.ccd_angle(k1, k2, k3, -1.0, 1.0) == 1.0
    assert E.ccd_angle(k1, k2, k3, -3.0, 3.0) == pytest.approx(2.0)


def test_prismatic_joint_step_is_exact():
    arm = load_arm(DATA / "scara.yaml")
    q = np.array([0.3, -0.4, 0.1, 0.2])
    target = q.copy()
    target[2] = 0.25
    goal = PositionGoal(arm.fk(target)[:3, 3])
    res = arm.ik(goal, q, solver="ccd", options=IKOptions(max_iterations=2, restarts=0))
    assert res.success
    assert res.iterations == 1
    assert res.q[2] == pytest.approx(0.25, abs=1e-12)


def test_two_goals_on_one_joint_add_their_objectives():
    arm = load_arm("torso")
    rng = np.random.default_rng(3)
    q_goal, q = arm.sample(rng), arm.sample(rng)
    goals = tuple(PoseGoal(arm.fk(q_goal, f), frame=f) for f in arm.end_effectors)
    waist = arm.joint_index("waist")
    step = _closed_form_step(arm, goals, q, waist)
    grid = np.linspace(arm.lower[waist] - q[waist], arm.upper[waist] - q[waist], 721)
    values = [_objective_by_fk(arm, goals, q, waist, t) for t in grid]
    assert _objective_by_fk(arm, goals, q, waist, step) >= max(values) - 1e-9
