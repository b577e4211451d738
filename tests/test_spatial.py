"""Rotation conversions round-trip (property-based) and agree with closed forms."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from armctl import spatial as sp

angle = st.floats(-math.pi, math.pi, allow_nan=False)
unit = st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)).filter(
    lambda v: 0.1 < math.sqrt(sum(x * x for x in v)))


def is_rotation(r: np.ndarray) -> bool:
    return bool(np.allclose(r @ r.T, np.eye(3), atol=1e-12) and np.isclose(np.linalg.det(r), 1))


@settings(max_examples=300, deadline=None)
@given(angle, st.floats(-1.5, 1.5), angle)
def test_rpy_round_trip(r: float, p: float, y: float) -> None:
    m = sp.rpy_to_matrix([r, p, y])
    assert is_rotation(m)
    np.testing.assert_allclose(sp.rpy_to_matrix(sp.matrix_to_rpy(m)), m, atol=1e-12)


@settings(max_examples=300, deadline=None)
@given(unit, st.floats(0, math.pi))
def test_rotvec_round_trip_including_near_pi(axis: tuple[float, float, float], a: float) -> None:
    v = np.array(axis) / np.linalg.norm(axis) * a
    m = sp.rotvec_to_matrix(v)
    assert is_rotation(m)
    back = sp.matrix_to_rotvec(m)
    np.testing.assert_allclose(sp.rotvec_to_matrix(back), m, atol=1e-10)
    if a < math.pi - 1e-6:
        np.testing.assert_allclose(back, v, atol=1e-8)


@settings(max_examples=300, deadline=None)
@given(unit, angle)
def test_quaternion_round_trip(axis: tuple[float, float, float], a: float) -> None:
    m = sp.axis_angle_to_matrix(axis, a)
    q = sp.matrix_to_quat(m)
    assert q[0] >= 0 and math.isclose(np.linalg.norm(q), 1.0)
    np.testing.assert_allclose(sp.quat_to_matrix(q), m, atol=1e-12)
    # quaternion of an axis-angle rotation in closed form
    u = np.array(axis) / np.linalg.norm(axis)
    expected = np.r_[math.cos(a / 2), math.sin(a / 2) * u]
    expected = -expected if expected[0] < 0 else expected
    np.testing.assert_allclose(q, expected, atol=1e-9)


def test_rpy_gimbal_lock_still_round_trips() -> None:
    for p in (math.pi / 2, -math.pi / 2):
        m = sp.rpy_to_matrix([0.3, p, -0.7])
        np.testing.assert_allclose(sp.rpy_to_matrix(sp.matrix_to_rpy(m)), m, atol=1e-12)


def test_rpy_is_fixed_axis_xyz() -> None:
    r, p, y = 0.1, 0.2, 0.3
    expected = (sp.axis_angle_to_matrix([0, 0, 1], y) @ sp.axis_angle_to_matrix([0, 1, 0], p)
                @ sp.axis_angle_to_matrix([1, 0, 0], r))
    np.testing.assert_allclose(sp.rpy_to_matrix([r, p, y]), expected, atol=1e-15)


@settings(max_examples=100, deadline=None)
@given(unit, angle, unit, angle, st.floats(0, 1))
def test_slerp_stays_on_the_geodesic(a1: tuple, t1: float, a2: tuple, t2: float, s: float) -> None:
    q0 = sp.matrix_to_quat(sp.axis_angle_to_matrix(a1, t1))
    q1 = sp.matrix_to_quat(sp.axis_angle_to_matrix(a2, t2))
    r0, r1 = sp.quat_to_matrix(q0), sp.quat_to_matrix(q1)
    rs = sp.quat_to_matrix(sp.slerp(q0, q1, s))
    total = np.linalg.norm(sp.matrix_to_rotvec(r1 @ r0.T))
    part = np.linalg.norm(sp.matrix_to_rotvec(rs @ r0.T))
    assert math.isclose(part, s * total, abs_tol=1e-7)


def test_transform_inverse_and_pose_error() -> None:
    t = sp.make_transform(sp.rpy_to_matrix([0.4, -0.2, 1.0]), [0.1, -0.2, 0.3])
    np.testing.assert_allclose(sp.transform_inverse(t) @ t, np.eye(4), atol=1e-15)
    target = sp.make_transform(sp.rpy_to_matrix([0.5, -0.1, 0.9]), [0.2, -0.2, 0.3])
    err = sp.pose_error(t, target)
    np.testing.assert_allclose(err[:3], [0.1, 0, 0], atol=1e-15)
    np.testing.assert_allclose(sp.rotvec_to_matrix(err[3:]) @ t[:3, :3], target[:3, :3],
                               atol=1e-12)
