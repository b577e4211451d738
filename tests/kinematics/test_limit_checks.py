"""The joint-vector checks ``as_q``, ``within_limits`` and ``clip`` (plain-float fast paths),
against NumPy's element-wise definitions (brute force over random vectors and edge values)."""

from __future__ import annotations

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.errors import InputError


@pytest.fixture(scope="module")
def arm() -> Arm:
    return load_arm("ur5e")


def test_within_limits_and_clip_match_numpy(arm: Arm) -> None:
    rng = np.random.default_rng(5)
    lo, hi = arm.lower, arm.upper
    span = hi - lo
    for _ in range(2000):
        q = rng.uniform(lo - 0.2 * span, hi + 0.2 * span)
        if rng.uniform() < 0.3:  # exactly at a limit, or within the tolerance of one
            i = rng.integers(arm.dof)
            q[i] = (lo if rng.uniform() < 0.5 else hi)[i] + rng.choice([0.0, 5e-10, -5e-10])
        for tol in (1e-9, 0.0, 0.05):
            truth = bool(np.all(q >= lo - tol) and np.all(q <= hi + tol))
            assert arm.within_limits(q, tol) is truth
        assert np.array_equal(arm.clip(q), np.clip(q, lo, hi))
    q = arm.middle()
    assert arm.clip(q) is not q  # a new vector


def test_non_finite_and_misshaped_joint_vectors_are_refused(arm: Arm) -> None:
    q = arm.middle()
    for bad in (np.nan, np.inf, -np.inf):
        q2 = q.copy()
        q2[3] = bad
        with pytest.raises(InputError, match="NaN or infinite"):
            arm.as_q(q2)
        with pytest.raises(InputError, match="NaN or infinite"):
            arm.within_limits(q2)
        with pytest.raises(InputError, match="NaN or infinite"):
            arm.clip(q2)
    with pytest.raises(InputError, match="must have 6 values"):
        arm.clip(q[:5])
    assert arm.as_q([1e308] * 6).tolist() == [1e308] * 6  # finite, however large
    assert arm.as_q(list(range(6))).dtype == np.float64
    strided = np.zeros(12)[::2]  # a non-contiguous view is read correctly
    strided[:] = q
    assert arm.within_limits(strided)
    assert np.array_equal(arm.clip(strided), q)
