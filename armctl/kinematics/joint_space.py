"""The configuration space of ball joints.

Unit-norm checks, swing-cone and twist limits, integration on the quaternion, differences,
projection into the limits, uniform sampling.

A ball joint's configuration is a unit quaternion ``(w, x, y, z)`` (the rotation of its moved
frame relative to its frame at rest); its tangent is the angular velocity in its own moved frame.
Its limits are a swing cone about its twist axis ``a`` (the largest angle between ``R a`` and
``a``) and a twist range about ``a``, from the split ``q = swing ⊗ twist``
(:func:`armctl.spatial.swing_twist_quat`). :class:`~armctl.kinematics.model.KinematicModel`
uses these functions; 1-DOF joints never reach them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armctl.errors import InputError
from armctl.spatial import quat_exp, quat_log, quat_multiply, swing_twist, swing_twist_quat
from armctl.typing import Array

__all__ = ["BallJoint", "ball_violation", "check_unit", "difference", "integrate",
           "project_ball", "sample_ball"]

#: How far a ball joint's quaternion may be from unit norm before it is refused.
UNIT_TOLERANCE = 1e-6


@dataclass(frozen=True, eq=False)
class BallJoint:
    """A ball joint's place in ``q`` and its limits.

    Attributes:
        name: The joint's name.
        q: Its four entries (w, x, y, z) in the configuration vector.
        v: Its three entries in a tangent vector.
        axis: The unit twist axis in the joint frame, the centre of the swing cone.
        swing: The cone's half angle [rad], pi for no cone limit.
        lower: Lowest twist [rad] (-inf for none).
        upper: Highest twist [rad] (+inf for none).
    """

    name: str
    q: slice
    v: slice
    axis: Array
    swing: float
    lower: float
    upper: float

    @property
    def limited(self) -> bool:
        """Whether the joint has a cone or a twist limit."""
        return self.swing < math.pi or math.isfinite(self.lower) or math.isfinite(self.upper)


def check_unit(q: Array, balls: tuple[BallJoint, ...], what: str) -> None:
    """Refuse a ball joint's quaternion whose norm is not 1 (within :data:`UNIT_TOLERANCE`).

    Raises:
        InputError: Naming the joint, its entries and the norm.
    """
    for b in balls:
        quat = q[b.q]
        norm = math.sqrt(float(quat @ quat))
        if abs(norm - 1.0) > UNIT_TOLERANCE:
            raise InputError(
                f"{what}: ball joint {b.name!r} (entries {b.q.start}-{b.q.stop - 1}) holds the "
                f"quaternion {quat.tolist()} of norm {norm:.6g}; a ball joint takes a unit "
                "quaternion (w, x, y, z) (normalize it, or use model.normalize(q))")


def ball_violation(quat: Array, b: BallJoint, tol: float) -> tuple[str, float, float, float] | None:
    """The first limit a ball joint's quaternion breaks: ``(what, value, lower, upper)``."""
    if not b.limited:
        return None
    swing, twist = swing_twist(quat, b.axis)
    if swing > b.swing + tol:
        return "swing from the cone's centre", swing, 0.0, b.swing
    if not b.lower - tol <= twist <= b.upper + tol:
        return "twist about the joint's axis", twist, b.lower, b.upper
    return None


def project_ball(quat: Array, b: BallJoint) -> Array:
    """The quaternion moved into the limits: twist clamped, swing shortened (same direction)."""
    quat = quat / np.linalg.norm(quat)
    if not b.limited:
        return quat if quat[0] >= 0 else -quat
    swing_q, twist_q = swing_twist_quat(quat, b.axis)
    swing, twist = swing_twist(quat, b.axis)
    if b.lower <= twist <= b.upper and swing <= b.swing:
        return quat if quat[0] >= 0 else -quat
    twist = min(max(twist, b.lower), b.upper)
    twist_q = quat_exp(b.axis * twist)
    if swing > b.swing:
        swing_q = quat_exp(quat_log(swing_q) * (b.swing / swing))
    out = quat_multiply(swing_q, twist_q)
    return out if out[0] >= 0 else -out


def sample_ball(rng: np.random.Generator, b: BallJoint, n: int) -> Array:
    """``n`` uniform random rotations ``(n, 4)`` inside a ball joint's limits.

    The twist axis's direction is uniform over the cone's spherical cap (``cos`` of its angle
    uniform), the twist uniform in its range: together the uniform (Haar) measure restricted to
    the limits.
    """
    cos_lo = math.cos(b.swing)
    ct = rng.uniform(cos_lo, 1.0, n)
    st = np.sqrt(np.maximum(0.0, 1.0 - ct * ct))
    phi = rng.uniform(-math.pi, math.pi, n)
    lo = b.lower if math.isfinite(b.lower) else -math.pi
    hi = b.upper if math.isfinite(b.upper) else math.pi
    twist = rng.uniform(lo, hi, n)
    a = b.axis
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    # the twist axis's new direction d, and the shortest rotation taking a to d (the swing)
    d = ct[:, None] * a + st[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)
    axis = np.cross(a, d)
    sn = np.linalg.norm(axis, axis=1)
    angle = np.arctan2(sn, d @ a)
    unit = np.where(sn[:, None] > 1e-12, axis / np.where(sn > 1e-12, sn, 1.0)[:, None],
                    np.where(angle[:, None] > 1.0, e1, 0.0))  # d = -a: about e1; d = a: none
    half = angle / 2.0
    sw = np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * unit], axis=1)
    tw_w, tw_s = np.cos(twist / 2.0), np.sin(twist / 2.0)
    # sw (x) (cos t/2, sin t/2 a): the Hamilton product, the twist's vector part along a
    out = np.empty((n, 4))
    out[:, 0] = sw[:, 0] * tw_w - tw_s * (sw[:, 1:] @ a)
    out[:, 1:] = (sw[:, 0] * tw_s)[:, None] * a + tw_w[:, None] * sw[:, 1:] \
        + tw_s[:, None] * np.cross(sw[:, 1:], a)
    out *= np.where(out[:, :1] >= 0.0, 1.0, -1.0)
    return out


def integrate(q: Array, v: Array, q_slices: tuple[slice, ...], v_slices: tuple[slice, ...],
              balls: tuple[BallJoint, ...]) -> Array:
    """``q`` moved by the tangent step ``v``: sums, and ``q ⊗ exp(v / 2)`` for ball joints."""
    out = np.empty(q.shape[0])
    for qs, vs in zip(q_slices, v_slices, strict=True):
        if qs.stop - qs.start == 4:
            continue
        out[qs] = q[qs] + v[vs]
    for b in balls:
        new = quat_multiply(q[b.q], quat_exp(v[b.v]))
        new /= np.linalg.norm(new)
        out[b.q] = new if new[0] >= 0 else -new
    return out


def difference(q0: Array, q1: Array, q_slices: tuple[slice, ...], v_slices: tuple[slice, ...],
               balls: tuple[BallJoint, ...]) -> Array:
    """The tangent step from ``q0`` to ``q1``.

    Differences, and ``log(q0^-1 ⊗ q1)`` (the shortest arc) for ball joints.
    """
    out = np.empty(v_slices[-1].stop if v_slices else 0)
    for qs, vs in zip(q_slices, v_slices, strict=True):
        if qs.stop - qs.start == 4:
            continue
        out[vs] = q1[qs] - q0[qs]
    for b in balls:
        conj = q0[b.q] * np.array([1.0, -1.0, -1.0, -1.0])
        out[b.v] = quat_log(quat_multiply(conj, q1[b.q]))
    return out
