"""The one-call path of ``ik_all`` (a pose array on a 6R family) against the general path."""

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.errors import InputError
from armctl.ik.analytic import GoalKind, decomposition, ik_all


@pytest.mark.parametrize("name", ["ur5e", "wx250s"])
def test_one_call_path_lists_the_rows_of_the_general_path(name):
    arm = load_arm(name)
    solved = list(decomposition(arm, None, GoalKind.POSE).columns)
    rng = np.random.default_rng(11)
    for q in arm.sample(rng, 40):
        goal = arm.fk(q)
        ref = arm.sample(rng)
        fast = ik_all(arm, goal, ref)  # a float64 array: the compiled one-call path
        general = ik_all(arm, goal.tolist(), ref.tolist())  # a list: the general path
        assert fast.family == general.family
        assert fast.singular == general.singular
        np.testing.assert_array_equal(fast.within_limits, general.within_limits)
        np.testing.assert_allclose(fast.q, general.q, atol=1e-12, rtol=0)
        np.testing.assert_allclose(fast.position_error, general.position_error, atol=1e-15)
        np.testing.assert_allclose(fast.rotation_error, general.rotation_error, atol=1e-15)
        # the generating configuration is among the answers, each answer meets the goal by FK
        d = np.abs((fast.q - q + np.pi) % (2 * np.pi) - np.pi)[:, solved].max(axis=1)
        assert d.min() < 1e-6
        for row in fast.q:
            t = arm.fk(row)
            assert np.linalg.norm(t[:3, 3] - goal[:3, 3]) <= 1e-9
            assert np.abs(t[:3, :3] - goal[:3, :3]).max() <= 1e-9


def test_one_call_path_keeps_the_input_checks():
    arm = load_arm("ur5e")
    goal = arm.fk(arm.middle())
    bad = goal.copy()
    bad[0, 3] = np.nan
    with pytest.raises(InputError, match="NaN or inf"):
        ik_all(arm, bad)
    skew = goal.copy()
    skew[:3, :3] *= 1.1
    with pytest.raises(InputError, match="not a rotation matrix"):
        ik_all(arm, skew)
    ref = arm.middle()
    ref[2] = np.inf
    with pytest.raises(InputError):
        ik_all(arm, goal, ref)
    with pytest.raises(InputError):
        ik_all(arm, goal, arm.middle()[:3])
    with pytest.raises(InputError, match="4x4"):
        ik_all(arm, goal[:3])
