"""Null-space criteria: the secondary objective improves while the goal stays met."""

from __future__ import annotations

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.errors import InputError
from armctl.ik import IKOptions, KeepOut, NullSpace, PoseGoal, PositionGoal, Tolerance

TOL = Tolerance(1e-6, 1e-6)


def _manipulability(arm, q):
    j = arm.jacobian(q)
    return float(np.sqrt(np.linalg.det(j @ j.T)))


def _limit_cost(arm, q):
    mid = (arm.lower + arm.upper) / 2
    half = (arm.upper - arm.lower) / 2
    return float(np.sum(((q - mid) / half) ** 2))


@pytest.mark.parametrize("solver", ["dls", "pinv"])
def test_each_criterion_improves_with_the_goal_kept(solver: str):
    arm = load_arm("panda")
    rng = np.random.default_rng(21)
    checked = 0
    for q in arm.sample(rng, 4):
        goal = PoseGoal(arm.fk(q), tolerance=TOL)
        # start at an exact solution: all motion from here is null-space motion
        start = q
        pref = arm.middle()
        elbow = arm.fk(start, "panda_link4")[:3, 3]
        centre = elbow + np.array([0.03, 0.0, 0.0])
        cases = [
            (NullSpace(posture=1.0), lambda x, pref=pref: float(np.sum((x - pref) ** 2)), "down"),
            (NullSpace(joint_limits=1.0), lambda x: _limit_cost(arm, x), "down"),
            (NullSpace(manipulability=1.0), lambda x: _manipulability(arm, x), "up"),
            (NullSpace(keep_out=(KeepOut(tuple(centre), 0.2, ("panda_link4",)),)),
             lambda x, c=centre: float(np.linalg.norm(arm.fk(x, "panda_link4")[:3, 3] - c)), "up"),
        ]
        for ns, measure, sense in cases:
            res = arm.ik(goal, start, solver=solver, options=IKOptions(nullspace=ns))
            assert res.success, res.message
            assert res.position_error <= TOL.position and res.rotation_error <= TOL.rotation
            before, after = measure(start), measure(res.q)
            if sense == "down":
                assert after < before - 1e-6, (ns, before, after)
            else:
                assert after > before + 1e-6, (ns, before, after)
            checked += 1
    assert checked == 16


def test_posture_on_a_position_goal_of_a_six_joint_arm():
    arm = load_arm("ur5e")
    rng = np.random.default_rng(3)
    pref = np.zeros(arm.dof)
    for q in arm.sample(rng, 5):
        goal = PositionGoal(arm.fk(q)[:3, 3], tolerance=TOL)
        res = arm.ik(goal, q, solver="dls",
                     options=IKOptions(nullspace=NullSpace(posture=1.0, preferred=tuple(pref))))
        assert res.success
        assert np.sum((res.q - pref) ** 2) < np.sum((q - pref) ** 2)


def test_bad_nullspace_options_are_refused():
    with pytest.raises(InputError):
        NullSpace(posture=-1.0)
    with pytest.raises(InputError):
        KeepOut((0, 0, 0), -0.1, ("tcp",))
    with pytest.raises(InputError):
        KeepOut((0, 0, 0), 0.1, ())
    arm = load_arm("panda")
    with pytest.raises(InputError):
        arm.ik(PositionGoal([0.4, 0, 0.4]), options=IKOptions(
            nullspace=NullSpace(posture=1.0, preferred=(0.0, 1.0))))
