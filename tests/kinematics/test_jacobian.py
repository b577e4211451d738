"""The geometric Jacobian equals central finite differences of forward kinematics."""

from __future__ import annotations

import numpy as np
import pytest
from armctl_testpaths import BUNDLED, CONFIGS, DATA
from randarm import random_tree_urdf

import armctl
from armctl.config.urdf import parse_urdf
from armctl.spatial import matrix_to_rotvec


def numeric_jacobian(arm: armctl.Arm, q: np.ndarray, frame: str | None,
                     h: float = 1e-6) -> np.ndarray:
    jac = np.zeros((6, arm.dof))
    for i in range(arm.dof):
        dq = np.zeros(arm.dof)
        dq[i] = h
        tp, tm = arm.fk(q + dq, frame), arm.fk(q - dq, frame)
        jac[:3, i] = (tp[:3, 3] - tm[:3, 3]) / (2 * h)
        # angular velocity: log(R+ R-^T) / 2h, expressed in the base frame
        jac[3:, i] = matrix_to_rotvec(tp[:3, :3] @ tm[:3, :3].T) / (2 * h)
    return jac


def check_arm(arm: armctl.Arm, n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    qs = arm.sample(rng, n)
    for frame in {arm.tool, *arm.end_effectors, arm.frame_names[-1]}:
        batch = arm.jacobian_batch(qs, frame)
        for k, q in enumerate(qs):
            jac = arm.jacobian(q, frame)
            np.testing.assert_allclose(jac, numeric_jacobian(arm, q, frame), atol=1e-7)
            np.testing.assert_array_equal(batch[k], jac)


@pytest.mark.parametrize("name", BUNDLED)
def test_bundled_arm_jacobian_matches_finite_differences(name: str) -> None:
    check_arm(armctl.load_arm(CONFIGS / f"{name}.yaml"), 100, seed=1)


def test_planar_jacobian_matches_finite_differences() -> None:
    check_arm(armctl.load_arm(DATA / "planar3r.yaml"), 100, seed=2)


@pytest.mark.parametrize("seed", range(5))
def test_random_tree_jacobian_matches_finite_differences(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    arm = armctl.Arm(parse_urdf(random_tree_urdf(rng, 10)).spec)
    check_arm(arm, 20, seed)


def test_joints_off_the_chain_have_zero_columns() -> None:
    rng = np.random.default_rng(7)
    arm = armctl.Arm(parse_urdf(random_tree_urdf(rng, 10, branch=0.6)).spec)
    q = arm.sample(rng)
    for frame in arm.frame_names:
        chain = set(arm.chain(frame))
        jac = arm.jacobian(q, frame)
        for i in range(arm.dof):
            if i not in chain:
                assert not jac[:, i].any(), (frame, i)


def test_fk_jacobian_agrees_with_separate_calls() -> None:
    arm = armctl.load_arm(DATA / "planar3r.yaml")
    q = np.array([0.3, -0.4, 1.1])
    pose, jac = arm.fk_jacobian(q)
    np.testing.assert_array_equal(pose, arm.fk(q))
    np.testing.assert_array_equal(jac, arm.jacobian(q))


def test_wrap_toward_keeps_the_pose_and_moves_toward_the_reference() -> None:
    arm = armctl.load_arm(CONFIGS / "ur5e.yaml")  # +-2 pi on most joints
    rng = np.random.default_rng(9)
    for _ in range(50):
        q = arm.sample(rng)
        ref = arm.sample(rng)
        w = arm.wrap_toward(q, ref)
        np.testing.assert_allclose(arm.fk(w), arm.fk(q), atol=1e-12)
        assert arm.within_limits(w)
        assert np.all(np.abs(w - ref) <= np.abs(q - ref) + 1e-12)
        turns = (w - q) / (2 * np.pi)
        np.testing.assert_allclose(turns, np.round(turns), atol=1e-12)
    q = np.array([5.9, 0.0, 0.0, 0.0, 0.0, 0.0])
    assert arm.wrap_toward(q, np.zeros(6))[0] == pytest.approx(5.9 - 2 * np.pi)
