"""6R chains with only axes 5 and 6 meeting: the general method, and the 1-D search fallback.

The search is not proven complete, so its completeness is measured, not assumed: the generating
configuration must be found for at least 97 % of random goals (about 99 % measured), and the
solution set must contain at least 95 % of the distinct solutions that a dense multi-start Newton
search finds. Exactness (FK residual <= 1e-9 for every row) is required without exception.
"""

from __future__ import annotations

import numpy as np
import pytest
from analytic_arms import dh_arm

from armctl.arm import Arm, load_arm
from armctl.ik.analytic import Family, classify, ik_all
from armctl.ik.analytic._polish import POSE, polish

TOL = 1e-9


def _wrapped(a: np.ndarray) -> np.ndarray:
    return np.abs((a + np.pi) % (2 * np.pi) - np.pi)


def _pair_arm(rng: np.random.Generator) -> Arm:
    rows = [[rng.uniform(-0.4, 0.4), rng.uniform(-0.5, 0.5), rng.uniform(-np.pi, np.pi)]
            for _ in range(6)]
    rows[4][0] = rows[4][1] = 0.0  # d5 = a5 = 0: axes 5 and 6 meet, nothing else special
    return dh_arm("pair", [tuple(r) for r in rows],  # type: ignore[misc]
                  offsets=list(rng.uniform(-np.pi, np.pi, 6)))


def _found_rate(arm: Arm, n: int, seed: int, frame: str | None = None) -> float:
    rng = np.random.default_rng(seed)
    chain = list(arm.chain(frame))
    found = 0
    for q in arm.sample(rng, n):
        goal = arm.fk(q, frame)
        sols = ik_all(arm, goal, q_ref=q, frame=frame)
        assert np.all(np.isfinite(sols.q))
        if len(sols):
            assert sols.position_error.max() <= TOL and sols.rotation_error.max() <= TOL
            for r in sols.q:
                t = arm.fk(r, frame)
                assert np.linalg.norm(t[:3, 3] - goal[:3, 3]) <= TOL
            found += _wrapped(sols.q[:, chain] - q[chain]).max(axis=1).min() < 1e-6
    return found / n


@pytest.mark.parametrize("frame", ["right_tcp", "left_tcp"])
def test_torso_arms(frame: str) -> None:
    arm = load_arm("torso")
    assert classify(arm, frame).family is Family.PAIR_SEARCH
    assert _found_rate(arm, 200, 1, frame) >= 0.97


def test_random_arms_with_axes_5_6_meeting_use_the_complete_general_method() -> None:
    rng = np.random.default_rng(31)
    for k in range(8):
        arm = _pair_arm(rng)
        assert classify(arm).family is Family.GENERAL_6R
        assert _found_rate(arm, 25, k) == 1.0


def test_against_a_dense_multistart_newton_search() -> None:
    rng = np.random.default_rng(41)
    arm = _pair_arm(rng)
    cols = np.arange(6, dtype=np.int64)
    z = np.zeros(3)
    f = arm.frame_index(None)
    total = hits = 0
    for q in arm.sample(rng, 6):
        goal = arm.fk(q)
        ours = ik_all(arm, goal).q
        seen: list[np.ndarray] = []
        for seed in arm.sample(rng, 300):  # Gauss-Newton from 300 random starts
            s = seed.copy()
            ep, er = polish(s, cols, POSE, goal, goal[:3, 3].copy(), z, z, arm.tree.joints,
                            arm.tree.frames, arm.tree.paths, f, 60)
            if ep <= TOL and er <= TOL and all(_wrapped(s - o).max() > 1e-6 for o in seen):
                seen.append(s)
        for s in seen:
            total += 1
            hits += bool(len(ours)) and _wrapped(ours - s).max(axis=1).min() < 1e-6
    assert total > 0 and hits == total
