"""Null-space criteria on arms with ball and universal joints (armctl.ik.tangent with
armctl.ik.nullspace.TangentObjective): the tangent-space gradient against central differences
through model.integrate, the goal still met, and the criterion lower than without it."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import armctl
from armctl.arm import Arm
from armctl.errors import InputError
from armctl.ik import IKOptions, PositionGoal
from armctl.ik.nullspace import KeepOut, NullSpace, TangentObjective

BALL_ARM = Path(__file__).parents[1] / "data" / "ball_arm.yaml"


@pytest.fixture(scope="module")
def arm() -> Arm:
    return armctl.load_arm(BALL_ARM)


def _criteria(arm: Arm, rng: np.random.Generator) -> list[NullSpace]:
    return [
        NullSpace(posture=1.0, preferred=tuple(arm.sample(rng))),
        NullSpace(joint_limits=1.0),
        NullSpace(keep_out=(KeepOut((0.1, 0.0, 0.45), 0.3, ("fore", "hand", "tcp")),)),
        NullSpace(manipulability=0.5),
        NullSpace(posture=0.3, joint_limits=2.0, manipulability=0.1,
                  keep_out=(KeepOut((0.0, 0.1, 0.3), 0.25, ("fore",)),)),
    ]


def test_gradient_matches_central_differences_through_integrate(arm: Arm) -> None:
    rng = np.random.default_rng(7)
    step = 1e-6
    for ns in _criteria(arm, rng):
        h = TangentObjective(arm, ns)
        for _ in range(6):
            q = arm.sample(rng)
            fd = np.zeros(arm.nv)
            for k in range(arm.nv):
                e = np.zeros(arm.nv)
                e[k] = step
                fd[k] = (h(arm.integrate(q, e)) - h(arm.integrate(q, -e))) / (2 * step)
            np.testing.assert_allclose(h.gradient(q), fd, atol=1e-6 * (1 + np.abs(fd).max()))


def test_the_ball_joint_limit_term_measures_swing_and_twist(arm: Arm) -> None:
    """Independent truth: the swing and twist from scipy, the term is 0 at the centre and 1/2
    at the cone's edge, like a 1-DOF entry at its limit."""
    h = TangentObjective(arm, NullSpace(joint_limits=1.0))
    q = arm.neutral()
    q[4:] = (arm.lower[4:] + arm.upper[4:]) / 2  # the elbow and wrist at their middles
    assert h(q) == pytest.approx(0.0, abs=1e-15)
    # the twist axis (z) swung by the cone's 120 deg about x, no twist
    q[0:4] = Rotation.from_rotvec([math.radians(120), 0.0, 0.0]).as_quat(scalar_first=True)
    assert h(q) == pytest.approx(0.5, abs=1e-12)
    # a twist of 75 deg in a range of -150..150 deg: ((75 - 0) / 150)^2 / 2
    q[0:4] = Rotation.from_rotvec([0.0, 0.0, math.radians(75)]).as_quat(scalar_first=True)
    assert h(q) == pytest.approx(0.125, abs=1e-12)


@pytest.mark.parametrize("method", ["dls", "pinv", "auto"])
def test_criteria_fall_and_the_goal_holds(arm: Arm, method: str) -> None:
    rng = np.random.default_rng(3)
    for kind in ("posture", "limits", "keep-out"):
        for seed in range(2):
            target = arm.fk(arm.sample(rng))[:3, 3]
            q0 = arm.sample(rng)
            plain = arm.ik(PositionGoal(target), q0=q0, solver=method,
                           options=IKOptions(seed=seed, time_limit=2.0))
            assert plain.success
            if kind == "posture":
                ns = NullSpace(posture=1.0)
            elif kind == "limits":
                ns = NullSpace(joint_limits=1.0)
            else:  # a sphere beside the elbow of the answer without criteria
                elbow = arm.fk(plain.q, "fore")[:3, 3]
                ns = NullSpace(keep_out=(KeepOut(tuple(elbow + np.array([0.02, 0.0, 0.0])), 0.06,
                                                 ("fore",)),))
            h = TangentObjective(arm, ns)
            res = arm.ik(PositionGoal(target), q0=q0, solver=method,
                         options=IKOptions(seed=seed, time_limit=2.0, nullspace=ns))
            assert res.success, res.message
            assert np.linalg.norm(arm.fk(res.q)[:3, 3] - target) < 1e-4
            assert arm.within_limits(res.q)
            assert h(plain.q) > 1e-3
            assert h(res.q) < 0.9 * h(plain.q), (kind, h(res.q), h(plain.q))


def test_posture_pulls_toward_the_preferred_configuration(arm: Arm) -> None:
    """A redundant goal (a position, six joints) from a start far off: the answer ends nearer
    the preferred configuration, measured by the tangent difference (rotation angles)."""
    rng = np.random.default_rng(9)
    pref = arm.named_pose("home")
    target = arm.fk(pref)[:3, 3] + np.array([0.02, -0.03, 0.01])
    q0 = arm.sample(rng)
    plain = arm.ik(PositionGoal(target), q0=q0, solver="dls")
    res = arm.ik(PositionGoal(target), q0=q0, solver="dls",
                 options=IKOptions(nullspace=NullSpace(posture=1.0, preferred=tuple(pref),
                                                       iterations=300), time_limit=2.0))
    assert res.success
    far = np.linalg.norm(arm.difference(pref, plain.q))
    near = np.linalg.norm(arm.difference(pref, res.q))
    assert near < far


def test_other_methods_ignore_the_criteria_and_bad_input_is_refused(arm: Arm) -> None:
    ns = NullSpace(posture=1.0)
    target = arm.fk(arm.named_pose("home"))[:3, 3]
    for method in ("jt", "ccd", "ccd-jt"):
        res = arm.ik(PositionGoal(target), solver=method,
                     options=IKOptions(nullspace=ns, max_iterations=300, time_limit=2.0))
        assert res.success
    with pytest.raises(InputError, match="null-space preferred posture"):
        arm.ik(PositionGoal(target), solver="dls",
               options=IKOptions(nullspace=NullSpace(posture=1.0, preferred=(0.0,) * 6)))
    with pytest.raises(InputError, match="ball joint 'shoulder'"):
        arm.ik(PositionGoal(target), solver="dls",
               options=IKOptions(nullspace=NullSpace(posture=1.0, preferred=(2.0,) + (0.0,) * 6)))
