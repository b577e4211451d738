"""General 6R arms: every solution by Raghavan-Roth / Manocha-Canny elimination.

Checked against independent truths: the forward kinematics of every returned row (residual
<= 1e-9), the configuration that generated the goal (it must be among the rows), and a dense
multi-start Newton search (Gauss-Newton from 1000 random starts on the model's FK) whose every
distinct solution must be in the returned set. The elimination's premise, that the 14 equations
are of degree one in the sine and cosine of every joint, is checked at random points.
"""

from __future__ import annotations

import numpy as np
import pytest
from analytic_arms import dh_arm, random_arm

from armctl.arm import Arm
from armctl.ik.analytic import Family, classify, ik_all
from armctl.ik.analytic._pipeline import GENERAL, pose6
from armctl.ik.analytic._polish import POSE, polish
from armctl.ik.analytic.chain import chain_of
from armctl.ik.analytic.general6r import (
    SHIFTS,
    _lhs,
    _rhs,
    lhs_coefficients,
    rhs_coefficients,
    well_posed,
)

TOL = 1e-9


def _wrapped(a: np.ndarray) -> np.ndarray:
    return np.abs((a + np.pi) % (2 * np.pi) - np.pi)


def _has(rows: np.ndarray, q: np.ndarray, tol: float = 1e-6) -> bool:
    return bool(len(rows)) and bool(_wrapped(rows - q).max(axis=1).min() < tol)


def _distinct(rows: np.ndarray) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for r in rows:
        if not out or not _has(np.array(out), r):
            out.append(r)
    return out


def _exact(arm: Arm, goal: np.ndarray, rows: np.ndarray) -> None:
    """Every row reaches the goal by the model's FK."""
    assert np.all(np.isfinite(rows))
    for r in rows:
        t = arm.fk(r)
        assert np.linalg.norm(t[:3, 3] - goal[:3, 3]) <= TOL
        assert np.abs(t[:3, :3] - goal[:3, :3]).max() <= TOL


def _newton(arm: Arm, goal: np.ndarray, rng: np.random.Generator,
            starts: int) -> list[np.ndarray]:
    """Distinct solutions found by Gauss-Newton from ``starts`` random configurations."""
    cols = np.arange(6, dtype=np.int64)
    z = np.zeros(3)
    f = arm.frame_index(None)
    seen: list[np.ndarray] = []
    for seed in arm.sample(rng, starts):
        s = seed.copy()
        ep, er = polish(s, cols, POSE, goal, goal[:3, 3].copy(), z, z, arm.tree.joints,
                        arm.tree.frames, arm.tree.paths, f, 60)
        if ep <= TOL and er <= TOL and not (seen and _has(np.array(seen), s)):
            seen.append(s)
    return seen


def test_the_14_equations_have_degree_one_in_each_joint() -> None:
    rng = np.random.default_rng(2)
    for _ in range(5):
        c = chain_of(random_arm(rng, "general"))
        p = lhs_coefficients(c.h, c.o, 0.7)
        xt, lt = rng.normal(size=3), rng.normal(size=3)
        lt /= np.linalg.norm(lt)
        q = rhs_coefficients(c.h, c.o, xt, lt, 0.7)
        for t in rng.uniform(-np.pi, np.pi, (10, 3)):
            def b(a: float) -> np.ndarray:
                return np.array([np.sin(a), np.cos(a), 1.0])
            f = np.empty(14)
            _lhs(c.h, c.o, t[0], t[1], t[2], 0.7, f)
            pred = np.einsum("kij,i,j->k", p, b(t[0]), np.kron(b(t[1]), b(t[2])))
            assert np.abs(pred - f).max() < 1e-12
            _rhs(c.h, c.o, xt, lt, t[0], t[1], 0.7, f)
            assert np.abs(q @ np.kron(b(t[0]), b(t[1])) - f).max() < 1e-12


def test_random_general_arms_exact_and_complete() -> None:
    rng = np.random.default_rng(11)
    for k in range(20):
        arm = random_arm(rng, "general")
        assert classify(arm).family is Family.GENERAL_6R
        for q in arm.sample(rng, 5):
            goal = arm.fk(q)
            sols = ik_all(arm, goal, q_ref=q)
            assert _has(sols.q, q), f"arm {k}: the generating configuration is missing"
            assert sols.position_error.max() <= TOL and sols.rotation_error.max() <= TOL
            assert len(_distinct(sols.q)) <= 16
            _exact(arm, goal, sols.q)


def test_no_solution_missed_by_a_dense_multistart_newton_search() -> None:
    rng = np.random.default_rng(23)
    found = 0
    for _ in range(8):
        arm = random_arm(rng, "general")
        for q in arm.sample(rng, 3):
            goal = arm.fk(q)
            ours = ik_all(arm, goal).q
            reference = _newton(arm, goal, rng, 1000)
            assert reference, "the reference search should find the generating configuration"
            for s in reference:
                assert _has(ours, s), "a solution of the Newton search is missing"
            found += len(reference)
    assert found >= 24


#: Manocha and Canny (1994), "Efficient inverse kinematics for general 6R manipulators", IEEE
#: Trans. Robotics and Automation 10(5), Table I (problem 6 of Wampler and Morgan, 1991, a
#: variation of Manseur and Doty's arm): standard DH ``(d, a, alpha)`` per joint [m, m, rad].
MANOCHA_CANNY = [(0.0, 0.3, np.radians(90.0)), (0.0, 1.0, np.radians(1.0)),
                 (0.2, 0.0, np.radians(90.0)), (0.0, 1.5, np.radians(1.0)),
                 (0.0, 0.0, np.radians(90.0)), (0.0, 0.0, np.radians(1.0))]
#: Their Table III: the 16 real solutions of one pose [deg], printed to 0.01 deg.
MANOCHA_CANNY_SOLUTIONS = np.array([
    [-96.28, -6.27, 179.96, 38.48, 52.55, -39.40],
    [-120.78, 172.33, -179.07, 31.33, -146.71, 142.82],
    [88.67, -176.72, -176.72, -63.24, 157.19, 140.43],
    [113.84, 5.30, -177.74, -55.92, -62.98, -43.37],
    [-178.12, 108.19, -147.73, -5.69, -164.67, 179.58],
    [168.32, -103.89, 146.60, -17.24, -171.87, 98.16],
    [-12.94, -105.09, -114.97, 3.02, 7.41, -79.42],
    [2.51, 108.07, 112.04, -10.52, 0.00, -0.10],
    [2.51, 108.07, -67.95, -169.47, 179.99, 179.89],
    [-12.94, -105.09, 65.02, 176.97, 172.58, 100.57],
    [168.32, -103.89, -33.39, -162.75, -8.12, -81.83],
    [-178.12, 108.19, 32.26, -174.30, -15.32, -0.41],
    [88.67, -176.72, 3.27, -116.75, 22.80, -39.56],
    [-96.28, -6.27, -0.03, 141.51, 127.44, 140.59],
    [-120.78, 172.33, 0.92, 148.66, -33.28, -37.17],
    [113.84, 5.30, 2.25, -124.07, -117.01, 136.62]])


@pytest.mark.parametrize("row", [0, 7, 13])
def test_the_published_sixteen_solution_example(row: int) -> None:
    """Manocha and Canny's example: all 16 solutions, each within the table's rounding.

    Its axes 5 and 6 meet; ``ik_all`` routes such arms to the general kernel when the
    elimination is well posed, so the public API must find all 16 too. The kernel is also run
    directly (through the same polish and acceptance).
    """
    arm = dh_arm("manocha-canny", MANOCHA_CANNY)
    c = chain_of(arm)
    assert well_posed(c.h, c.o, c.m)
    goal = arm.fk(np.radians(MANOCHA_CANNY_SOLUTIONS[row]))
    q, _, errs, _ = pose6(GENERAL, False, c.h, c.o, c.m, c.index, c.sign,
                          np.arange(6, dtype=np.int64), np.ones(6, dtype=np.bool_), np.zeros(6),
                          goal, arm.tree.joints, arm.tree.frames, arm.tree.paths,
                          arm.frame_index(None), TOL, arm.lower, arm.upper, True)
    assert errs.max() <= TOL
    assert len(_distinct(q)) == 16  # rows: also the +-pi variants of a joint at pi
    _exact(arm, goal, q)
    deg = np.degrees((q + np.pi) % (2 * np.pi) - np.pi)
    for published in MANOCHA_CANNY_SOLUTIONS:
        assert np.abs((deg - published + 180.0) % 360.0 - 180.0).max(axis=1).min() < 0.05
    public = ik_all(arm, goal)
    assert public.family.startswith("general 6R")
    assert len(_distinct(public.q)) == 16


def test_angles_at_pi_and_at_the_shifted_zero() -> None:
    """Joints at pi (tangent of the half angle infinite) and joint 3 where the first shift
    puts the eigenvalue at infinity: another shift is taken, nothing is lost."""
    rng = np.random.default_rng(17)
    arm = random_arm(rng, "general")
    c = classify(arm)
    j3 = c.chain.joints[2]
    for q in arm.sample(rng, 4):
        for joint, value in ((3, np.pi), (4, np.pi), (0, np.pi), (j3, SHIFTS[0] + np.pi)):
            qq = q.copy()
            qq[joint] = (value + np.pi) % (2 * np.pi) - np.pi
            goal = arm.fk(qq)
            sols = ik_all(arm, goal, q_ref=qq)
            assert _has(sols.q, qq)
            _exact(arm, goal, sols.q)


def test_unreachable_and_near_boundary_goals() -> None:
    rng = np.random.default_rng(29)
    arm = random_arm(rng, "general")
    far = np.eye(4)
    far[:3, 3] = (5.0, 0.0, 0.0)
    sols = ik_all(arm, far)
    assert len(sols) == 0
    # goals pushed outwards along the radial direction until they leave the workspace
    for q in arm.sample(rng, 5):
        goal = arm.fk(q)
        for stretch in (1.0, 1.05, 1.2, 1.5):
            g = goal.copy()
            g[:3, 3] *= stretch
            sols = ik_all(arm, g)
            _exact(arm, g, sols.q)
            assert np.all(sols.position_error <= TOL) and np.all(sols.rotation_error <= TOL)


@pytest.mark.parametrize("special", ["parallel 1-2", "parallel 2-3", "meet 3-4",
                                     "parallel 4-5"])
def test_arms_with_one_special_pair(special: str) -> None:
    """Chains in no family but with two parallel or two meeting consecutive axes; with axes 1
    and 2 parallel the elimination is done on the inverted chain."""
    rng = np.random.default_rng(37)
    rows = [[rng.uniform(-0.4, 0.4), rng.uniform(-0.5, 0.5), rng.uniform(-np.pi, np.pi)]
            for _ in range(6)]
    kind, pair = special.split()
    i = int(pair[0]) - 1
    if kind == "parallel":
        rows[i][2] = 0.0
    else:
        rows[i][1] = 0.0
    arm = dh_arm("special", [tuple(r) for r in rows],  # type: ignore[misc]
                 offsets=list(rng.uniform(-np.pi, np.pi, 6)))
    dec = classify(arm)
    assert dec.family is Family.GENERAL_6R
    assert dec.inverted == (special == "parallel 1-2")
    for q in arm.sample(rng, 10):
        goal = arm.fk(q)
        sols = ik_all(arm, goal, q_ref=q)
        assert _has(sols.q, q)
        _exact(arm, goal, sols.q)


def _singular_configuration(arm: Arm, rng: np.random.Generator) -> np.ndarray:
    """A configuration where the Jacobian loses rank: bisection on det(J) along a line."""
    while True:
        q0, d = arm.sample(rng, 1)[0], rng.normal(size=6)
        s = np.linspace(0.0, 1.0, 41)
        dets = [np.linalg.det(arm.jacobian(q0 + t * d)) for t in s]
        for k in range(40):
            if dets[k] * dets[k + 1] < 0:
                lo, hi, flo = s[k], s[k + 1], dets[k]
                for _ in range(60):
                    mid = 0.5 * (lo + hi)
                    fm = np.linalg.det(arm.jacobian(q0 + mid * d))
                    if fm * flo > 0:
                        lo, flo = mid, fm
                    else:
                        hi = mid
                return q0 + 0.5 * (lo + hi) * d


def test_singular_and_near_singular_goals() -> None:
    """At a singular configuration two solutions meet: no NaN, no false row, and the
    configuration (or its merged neighbour) is still found."""
    rng = np.random.default_rng(43)
    for _ in range(4):
        arm = random_arm(rng, "general")
        qs = _singular_configuration(arm, rng)
        sv = np.linalg.svd(arm.jacobian(qs), compute_uv=False)
        assert sv[-1] < 1e-9 * sv[0]
        for eps in (0.0, 1e-9, 1e-6, 1e-3):
            q = qs + eps * rng.normal(size=6)
            goal = arm.fk(q)
            sols = ik_all(arm, goal, q_ref=q)
            _exact(arm, goal, sols.q)
            assert _has(sols.q, q, 1e-3)
