"""Forward kinematics against independent truth: pinocchio, closed forms, DH tables."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
from armctl_testpaths import CONFIGS, DATA, WITH_URDF
from randarm import random_tree_urdf

import armctl
from armctl.config.urdf import parse_urdf


def pin_config(model: pin.Model, arm: armctl.Arm, q: np.ndarray) -> np.ndarray:
    """armctl's joint vector as a pinocchio configuration (matched by joint name)."""
    qp = pin.neutral(model)
    for name, value in zip(arm.joint_names, q, strict=True):
        joint = model.joints[model.getJointId(name)]
        if joint.nq == 2:  # continuous: (cos, sin)
            qp[joint.idx_q : joint.idx_q + 2] = (math.cos(value), math.sin(value))
        else:
            qp[joint.idx_q] = value
    return qp


def pin_frame_pose(model: pin.Model, data: pin.Data, qp: np.ndarray, frame: str) -> np.ndarray:
    pin.framesForwardKinematics(model, data, qp)
    return data.oMf[model.getFrameId(frame)].homogeneous


@pytest.mark.parametrize("name", WITH_URDF)
def test_bundled_yaml_matches_pinocchio_on_reference_urdf(name: str) -> None:
    """The bundled YAML (hand-transcribed) equals pinocchio on the maker-derived URDF."""
    urdf = DATA / "urdf" / f"{name}.urdf"
    arm = armctl.load_arm(CONFIGS / f"{name}.yaml")
    from_urdf = armctl.load_arm(urdf)
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    rng = np.random.default_rng(3)
    for q in arm.sample(rng, 100):
        q_urdf = np.array([q[arm.joint_index(n)] if n in arm.joint_names else 0.0
                           for n in from_urdf.joint_names])
        qp = pin_config(model, from_urdf, q_urdf)
        expected = pin_frame_pose(model, data, qp, arm.tool)
        np.testing.assert_allclose(arm.fk(q), expected, atol=1e-9)
        np.testing.assert_allclose(from_urdf.fk(q_urdf, arm.tool), expected, atol=1e-9)


@pytest.mark.parametrize("seed", range(8))
def test_random_tree_matches_pinocchio_for_every_frame(seed: int) -> None:
    rng = np.random.default_rng(seed)
    text = random_tree_urdf(rng, 12)
    arm = armctl.Arm(parse_urdf(text).spec)
    model = pin.buildModelFromXML(text)
    data = model.createData()
    qs = arm.sample(rng, 20)
    for q in qs:
        qp = pin_config(model, arm, q)
        poses = arm.fk_all(q)
        for frame in arm.frame_names:
            expected = pin_frame_pose(model, data, qp, frame)
            np.testing.assert_allclose(poses[frame], expected, atol=1e-10)
            np.testing.assert_allclose(arm.fk(q, frame), expected, atol=1e-10)
    batch = arm.fk_batch(qs, arm.tool)
    for k, q in enumerate(qs):
        np.testing.assert_array_equal(batch[k], arm.fk(q))


def test_planar_3r_closed_form() -> None:
    arm = armctl.load_arm(DATA / "planar3r.yaml")
    rng = np.random.default_rng(4)
    for q in arm.sample(rng, 50):
        a1, a12, a123 = q[0], q[0] + q[1], q.sum()
        x = 0.3 * math.cos(a1) + 0.2 * math.cos(a12) + 0.1 * math.cos(a123)
        y = 0.3 * math.sin(a1) + 0.2 * math.sin(a12) + 0.1 * math.sin(a123)
        expected = np.array([[math.cos(a123), -math.sin(a123), 0, x],
                             [math.sin(a123), math.cos(a123), 0, y],
                             [0, 0, 1, 0], [0, 0, 0, 1]])
        np.testing.assert_allclose(arm.fk(q), expected, atol=1e-12)


# Universal Robots' published DH parameters for the UR5e (standard DH, metres and radians).
UR5E_DH = [  # (d, a, alpha)
    (0.1625, 0.0, math.pi / 2),
    (0.0, -0.425, 0.0),
    (0.0, -0.3922, 0.0),
    (0.1333, 0.0, math.pi / 2),
    (0.0997, 0.0, -math.pi / 2),
    (0.0996, 0.0, 0.0),
]


def dh_standard(q: np.ndarray, table: list[tuple[float, float, float]]) -> np.ndarray:
    """Hand-written chain product T = prod Rz(q) Tz(d) Tx(a) Rx(alpha)."""
    t = np.eye(4)
    for qi, (d, a, alpha) in zip(q, table, strict=True):
        ct, st, ca, sa = math.cos(qi), math.sin(qi), math.cos(alpha), math.sin(alpha)
        t = t @ np.array([[ct, -st * ca, st * sa, a * ct],
                          [st, ct * ca, -ct * sa, a * st],
                          [0, sa, ca, d], [0, 0, 0, 1]])
    return t


def test_dh_notation_matches_hand_written_chain() -> None:
    """An arm written with standard DH parameters in YAML equals the DH chain product."""
    arm = armctl.load_arm(DATA / "ur5e_dh.yaml")
    rng = np.random.default_rng(5)
    for q in arm.sample(rng, 50):
        np.testing.assert_allclose(arm.fk(q), dh_standard(q, UR5E_DH), atol=1e-12)


def test_modified_dh_notation_matches_hand_written_chain() -> None:
    arm = armctl.load_arm(DATA / "puma_mdh.yaml")
    table = [(0.0, 0.0, 0.0), (0.0, 0.0, -math.pi / 2), (0.15, 0.43, 0.0),
             (0.43, 0.02, -math.pi / 2), (0.0, 0.0, math.pi / 2), (0.0, 0.0, -math.pi / 2)]
    rng = np.random.default_rng(6)
    for q in arm.sample(rng, 50):
        t = np.eye(4)
        for qi, (d, a, alpha) in zip(q, table, strict=True):  # Craig: Rx(alpha) Tx(a) Rz(q) Tz(d)
            ct, st, ca, sa = math.cos(qi), math.sin(qi), math.cos(alpha), math.sin(alpha)
            t = t @ np.array([[ct, -st, 0, a], [st * ca, ct * ca, -sa, -sa * d],
                              [st * sa, ct * sa, ca, ca * d], [0, 0, 0, 1]])
        np.testing.assert_allclose(arm.fk(q), t, atol=1e-12)


def test_ur5e_bundled_config_matches_dh_table() -> None:
    """The bundled UR5e (from the maker's URDF) equals UR's DH chain.

    UR's URDF puts ``base_link`` at the DH base frame turned by pi about z; the flange frame
    differs from DH frame 6 by a constant transform, found at q = 0 and then checked everywhere.
    """
    arm = armctl.load_arm(CONFIGS / "ur5e.yaml")
    dh = armctl.load_arm(DATA / "ur5e_dh.yaml")
    base = np.diag([-1.0, -1.0, 1.0, 1.0])  # Rz(pi)
    flange = np.linalg.inv(base @ dh.fk(np.zeros(6))) @ arm.fk(np.zeros(6), "flange")
    rng = np.random.default_rng(8)
    for q in arm.sample(rng, 50):
        np.testing.assert_allclose(arm.fk(q, "flange"), base @ dh.fk(q) @ flange, atol=1e-9)
