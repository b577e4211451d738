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


@pytest.mark.parametrize("name", ["ur5e", "wx250s"])
def test_one_call_path_without_q_ref_shares_a_read_only_middle(name):
    # without q_ref the rows sort by the middle of the ranges, as the general path does; the
    # results share that reference read-only (nothing can change it under another result)
    arm = load_arm(name)
    goal = arm.fk(arm.sample(np.random.default_rng(5)))
    a, b = ik_all(arm, goal), ik_all(arm, goal)
    general = ik_all(arm, goal.tolist())
    np.testing.assert_array_equal(a.q_ref, arm.middle())
    np.testing.assert_allclose(a.q, general.q, atol=1e-12, rtol=0)
    assert not a.q_ref.flags.writeable
    with pytest.raises(ValueError):
        a.q_ref[0] = 1.0
    np.testing.assert_array_equal(b.q_ref, arm.middle())
    assert not np.shares_memory(a.q, b.q)  # each result owns its rows
    ref = arm.middle()
    own = ik_all(arm, goal, ref)
    ref[0] += 1.0  # the caller's array stays the caller's
    np.testing.assert_array_equal(own.q_ref, arm.middle())


def test_one_call_path_hands_a_full_buffer_to_the_general_path(monkeypatch):
    # a family that gave more candidates than the buffer holds is not cut short: the call
    # falls back to the general path, which lists every solution
    from armctl.ik.analytic import solve_all

    arm = load_arm("ur5e")
    rng = np.random.default_rng(8)
    goals = [arm.fk(q) for q in arm.sample(rng, 5)]
    full = [ik_all(arm, g) for g in goals]
    monkeypatch.setattr(solve_all, "_PLANS", {})
    for code in list(solve_all._MOST):
        monkeypatch.setitem(solve_all._MOST, code, 2)
    from armctl.ik.analytic._pipeline import OVERFLOW, pose6_distinct

    for g, want in zip(goals, full, strict=True):
        got = ik_all(arm, g)
        assert len(want) > 2
        np.testing.assert_allclose(got.q, want.q, atol=1e-12, rtol=0)
        plan = solve_all._PLANS[(id(arm), None)]
        res = pose6_distinct(plan.arm, plan.middle, g, 1e-9, np.empty(plan.rows),
                             np.empty(plan.most, dtype=bool))
        assert (res >> 1) & 7 == OVERFLOW  # the kernel refused to write past the buffer
