"""Rotations and rigid transforms: matrices, roll-pitch-yaw, quaternions, rotation vectors.

Conventions used everywhere in armctl:

* Homogeneous transforms are ``(4, 4)`` float arrays; ``T_a_b`` maps coordinates in frame ``b``
  to frame ``a``.
* Roll-pitch-yaw follows URDF: ``R = Rz(yaw) @ Ry(pitch) @ Rx(roll)`` (rotations about the fixed
  x, y, z axes, in that order), angles in [rad].
* Quaternions are ``(w, x, y, z)`` with unit norm; functions that return one choose ``w >= 0``.
* A rotation vector is ``angle * unit_axis`` in [rad].
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from armctl.typing import Array

__all__ = [
    "axis_angle_to_matrix",
    "make_transform",
    "matrix_to_quat",
    "matrix_to_rotvec",
    "matrix_to_rpy",
    "orthonormalize",
    "pose_error",
    "quat_exp",
    "quat_log",
    "quat_multiply",
    "quat_to_matrix",
    "rotvec_to_matrix",
    "rpy_to_matrix",
    "slerp",
    "swing_twist",
    "swing_twist_quat",
    "transform_inverse",
]


def rpy_to_matrix(rpy: npt.ArrayLike) -> Array:
    """Rotation matrix from URDF roll, pitch, yaw.

    Args:
        rpy: ``(roll, pitch, yaw)`` in [rad].

    Returns:
        ``(3, 3)`` rotation matrix ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``.
    """
    r, p, y = np.asarray(rpy, dtype=float).reshape(3)
    cr, sr = np.cos(r), np.sin(r)
    cp, sp = np.cos(p), np.sin(p)
    cy, sy = np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def matrix_to_rpy(rot: npt.ArrayLike) -> Array:
    """Roll, pitch, yaw of a rotation matrix (inverse of :func:`rpy_to_matrix`).

    At the gimbal-lock pitch of +-pi/2 the roll is set to zero and the yaw carries the rotation.

    Args:
        rot: ``(3, 3)`` rotation matrix.

    Returns:
        ``(roll, pitch, yaw)`` in [rad], with pitch in [-pi/2, pi/2].
    """
    m = np.asarray(rot, dtype=float)
    sp = float(np.clip(-m[2, 0], -1.0, 1.0))
    cp = float(np.hypot(m[0, 0], m[1, 0]))
    pitch = float(np.arctan2(sp, cp))
    if cp > 1e-9:
        roll = float(np.arctan2(m[2, 1], m[2, 2]))
        yaw = float(np.arctan2(m[1, 0], m[0, 0]))
    else:  # gimbal lock: only yaw - sign(pitch) * roll is defined
        roll = 0.0
        yaw = float(np.arctan2(-m[0, 1], m[1, 1]))
    return np.array([roll, pitch, yaw])


def quat_to_matrix(quat: npt.ArrayLike) -> Array:
    """Rotation matrix of a quaternion.

    Args:
        quat: ``(w, x, y, z)``; normalised here, so it must not be zero.

    Returns:
        ``(3, 3)`` rotation matrix.

    Raises:
        ValueError: If the quaternion has (nearly) zero norm.
    """
    q = np.asarray(quat, dtype=float).reshape(4)
    n = float(np.linalg.norm(q))
    if n < 1e-12:
        raise ValueError("a quaternion (w, x, y, z) must not be zero")
    w, x, y, z = q / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quat(rot: npt.ArrayLike) -> Array:
    """Unit quaternion ``(w, x, y, z)`` with ``w >= 0`` of a rotation matrix.

    Uses the numerically stable branch selection on the largest diagonal term.

    Args:
        rot: ``(3, 3)`` rotation matrix.

    Returns:
        ``(4,)`` unit quaternion.
    """
    m = np.asarray(rot, dtype=float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0:
        s = 2.0 * np.sqrt(tr + 1.0)
        q = np.array([0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s,
                      (m[1, 0] - m[0, 1]) / s])
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = np.array([(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s,
                      (m[0, 2] + m[2, 0]) / s])
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * np.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = np.array([(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s,
                      (m[1, 2] + m[2, 1]) / s])
    else:
        s = 2.0 * np.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = np.array([(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s,
                      (m[1, 2] + m[2, 1]) / s, 0.25 * s])
    q /= np.linalg.norm(q)
    return -q if q[0] < 0 else q


def axis_angle_to_matrix(axis: npt.ArrayLike, angle: float) -> Array:
    """Rotation about a unit axis (Rodrigues' formula).

    Args:
        axis: ``(3,)`` rotation axis; normalised here.
        angle: Rotation angle in [rad].

    Returns:
        ``(3, 3)`` rotation matrix.

    Raises:
        ValueError: If the axis has (nearly) zero length.
    """
    a = np.asarray(axis, dtype=float).reshape(3)
    n = float(np.linalg.norm(a))
    if n < 1e-12:
        raise ValueError("a rotation axis must not have zero length")
    x, y, z = a / n
    c, s = np.cos(angle), np.sin(angle)
    v = 1.0 - c
    return np.array(
        [
            [c + x * x * v, x * y * v - z * s, x * z * v + y * s],
            [y * x * v + z * s, c + y * y * v, y * z * v - x * s],
            [z * x * v - y * s, z * y * v + x * s, c + z * z * v],
        ]
    )


def rotvec_to_matrix(rotvec: npt.ArrayLike) -> Array:
    """Rotation matrix of a rotation vector (the exponential map of SO(3)).

    Args:
        rotvec: ``(3,)`` axis times angle in [rad].

    Returns:
        ``(3, 3)`` rotation matrix (identity for a zero vector).
    """
    v = np.asarray(rotvec, dtype=float).reshape(3)
    angle = float(np.linalg.norm(v))
    if angle < 1e-15:
        return np.eye(3)
    return axis_angle_to_matrix(v / angle, angle)


def matrix_to_rotvec(rot: npt.ArrayLike) -> Array:
    """Rotation vector of a rotation matrix (the logarithm map of SO(3)).

    Accurate near zero and near pi, where the axis is taken from the symmetric part.

    Args:
        rot: ``(3, 3)`` rotation matrix.

    Returns:
        ``(3,)`` rotation vector with angle in [0, pi] [rad].
    """
    m = np.asarray(rot, dtype=float)
    skew = np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])
    cos_a = float(np.clip((m[0, 0] + m[1, 1] + m[2, 2] - 1.0) / 2.0, -1.0, 1.0))
    sin_a = float(np.linalg.norm(skew)) / 2.0
    angle = float(np.arctan2(sin_a, cos_a))
    if angle < 1e-6:
        return 0.5 * skew * (1.0 + angle * angle / 6.0)  # series of angle / sin(angle)
    if angle < np.pi - 1e-3:
        return skew * (angle / (2.0 * sin_a))
    # near pi: sym(R) = cos(a) I + (1 - cos(a)) k k^T; take the best-conditioned column of k k^T
    outer = ((m + m.T) / 2.0 - cos_a * np.eye(3)) / (1.0 - cos_a)
    k = int(np.argmax(np.diag(outer)))
    axis = outer[:, k] / np.sqrt(max(outer[k, k], 1e-300))
    axis /= np.linalg.norm(axis)
    if float(axis @ skew) < 0.0:
        axis = -axis
    return axis * angle


def make_transform(rot: npt.ArrayLike | None = None, pos: npt.ArrayLike | None = None) -> Array:
    """Homogeneous transform from a rotation and a translation.

    Args:
        rot: ``(3, 3)`` rotation matrix, identity when ``None``.
        pos: ``(3,)`` translation in [m], zero when ``None``.

    Returns:
        ``(4, 4)`` transform.
    """
    t = np.eye(4)
    if rot is not None:
        t[:3, :3] = np.asarray(rot, dtype=float)
    if pos is not None:
        t[:3, 3] = np.asarray(pos, dtype=float).reshape(3)
    return t


def transform_inverse(t: npt.ArrayLike) -> Array:
    """Inverse of a rigid transform, using the transpose of its rotation.

    Args:
        t: ``(4, 4)`` rigid transform.

    Returns:
        ``(4, 4)`` inverse transform.
    """
    m = np.asarray(t, dtype=float)
    out = np.eye(4)
    out[:3, :3] = m[:3, :3].T
    out[:3, 3] = -m[:3, :3].T @ m[:3, 3]
    return out


def orthonormalize(rot: npt.ArrayLike) -> Array:
    """The nearest rotation matrix (in the Frobenius norm) to a nearly orthogonal matrix.

    Args:
        rot: ``(3, 3)`` matrix.

    Returns:
        ``(3, 3)`` proper rotation matrix.
    """
    u, _, vt = np.linalg.svd(np.asarray(rot, dtype=float))
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, -1] *= -1
        r = u @ vt
    return r


def pose_error(t_current: npt.ArrayLike, t_target: npt.ArrayLike) -> Array:
    """Twist-like error from the current to the target pose, expressed in the base frame.

    Args:
        t_current: ``(4, 4)`` current pose.
        t_target: ``(4, 4)`` target pose.

    Returns:
        ``(6,)`` ``[dp; dw]``: position difference in [m] and the rotation vector in [rad] that
        turns the current orientation into the target one (``R_target = exp(dw) @ R_current``).
    """
    a = np.asarray(t_current, dtype=float)
    b = np.asarray(t_target, dtype=float)
    out = np.empty(6)
    out[:3] = b[:3, 3] - a[:3, 3]
    out[3:] = matrix_to_rotvec(b[:3, :3] @ a[:3, :3].T)
    return out


def slerp(q0: npt.ArrayLike, q1: npt.ArrayLike, s: float) -> Array:
    """Spherical linear interpolation of unit quaternions along the shorter arc.

    Args:
        q0: ``(4,)`` start quaternion ``(w, x, y, z)``.
        q1: ``(4,)`` end quaternion.
        s: Fraction in [0, 1].

    Returns:
        ``(4,)`` unit quaternion.
    """
    a = np.asarray(q0, dtype=float) / np.linalg.norm(q0)
    b = np.asarray(q1, dtype=float) / np.linalg.norm(q1)
    d = float(a @ b)
    if d < 0.0:
        b, d = -b, -d
    if d > 1.0 - 1e-12:
        out = a + s * (b - a)
        return out / np.linalg.norm(out)
    theta = np.arccos(d)
    out = (np.sin((1 - s) * theta) * a + np.sin(s * theta) * b) / np.sin(theta)
    return out / np.linalg.norm(out)


# ---- quaternion algebra (ball joints) ----------------------------------------------------------
def quat_multiply(a: npt.ArrayLike, b: npt.ArrayLike) -> Array:
    """Hamilton product ``a ⊗ b`` of quaternions ``(w, x, y, z)``.

    The rotation ``a`` then, in the frame it moved, ``b``: ``R(a ⊗ b) = R(a) @ R(b)``.
    """
    aw, ax, ay, az = (float(x) for x in np.asarray(a, dtype=float).reshape(4))
    bw, bx, by, bz = (float(x) for x in np.asarray(b, dtype=float).reshape(4))
    return np.array([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw])


def quat_exp(rotvec: npt.ArrayLike) -> Array:
    """Unit quaternion of a rotation vector ``angle * axis`` [rad]: ``(cos a/2, sin a/2 axis)``."""
    v = np.asarray(rotvec, dtype=float).reshape(3)
    angle = float(np.linalg.norm(v))
    if angle < 1e-8:  # second-order series: sin(a/2)/a = 1/2 - a^2/48
        return np.array([1.0 - angle * angle / 8.0, *(v * (0.5 - angle * angle / 48.0))])
    return np.array([np.cos(angle / 2.0), *(v * (np.sin(angle / 2.0) / angle))])


def quat_log(quat: npt.ArrayLike) -> Array:
    """Rotation vector [rad] of a unit quaternion, the shortest arc (angle in [0, pi])."""
    q = np.asarray(quat, dtype=float).reshape(4)
    if q[0] < 0:
        q = -q
    vn = float(np.linalg.norm(q[1:]))
    if vn < 1e-12:
        return np.asarray(2.0 * q[1:], dtype=float)
    return np.asarray(q[1:] * (2.0 * np.arctan2(vn, q[0]) / vn), dtype=float)


def swing_twist_quat(quat: npt.ArrayLike, axis: npt.ArrayLike) -> tuple[Array, Array]:
    """Split a unit quaternion into ``swing ⊗ twist``: a twist about ``axis``, then a swing.

    Args:
        quat: ``(w, x, y, z)``.
        axis: The unit twist axis, in the frame the quaternion rotates from.

    Returns:
        ``(swing, twist)`` unit quaternions, ``w >= 0``; the swing turns about an axis
        perpendicular to ``axis``.
    """
    q = np.asarray(quat, dtype=float).reshape(4)
    q = q / np.linalg.norm(q)
    if q[0] < 0:
        q = -q
    a = np.asarray(axis, dtype=float).reshape(3)
    proj = float(np.dot(q[1:], a))
    twist = np.array([q[0], *(proj * a)])
    tn = float(np.linalg.norm(twist))
    if tn < 1e-12:  # a half turn about an axis perpendicular to the twist axis: no twist
        twist = np.array([1.0, 0.0, 0.0, 0.0])
    else:
        twist /= tn
    conj = twist * np.array([1.0, -1.0, -1.0, -1.0])
    swing = quat_multiply(q, conj)
    return (-swing if swing[0] < 0 else swing), twist


def swing_twist(quat: npt.ArrayLike, axis: npt.ArrayLike) -> tuple[float, float]:
    """Swing and twist angles [rad] of a unit quaternion about a unit axis.

    Args:
        quat: ``(w, x, y, z)``: the rotation of a ball joint.
        axis: Its twist axis.

    Returns:
        ``(swing, twist)``: the angle in [0, pi] between the rotated axis and the axis, and the
        turn about the axis in [-pi, pi] (see :func:`swing_twist_quat`).
    """
    swing, twist = swing_twist_quat(quat, axis)
    a = np.asarray(axis, dtype=float).reshape(3)
    swing_angle = 2.0 * float(np.arctan2(np.linalg.norm(swing[1:]), abs(swing[0])))
    twist_angle = 2.0 * float(np.arctan2(np.dot(twist[1:], a), twist[0]))
    if twist_angle > np.pi:
        twist_angle -= 2.0 * np.pi
    return swing_angle, twist_angle
