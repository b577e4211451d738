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
import numpy.typing as npt

from armctl.errors import InputError
from armctl.spatial import quat_exp, quat_log, quat_multiply, swing_twist_quat
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

    @property
    def axis_tuple(self) -> tuple[float, float, float]:
        """The twist axis as three floats."""
        ax, ay, az = self.axis.tolist()
        return ax, ay, az


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


def _swing_twist(w: float, x: float, y: float, z: float, b: BallJoint) -> tuple[float, float]:
    """Swing and twist angles [rad] of a unit quaternion with ``w >= 0`` (scalars).

    The split of :func:`armctl.spatial.swing_twist`: the twist quaternion is ``(w, p a) / t``
    (``p`` the projection of the vector part on the axis ``a``, ``t = |(w, p)|``), so the swing
    ``q ⊗ twist^-1`` has the scalar part ``t``: swing ``2 atan2(sqrt(1 - t^2), t)``, twist
    ``2 atan2(p, w)``.
    """
    ax, ay, az = b.axis_tuple
    p = x * ax + y * ay + z * az
    t2 = w * w + p * p
    t = math.sqrt(t2)
    if t < 1e-12:  # a half turn about an axis perpendicular to the twist axis: no twist
        return math.pi, 0.0
    return 2.0 * math.atan2(math.sqrt(max(0.0, 1.0 - t2)), t), 2.0 * math.atan2(p, w)


def ball_violation(quat: Array, b: BallJoint, tol: float) -> tuple[str, float, float, float] | None:
    """The first limit a ball joint's quaternion breaks: ``(what, value, lower, upper)``."""
    if not b.limited:
        return None
    w, x, y, z = quat.tolist()
    n = math.sqrt(w * w + x * x + y * y + z * z)
    sign = 1.0 / n if w >= 0 else -1.0 / n
    swing, twist = _swing_twist(w * sign, x * sign, y * sign, z * sign, b)
    if swing > b.swing + tol:
        return "swing from the cone's centre", swing, 0.0, b.swing
    if not b.lower - tol <= twist <= b.upper + tol:
        return "twist about the joint's axis", twist, b.lower, b.upper
    return None


def project_ball(quat: Array, b: BallJoint) -> Array:
    """The quaternion moved into the limits: twist clamped, swing shortened (same direction)."""
    w, x, y, z = quat.tolist()
    n = math.sqrt(w * w + x * x + y * y + z * z)
    sign = 1.0 / n if w >= 0 else -1.0 / n
    w, x, y, z = w * sign, x * sign, y * sign, z * sign
    out_q = np.array([w, x, y, z])
    if not b.limited:
        return out_q
    swing, twist = _swing_twist(w, x, y, z, b)
    if b.lower <= twist <= b.upper and swing <= b.swing:
        return out_q
    quat = out_q
    swing_q, twist_q = swing_twist_quat(quat, b.axis)
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


def integrate(q: Array, v: Array, scalar_q: npt.NDArray[np.intp], scalar_v: npt.NDArray[np.intp],
              balls: tuple[BallJoint, ...]) -> Array:
    """``q`` moved by the tangent step ``v``: sums, and ``q ⊗ exp(v / 2)`` for ball joints.

    ``scalar_q`` and ``scalar_v`` index the entries of 1-DOF and universal joints in ``q`` and
    in ``v`` (in the same order).
    """
    out = np.empty(q.shape[0])
    out[scalar_q] = q[scalar_q] + v[scalar_v]
    for b in balls:
        out[b.q] = _times_exp(q[b.q].tolist(), v[b.v].tolist())
    return out


def _times_exp(q: list[float], v: list[float]) -> list[float]:
    """``q ⊗ exp(v / 2)`` normalised with ``w >= 0``, in scalars.

    The product of :func:`armctl.spatial.quat_multiply` and :func:`armctl.spatial.quat_exp`.
    """
    aw, ax, ay, az = q
    vx, vy, vz = v
    angle = math.sqrt(vx * vx + vy * vy + vz * vz)
    if angle < 1e-8:  # second-order series: sin(a/2)/a = 1/2 - a^2/48
        bw, k = 1.0 - angle * angle / 8.0, 0.5 - angle * angle / 48.0
    else:
        bw, k = math.cos(angle / 2.0), math.sin(angle / 2.0) / angle
    bx, by, bz = vx * k, vy * k, vz * k
    w = aw * bw - ax * bx - ay * by - az * bz
    x = aw * bx + ax * bw + ay * bz - az * by
    y = aw * by - ax * bz + ay * bw + az * bx
    z = aw * bz + ax * by - ay * bx + az * bw
    n = math.sqrt(w * w + x * x + y * y + z * z)
    n = n if w >= 0 else -n
    return [w / n, x / n, y / n, z / n]


def difference(q0: Array, q1: Array, scalar_q: npt.NDArray[np.intp],
               scalar_v: npt.NDArray[np.intp], nv: int,
               balls: tuple[BallJoint, ...]) -> Array:
    """The tangent step from ``q0`` to ``q1``.

    Differences, and ``log(q0^-1 ⊗ q1)`` (the shortest arc) for ball joints; ``scalar_q``,
    ``scalar_v`` as for :func:`integrate`, ``nv`` the tangent's length.
    """
    out = np.empty(nv)
    out[scalar_v] = q1[scalar_q] - q0[scalar_q]
    for b in balls:
        conj = q0[b.q] * np.array([1.0, -1.0, -1.0, -1.0])
        out[b.v] = quat_log(quat_multiply(conj, q1[b.q]))
    return out
