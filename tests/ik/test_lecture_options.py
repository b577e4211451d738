"""The lecture's knobs: CCD's weights w1, w2 and the fixed-gain Jacobian transpose.

CCD maximises ``w1 g1 + w2 g2`` per joint (L. Kavan, *Metody skeletální animace*, 2002); the
lecture's J^T step is ``dq = alpha J^T e`` with a constant ``alpha``.
"""

from __future__ import annotations

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.errors import InputError
from armctl.ik import CCDWeights, IKOptions, PoseGoal
from armctl.spatial import pose_error

ARM = load_arm("ur5e")


def _goal(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = ARM.sample(rng)
    start = np.clip(q + rng.uniform(-0.6, 0.6, ARM.dof), ARM.lower, ARM.upper)
    return ARM.fk(q), start


def _errors(q: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    e = pose_error(ARM.fk(q), target)
    return float(np.linalg.norm(e[:3])), float(np.linalg.norm(e[3:]))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_ccd_weights_choose_what_the_sweep_serves(seed: int) -> None:
    target, start = _goal(seed)
    budget = {"max_iterations": 200, "restarts": 0, "time_limit": 5.0}
    only_position = IKOptions(ccd_weights=CCDWeights(1.0, 0.0), **budget)
    only_rotation = IKOptions(ccd_weights=CCDWeights(0.0, 1.0), **budget)
    pos = ARM.ik(PoseGoal(target), start, solver="ccd", options=only_position)
    rot = ARM.ik(PoseGoal(target), start, solver="ccd", options=only_rotation)
    pe_p, re_p = _errors(pos.q, target)
    pe_r, re_r = _errors(rot.q, target)
    # each setting drives its own term (nearly) to zero and leaves the other one
    assert pe_p < 1e-4 and re_p > 10 * re_r
    assert re_r < 1e-4 and pe_r > 10 * pe_p
    # a pose goal is reached only by both terms: neither alone reports success
    assert not pos.success and not rot.success


def test_default_weights_are_the_documented_ones() -> None:
    target, start = _goal(4)
    opts = {"max_iterations": 50, "restarts": 0, "time_limit": 5.0}
    reach = ARM.tree.max_reach
    a = ARM.ik(PoseGoal(target), start, solver="ccd", options=IKOptions(**opts))
    b = ARM.ik(PoseGoal(target), start, solver="ccd", options=IKOptions(
        ccd_weights=CCDWeights(1.0, (reach / 4) ** 2), **opts))
    c = ARM.ik(PoseGoal(target), start, solver="ccd", options=IKOptions(
        ccd_weights=CCDWeights(2.0, 2 * (reach / 4) ** 2), **opts))  # only the ratio counts
    assert np.allclose(a.q, b.q, atol=1e-12) and np.allclose(a.q, c.q, atol=1e-9)


def test_a_fixed_gain_moves_by_its_gain() -> None:
    target, start = _goal(5)
    one = {"max_iterations": 1, "restarts": 0, "time_limit": 5.0}
    small = ARM.ik(PoseGoal(target), start, solver="jt", options=IKOptions(jt_gain=0.01, **one))
    large = ARM.ik(PoseGoal(target), start, solver="jt", options=IKOptions(jt_gain=0.02, **one))
    d_small = small.q - start
    d_large = large.q - start
    # one step dq = alpha J^T e: twice the gain, twice the step, the same direction
    assert np.linalg.norm(d_small) > 0
    assert np.allclose(d_large, 2 * d_small, rtol=1e-9, atol=1e-12)


def test_a_fixed_gain_is_taken_even_when_it_overshoots() -> None:
    target, start = _goal(6)
    one = {"max_iterations": 1, "restarts": 0, "time_limit": 5.0}
    huge = ARM.ik(PoseGoal(target), start, solver="jt", options=IKOptions(jt_gain=50.0, **one))
    optimal = ARM.ik(PoseGoal(target), start, solver="jt", options=IKOptions(**one))
    # armctl's step keeps only steps that lower the error; the lecture's fixed gain does not
    # look: a gain far too large makes the error grow
    e0 = sum(_errors(start, target))
    assert sum(_errors(optimal.q, target)) < e0
    assert sum(_errors(huge.q, target)) > e0


@pytest.mark.parametrize("kwargs, match", [
    ({"jt_gain": 0.0}, "never move"),
    ({"jt_gain": -1.0}, "finite number >= 0"),
    ({"jt_gain": float("nan")}, "finite number >= 0"),
    ({"jt_gain": "fast"}, "must be a number"),
    ({"ccd_weights": (1.0, 0.5)}, "must be a CCDWeights"),
])
def test_bad_options_are_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(InputError, match=match):
        IKOptions(**kwargs)


@pytest.mark.parametrize("args, match", [
    ((0.0, 0.0), "both 0"), ((-1.0, None), "finite number >= 0"),
    ((1.0, float("inf")), "finite number >= 0"), ((True, None), "must be a number"),
])
def test_bad_weights_are_refused(args: tuple, match: str) -> None:
    with pytest.raises(InputError, match=match):
        CCDWeights(*args)


def test_the_fixed_gain_step_is_alpha_jt_e_by_finite_differences() -> None:
    from armctl.ik import PositionGoal

    rng = np.random.default_rng(9)
    q0 = ARM.sample(rng) * 0.5
    p_goal = ARM.fk(ARM.sample(rng) * 0.5)[:3, 3]
    alpha = 0.05
    res = ARM.ik(PositionGoal(p_goal), q0, solver="jt", options=IKOptions(
        jt_gain=alpha, max_iterations=1, restarts=0, time_limit=5.0))
    h = 1e-7  # J of the tool position by central differences of FK, an independent Jacobian
    jac = np.empty((3, ARM.dof))
    for i in range(ARM.dof):
        d = np.zeros(ARM.dof)
        d[i] = h
        jac[:, i] = (ARM.fk(q0 + d)[:3, 3] - ARM.fk(q0 - d)[:3, 3]) / (2 * h)
    expected = alpha * jac.T @ (p_goal - ARM.fk(q0)[:3, 3])
    assert np.abs(expected).max() < 0.5  # below the step cap: the step is taken as it is
    assert np.allclose(res.q - q0, expected, atol=1e-8)
