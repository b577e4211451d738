"""Ball-joint keyframes interpolated on the sphere: slerp and the C1 quaternion spline.

Truth comes from scipy.spatial.transform (rotation products, angles, rotation vectors), never
from the module under test.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from armctl.errors import PlanningError
from armctl.motion.interpolate import Interpolation, spline_through
from armctl.motion.quaternion_spline import (
    QuaternionSpline,
    keyframe_positions,
    quat_exp,
    quat_log,
    slerp_path,
)


def _rot(q: np.ndarray) -> Rotation:
    """scipy rotation(s) of (w, x, y, z) quaternions."""
    return Rotation.from_quat(np.roll(np.asarray(q), -1, axis=-1))


def _wxyz(r: Rotation) -> np.ndarray:
    return np.roll(r.as_quat(), 1, axis=-1)


def _travel_and_stray(path: Rotation, r0: Rotation, r1: Rotation) -> tuple[float, float]:
    """Angle travelled along the samples, and the largest angle from the geodesic r0 -> r1."""
    travel = float(np.sum((path[:-1].inv() * path[1:]).magnitude()))
    rel = (r0.inv() * r1).as_rotvec()
    arc = r0 * Rotation.from_rotvec(np.linspace(0, 1, 2001)[:, None] * rel[None])
    dots = np.abs(path.as_quat() @ arc.as_quat().T).max(axis=1)
    return travel, float(2 * np.arccos(np.clip(dots, -1, 1)).max())


# two orientations 120 deg apart (intrinsic x-y-z angles, as three revolute joints x, y, z
# make them); interpolating the three angles one by one travels 138 deg and strays 30 deg
RPY0, RPY1 = np.radians([0.0, -45.0, 45.0]), np.radians([-90.0, 0.0, -90.0])


def test_slerp_keeps_to_the_great_circle_where_euler_angles_stray():
    r0, r1 = Rotation.from_euler("XYZ", RPY0), Rotation.from_euler("XYZ", RPY1)
    geodesic = float((r0.inv() * r1).magnitude())
    assert np.degrees(geodesic) == pytest.approx(120.0, abs=1.0)
    s = np.linspace(0.0, 1.0, 401)
    q = slerp_path([0.0, 1.0], np.stack([_wxyz(r0), _wxyz(r1)]), s)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-12)
    travel, stray = _travel_and_stray(_rot(q), r0, r1)
    assert travel == pytest.approx(geodesic, abs=1e-9)
    assert stray < 1e-3  # on the arc (the residue is the reference arc's sampling)
    # constant rate: equal steps
    steps = (_rot(q)[:-1].inv() * _rot(q)[1:]).magnitude()
    np.testing.assert_allclose(steps, geodesic / 400, atol=1e-9)
    # the same keyframes as three angles interpolated one by one
    euler = Rotation.from_euler("XYZ", RPY0[None] + s[:, None] * (RPY1 - RPY0)[None])
    e_travel, e_stray = _travel_and_stray(euler, r0, r1)
    assert np.degrees(e_travel) == pytest.approx(137.7, abs=0.5)
    assert np.degrees(e_stray) == pytest.approx(30.5, abs=0.5)


def test_slerp_takes_the_shorter_way_for_opposite_signs():
    r0, r1 = Rotation.from_rotvec([0, 0, 0.3]), Rotation.from_rotvec([0, 0, 1.3])
    q1 = -_wxyz(r1)  # the same rotation written with the other sign
    q = slerp_path([0.0, 2.0], np.stack([_wxyz(r0), q1]), [1.0])
    assert (_rot(q[0]).inv() * Rotation.from_rotvec([0, 0, 0.8])).magnitude() < 1e-12


def test_exp_and_log_match_scipy():
    rv = np.random.default_rng(0).normal(size=(50, 3))
    rv *= (np.random.default_rng(1).uniform(0, np.pi, 50) / np.linalg.norm(rv, axis=1))[:, None]
    q = quat_exp(rv)
    np.testing.assert_allclose(np.abs(np.sum(q * _wxyz(Rotation.from_rotvec(rv)), axis=1)), 1.0,
                               atol=1e-12)
    np.testing.assert_allclose(quat_log(q), rv, atol=1e-10)


def _omega(spline: QuaternionSpline, a: float, b: float) -> np.ndarray:
    """Body angular velocity [rad/s] from two nearby samples (finite difference, scipy)."""
    qa, qb = spline([a, b])
    return (_rot(qa).inv() * _rot(qb)).as_rotvec() / (b - a)


def test_spline_passes_the_keyframes_with_continuous_angular_velocity():
    knots = _wxyz(Rotation.random(6, random_state=7))
    times = np.array([0.0, 0.8, 1.5, 2.9, 3.4, 4.6])
    spline = QuaternionSpline(times, knots)
    on_knots = spline(times)
    assert np.all(np.abs(np.sum(on_knots * knots, axis=1)) > 1 - 1e-12)
    t = np.linspace(0.0, times[-1], 3001)
    np.testing.assert_allclose(np.linalg.norm(spline(t), axis=1), 1.0, atol=1e-12)
    e = 1e-6
    for k, tk in enumerate(times[1:-1], start=1):
        left, right = _omega(spline, tk - 2 * e, tk - e), _omega(spline, tk + e, tk + 2 * e)
        scale = max(1.0, float(np.linalg.norm(left)))
        assert np.linalg.norm(left - right) < 1e-4 * scale, (k, left, right)
        np.testing.assert_allclose(left, spline.knot_omega[k], atol=1e-4 * scale)
    # at rest at the ends of the run
    assert np.linalg.norm(_omega(spline, 0.0, e)) < 1e-4
    assert np.linalg.norm(_omega(spline, times[-1] - e, times[-1])) < 1e-4


def test_spline_is_not_c1_when_segments_are_slerped():
    """The finite-difference check can fail: slerp's angular velocity jumps at a knot."""
    knots = _wxyz(Rotation.random(3, random_state=3))
    q = lambda t: slerp_path([0.0, 1.0, 2.0], knots, t)  # noqa: E731
    e = 1e-6
    left = (_rot(q([1 - 2 * e])[0]).inv() * _rot(q([1 - e])[0])).as_rotvec() / e
    right = (_rot(q([1 + e])[0]).inv() * _rot(q([1 + 2 * e])[0])).as_rotvec() / e
    assert np.linalg.norm(left - right) > 0.1


def test_spline_of_two_keyframes_stays_on_their_great_circle():
    r0, r1 = Rotation.from_euler("XYZ", RPY0), Rotation.from_euler("XYZ", RPY1)
    spline = QuaternionSpline([0.0, 2.0], np.stack([_wxyz(r0), _wxyz(r1)]))
    travel, stray = _travel_and_stray(_rot(spline(np.linspace(0, 2, 801))), r0, r1)
    assert stray < 1e-3
    assert travel == pytest.approx(float((r0.inv() * r1).magnitude()), abs=1e-9)


@pytest.mark.parametrize("knots, times, what", [
    (np.ones((3, 4)), [0, 1, 2], "unit quaternions"),
    (np.eye(4)[:3, :3], [0, 1, 2], "(n, 4)"),
    (np.eye(4)[:2], [1, 1], "increase"),
])
def test_bad_keyframes_are_refused(knots, times, what):
    with pytest.raises(PlanningError, match=r"quaternion|increase") as info:
        QuaternionSpline(times, knots)
    assert what in str(info.value)


@pytest.mark.parametrize("kind", list(Interpolation))
def test_a_joint_vector_with_a_ball_joint(kind: Interpolation):
    """1-DOF coordinates are joined as before; the ball joint's block stays on the sphere."""
    rng = np.random.default_rng(4)
    times = np.array([0.0, 0.7, 1.6, 2.2])
    ball = _wxyz(Rotation.random(4, random_state=11))
    other = rng.uniform(-1, 1, (4, 3))
    q = np.column_stack([other[:, :1], ball, other[:, 1:]])  # [r0, w, x, y, z, r1, r2]
    t = np.linspace(0, times[-1], 301)
    got = keyframe_positions(times, q, [1], kind, t)
    if kind is Interpolation.LINEAR:
        want = np.column_stack([np.interp(t, times, other[:, j]) for j in range(3)])
    else:
        want = spline_through(times, other, kind).sample_many(t)[0]
    np.testing.assert_array_equal(got[:, [0, 5, 6]], want)
    np.testing.assert_allclose(np.linalg.norm(got[:, 1:5], axis=1), 1.0, atol=1e-12)
    on_knots = keyframe_positions(times, q, [1], kind, times)[:, 1:5]
    assert np.all(np.abs(np.sum(on_knots * ball, axis=1)) > 1 - 1e-12)
    with pytest.raises(PlanningError, match="overlaps another or is outside"):
        keyframe_positions(times, q, [1, 3], kind, t)


def test_spline_angular_velocity_and_acceleration_match_finite_differences():
    """QuaternionSpline.sample's body-frame rates against scipy finite differences."""
    knots = _wxyz(Rotation.random(5, random_state=2))
    spline = QuaternionSpline([0.0, 0.7, 1.5, 2.0, 3.1], knots)
    t = np.linspace(0.01, 3.0, 37)
    q, omega, alpha = spline.sample(t)
    assert np.allclose(q, spline(t))
    h = 1e-5
    fd = (_rot(spline(t - h)).inv() * _rot(spline(t + h))).as_rotvec() / (2 * h)
    assert np.abs(fd - omega).max() < 1e-6
    fd_alpha = (spline.sample(t + h)[1] - spline.sample(t - h)[1]) / (2 * h)
    assert np.abs(fd_alpha - alpha).max() < 1e-5 * max(1.0, np.abs(alpha).max())
