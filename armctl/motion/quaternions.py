"""Quaternion arithmetic on arrays: products, exponential and logarithm of unit quaternions.

Quaternions are ``(..., 4)`` arrays ``(w, x, y, z)`` (the convention of :mod:`armctl.spatial`,
whose functions take one quaternion at a time); rotation vectors ``(..., 3)`` [rad].
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from armctl.typing import Array

__all__ = ["conj", "quat_exp", "quat_log", "quat_multiply"]


def quat_multiply(a: npt.ArrayLike, b: npt.ArrayLike) -> Array:
    """Hamilton product ``a · b`` of quaternions ``(..., 4)`` ``(w, x, y, z)``."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack([aw * bw - ax * bx - ay * by - az * bz,
                     aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw], -1)


def conj(q: Array) -> Array:
    """The conjugate (the inverse of a unit quaternion) ``(..., 4)``."""
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def quat_exp(rotvec: npt.ArrayLike) -> Array:
    """Unit quaternions ``(..., 4)`` of rotation vectors ``(..., 3)`` [rad]."""
    r = np.asarray(rotvec, dtype=float)
    angle = np.linalg.norm(r, axis=-1, keepdims=True)
    half = 0.5 * angle
    # sin(half)/angle, with its series near zero
    k = np.where(angle > 1e-8, np.sin(half) / np.where(angle > 1e-8, angle, 1.0),
                 0.5 - angle**2 / 48.0)
    return np.concatenate([np.cos(half), k * r], -1)


def quat_log(q: npt.ArrayLike) -> Array:
    """Rotation vectors ``(..., 3)`` [rad] of unit quaternions ``(..., 4)``, angle in [0, pi]."""
    q = np.asarray(q, dtype=float)
    q = np.where(q[..., :1] < 0.0, -q, q)  # the same rotation, the shorter way
    v = q[..., 1:]
    s = np.linalg.norm(v, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(s, q[..., :1])
    k = np.where(s > 1e-12, angle / np.where(s > 1e-12, s, 1.0), 2.0)
    return k * v
