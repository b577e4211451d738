"""The batch entry point: one compiled call for many goals, the same honesty as single solves."""

from __future__ import annotations

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.errors import InputError
from armctl.ik import (
    DirectionGoal,
    IKOptions,
    IKStatus,
    PoseGoal,
    PositionGoal,
    Tolerance,
    evaluate,
    solve_batch,
)

TOL = Tolerance(1e-6, 1e-6)


@pytest.mark.parametrize("solver", ["dls", "pinv", "ccd"])
def test_batch_of_poses_agrees_with_fk(solver: str):
    arm = load_arm("ur5e")
    rng = np.random.default_rng(0)
    qs = arm.sample(rng, 40)
    poses = arm.fk_batch(qs)
    poses[-1, :3, 3] = [3.0, 0.0, 0.0]  # one unreachable goal
    res = solve_batch(arm, poses, solver=solver, tolerance=TOL, options=IKOptions(restarts=30))
    assert len(res) == 40
    for i in range(40):
        errs = evaluate(arm, (PoseGoal(poses[i], tolerance=TOL),), res.q[i])
        assert res.success[i] == (errs[0].reached and arm.within_limits(res.q[i]))
        assert res.position_error[i] == pytest.approx(errs[0].position, abs=1e-12)
        assert res.rotation_error[i] == pytest.approx(errs[0].rotation, abs=1e-9)
        assert arm.within_limits(res.q[i])
    assert not res.success[-1]
    assert res.status[-1] in (IKStatus.UNREACHABLE, IKStatus.MAX_ITERATIONS)
    if solver != "ccd":
        assert res.success[:-1].all()


def test_batch_of_direction_goals_and_determinism():
    arm = load_arm("so101")
    rng = np.random.default_rng(1)
    sets = []
    for q in arm.sample(rng, 30):
        t = arm.fk(q)
        sets.append(DirectionGoal(t[:3, 3], t[:3, 2], tolerance=TOL))
    a = solve_batch(arm, sets, options=IKOptions(seed=5))
    b = solve_batch(arm, sets, options=IKOptions(seed=5))
    assert a.success.all()
    assert np.array_equal(a.q, b.q)
    for goal, q in zip(sets, a.q, strict=True):
        assert evaluate(arm, (goal,), q)[0].reached


def test_batch_refuses_mixed_structures():
    arm = load_arm("ur5e")
    with pytest.raises(InputError, match="structure"):
        solve_batch(arm, [PositionGoal([0.3, 0.1, 0.3]), PoseGoal(np.eye(4))])
    with pytest.raises(InputError):
        solve_batch(arm, np.zeros((3, 3)))
    with pytest.raises(InputError):
        solve_batch(arm, [PositionGoal([0.3, 0.1, 0.3])], solver="nlp")
