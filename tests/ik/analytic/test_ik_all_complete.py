"""``ik_all`` by default: one row per solution, complete, exact, and its variant choice.

Truth here is independent of the solver: the generating configuration of each goal (from the
forward kinematics), and a brute-force enumeration of the 2 pi shifts of every row.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from analytic_arms import KR6, PUMA560, UR5E, dh_arm, random_arm

from armctl.arm import Arm, load_arm
from armctl.errors import InputError
from armctl.ik import PoseGoal
from armctl.ik.analytic import Family, classify, ik_all
from armctl.ik.analytic._subproblems import circle2

TOL = 1e-9
TWO_PI = 2.0 * math.pi


def _wrapped(a: np.ndarray) -> np.ndarray:
    return np.abs((a + np.pi) % TWO_PI - np.pi)


def _arms() -> list[tuple[str, Arm]]:
    rng = np.random.default_rng(7)
    return [
        ("ur5e bundled (limits +-2 pi)", load_arm("ur5e")),
        ("UR5e DH, limits +-2 pi", dh_arm("ur5e-dh", UR5E, -TWO_PI, TWO_PI)),
        ("KR6-class DH, limits +-1.5 pi", dh_arm("kr6", KR6, -1.5 * math.pi, 1.5 * math.pi)),
        ("PUMA 560 DH, limits +-pi", dh_arm("puma", PUMA560)),
        *((f"random {fam} arm", random_arm(rng, fam))
          for fam in ("wrist", "shoulder", "parallel", "outer")),
    ]


ARMS = _arms()


@pytest.mark.parametrize(("label", "arm"), ARMS, ids=[a[0] for a in ARMS])
def test_every_class_finds_the_generating_configuration_exactly_and_once(label: str,
                                                                         arm: Arm) -> None:
    fam = classify(arm).family
    assert fam in (Family.SPHERICAL_WRIST, Family.SPHERICAL_SHOULDER, Family.THREE_PARALLEL,
                   Family.THREE_PARALLEL_OUTER), label
    rng = np.random.default_rng(11)
    for q in arm.sample(rng, 150):
        goal = arm.fk(q)
        ref = arm.sample(rng, 1)[0]
        sols = ik_all(arm, goal, q_ref=ref)
        assert 0 < len(sols) <= 8
        # complete: the generating configuration, up to 2 pi wraps
        assert _wrapped(sols.q - q).max(axis=1).min() < 1e-6, (label, q.tolist())
        # exact: every row's FK, recomputed here
        for row in sols.q:
            t = arm.fk(row)
            assert np.linalg.norm(t[:3, 3] - goal[:3, 3]) <= TOL
            assert np.abs(t[:3, :3] - goal[:3, :3]).max() <= TOL
        assert sols.position_error.max() <= TOL and sols.rotation_error.max() <= TOL
        # distinct: no two rows are the same arm pose
        for i, j in itertools.combinations(range(len(sols)), 2):
            assert _wrapped(sols.q[i] - sols.q[j]).max() > 1e-6
        dist = np.linalg.norm(sols.q - ref, axis=1)
        assert np.all(np.diff(dist) >= 0)  # nearest to q_ref first


def _variants(arm: Arm, row: np.ndarray) -> list[np.ndarray]:
    """Every 2 pi shift of ``row`` inside the limits, by brute force (shifts up to +-3)."""
    per_joint = []
    for j, v in enumerate(row):
        shifts = [v + k * TWO_PI for k in range(-3, 4)
                  if arm.lower[j] - 1e-9 <= v + k * TWO_PI <= arm.upper[j] + 1e-9]
        per_joint.append(shifts or [v])
    return [np.array(c) for c in itertools.product(*per_joint)]


@pytest.mark.parametrize("name", ["ur5e", "kr6"])
def test_each_row_is_the_variant_inside_the_limits_nearest_the_reference(name: str) -> None:
    arm = load_arm("ur5e") if name == "ur5e" else dh_arm("kr6", KR6, -1.5 * math.pi,
                                                         1.5 * math.pi)
    rng = np.random.default_rng(5)
    for q in arm.sample(rng, 40):
        goal = arm.fk(q)
        ref = arm.sample(rng, 1)[0]
        sols = ik_all(arm, goal, q_ref=ref)
        every = ik_all(arm, goal, q_ref=ref, variants=True)
        assert len(every) >= len(sols)
        for row, inside in zip(sols.q, sols.within_limits, strict=True):
            options = _variants(arm, row)
            ok = [v for v in options if arm.within_limits(v)]
            assert inside == bool(ok)
            best = min(ok or options, key=lambda v: float(np.linalg.norm(v - ref)))
            np.testing.assert_allclose(row, best, atol=1e-12)
            # the variant listing holds exactly this solution's in-limit variants
            same = [r for r in every.q if _wrapped(r - row).max() < 1e-6]
            assert len(same) == max(len(ok), 1)
        # and the variant listing has no solution that the default rows miss
        for r in every.q:
            assert _wrapped(sols.q - r).max(axis=1).min() < 1e-6


def test_goal_objects_and_arrays_give_the_same_rows() -> None:
    arm = load_arm("ur5e")
    q = np.array([0.3, -1.1, 1.4, -0.6, 1.2, -2.5])
    t = arm.fk(q)
    a = ik_all(arm, t, q_ref=q)
    b = ik_all(arm, PoseGoal(t), q_ref=list(q))
    np.testing.assert_array_equal(a.q, b.q)
    np.testing.assert_array_equal(a.within_limits, b.within_limits)
    assert a.family == b.family and "UR type" in a.family
    np.testing.assert_allclose(a.q[0], q, atol=1e-9)


def test_a_pose_off_by_more_than_roundoff_is_cleaned_up_not_refused() -> None:
    arm = load_arm("ur5e")
    q = np.array([0.3, -1.1, 1.4, -0.6, 1.2, -2.5])
    t = arm.fk(q)
    t[:3, :3] *= 1.0 + 1e-9  # |R R^T - I| ~ 2e-9: accepted, orthonormalised
    sols = ik_all(arm, t, q_ref=q)
    assert _wrapped(sols.q - q).max(axis=1).min() < 1e-6


@pytest.mark.parametrize(("bad", "message"), [
    ("nan", "contains NaN or inf"),
    ("scaled", "not a rotation matrix"),
    ("mirrored", "not a rotation matrix"),
])
def test_bad_poses_are_refused_with_a_clear_error(bad: str, message: str) -> None:
    arm = load_arm("ur5e")
    t = arm.fk(arm.middle())
    if bad == "nan":
        t[0, 3] = np.nan
    elif bad == "scaled":
        t[:3, :3] *= 1.01
    else:
        t[:3, 0] *= -1.0
    with pytest.raises(InputError, match=message):
        ik_all(arm, t)


def test_a_bad_reference_is_refused_with_the_joint_values() -> None:
    arm = load_arm("ur5e")
    ref = arm.middle()
    ref[2] = np.nan
    with pytest.raises(InputError, match="q_ref contains a NaN"):
        ik_all(arm, arm.fk(arm.middle()), q_ref=ref)
    with pytest.raises(InputError, match="q_ref must have 6 values"):
        ik_all(arm, arm.fk(arm.middle()), q_ref=np.zeros(5))


def test_circle2_with_a_rank_one_reduction_matches_a_dense_scan() -> None:
    """``b`` singular and ``a`` regular (a decoupled arm): the exact rank-one path."""
    rng = np.random.default_rng(3)
    grid = np.linspace(-np.pi, np.pi, 20001)
    checked = 0
    for _ in range(40):
        a = rng.normal(size=(2, 2))
        u, w = rng.normal(size=2), rng.normal(size=2)
        b = np.outer(u, w)
        t1, t2 = rng.uniform(-np.pi, np.pi, 2)
        d = a @ [math.cos(t1), math.sin(t1)] + b @ [math.cos(t2), math.sin(t2)]
        o1, o2 = np.empty(4), np.empty(4)
        n, cont = circle2(a, b, d, 0.0, 0.0, o1, o2)
        assert not cont and 1 <= n <= 4
        for i in range(n):  # every pair solves the system
            r = (a @ [math.cos(o1[i]), math.sin(o1[i])]
                 + b @ [math.cos(o2[i]), math.sin(o2[i])] - d)
            assert np.abs(r).max() < 1e-9
        assert np.min(_wrapped(o2[:n] - t2)) < 1e-6  # the generating pair is among them
        # the count: the sign changes of the residual of the eliminated equation along t2
        x = np.linalg.solve(a, d[:, None] - b @ np.vstack([np.cos(grid), np.sin(grid)]))
        f = x[0] ** 2 + x[1] ** 2 - 1.0
        crossings = int(np.sum(np.sign(f[1:]) != np.sign(f[:-1])))
        if crossings in (2, 4):  # no tangency within the scan's resolution
            assert n == crossings
            checked += 1
    assert checked >= 20
