"""The joint vector of an arm with universal and ball joints, as motion planning sees it.

A universal joint's two angles are two coordinates like those of 1-DOF joints: a value in ``q``,
a rate in a velocity vector, each with its own limits. A ball joint's value is a unit quaternion
(four entries of ``q``) and its rate the angular velocity in its moved frame (three entries of a
velocity vector); its speed is the *norm* of that angular velocity, and its velocity,
acceleration and jerk limits bound the norms. So the limits are checked on *rates*: one per
scalar coordinate, one per ball joint (:meth:`JointLayout.rates`).

A move between two configurations turns each ball joint on the great circle (slerp: about one
axis, by the geodesic angle ``|log(q0^-1 q1)|``): :class:`GeodesicMove` plays a synchronised
profile of the *reduced coordinates* (the scalar coordinates, then each ball joint's angle along
its arc) and maps it back to ``q`` and the tangent space.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.config.schema import JointType
from armctl.kinematics import joint_space as js
from armctl.kinematics.model import KinematicModel
from armctl.motion.quaternions import conj, quat_exp, quat_log, quat_multiply
from armctl.motion.trajectory import RuckigTrajectory, Sampled, Trajectory
from armctl.typing import Array

__all__ = ["GeodesicMove", "JointLayout"]


@dataclass(frozen=True, eq=False)
class JointLayout:
    """Where each joint's entries sit in ``q`` and in a velocity vector, and its rate's name.

    Attributes:
        nq: Entries of ``q``.
        nv: Entries of a velocity vector.
        q_names: Per entry of ``q``, what it is for messages (``"wrist (angle 2)"``, ``"hip"``).
        q_units: Per entry of ``q``, ``"rad"`` or ``"m"``.
        scalar_q: Entries of ``q`` that are not a ball joint's quaternion.
        scalar_v: The velocity entries of the same coordinates, in the same order.
        balls: The ball joints (entries and swing/twist limits).
        rate_names: Per rate (scalar coordinates, then ball joints), the name for messages.
        rate_units: Per rate, ``"rad"`` or ``"m"``.
    """

    nq: int
    nv: int
    q_names: tuple[str, ...]
    q_units: tuple[str, ...]
    scalar_q: npt.NDArray[np.intp]
    scalar_v: npt.NDArray[np.intp]
    balls: tuple[js.BallJoint, ...]
    rate_names: tuple[str, ...]
    rate_units: tuple[str, ...]

    @classmethod
    def of(cls, model: KinematicModel) -> JointLayout | None:
        """The layout of an arm; ``None`` for an arm of 1-DOF joints only."""
        if not model.multi_dof_joints:
            return None
        joints = model.spec.actuated_joints
        q_names: list[str] = []
        q_units: list[str] = []
        scalar_q: list[int] = []
        scalar_v: list[int] = []
        balls: list[js.BallJoint] = []
        for i, j in enumerate(joints):
            qs, vs = model.q_index(i), model.v_index(i)
            if j.type is JointType.BALL:
                q_names += [j.name] * 4
                q_units += ["rad"] * 4
                balls.append(js.BallJoint(j.name, qs, vs, np.asarray(j.axis, dtype=float),
                                          j.swing, j.limits.lower, j.limits.upper))
                continue
            n = qs.stop - qs.start
            q_names += ([j.name] if n == 1 else
                        [f"{j.name} (angle {k + 1})" for k in range(n)])
            q_units += ["m" if j.type is JointType.PRISMATIC else "rad"] * n
            scalar_q += list(range(qs.start, qs.stop))
            scalar_v += list(range(vs.start, vs.stop))
        names = tuple(q_names[i] for i in scalar_q) + tuple(b.name for b in balls)
        units = tuple(q_units[i] for i in scalar_q) + ("rad",) * len(balls)
        return cls(model.nq, model.nv, tuple(q_names), tuple(q_units),
                   np.array(scalar_q, dtype=np.intp), np.array(scalar_v, dtype=np.intp),
                   tuple(balls), names, units)

    @property
    def n_rates(self) -> int:
        """Number of rates: scalar coordinates and ball joints."""
        return int(self.scalar_v.size) + len(self.balls)

    def rates(self, values: npt.ArrayLike) -> Array:
        """Velocities (or accelerations, jerks) ``(..., nv)`` as rates ``(..., n_rates)``.

        Scalar coordinates keep their sign; a ball joint's rate is the norm of its three entries.
        """
        arr = np.asarray(values, dtype=float)
        parts = [arr[..., self.scalar_v]]
        parts += [np.linalg.norm(arr[..., b.v], axis=-1)[..., None] for b in self.balls]
        return np.concatenate(parts, axis=-1)

    def rate_limits(self, limits: npt.ArrayLike) -> Array:
        """Per-tangent-entry limits ``(nv,)`` as per-rate limits (a ball joint's first entry)."""
        arr = np.asarray(limits, dtype=float)
        return np.concatenate([arr[self.scalar_v], [arr[b.v.start] for b in self.balls]])

    def tangent_limits(self, rate_limits: npt.ArrayLike) -> Array:
        """Per-rate limits back as per-tangent-entry limits ``(nv,)``."""
        r = np.asarray(rate_limits, dtype=float)
        out = np.empty(self.nv)
        out[self.scalar_v] = r[:self.scalar_v.size]
        for k, b in enumerate(self.balls):
            out[b.v] = r[self.scalar_v.size + k]
        return out

    def normalize(self, q: npt.ArrayLike) -> Array:
        """``q`` with every ball joint's quaternion of unit norm and ``w >= 0``."""
        out = np.array(q, dtype=float)
        for b in self.balls:
            quat = out[b.q] / np.linalg.norm(out[b.q])
            out[b.q] = quat if quat[0] >= 0 else -quat
        return out

    def ball_angles(self, q0: npt.ArrayLike, q1: npt.ArrayLike) -> Array:
        """Each ball joint's rotation vector from ``q0`` to ``q1`` ``(len(balls), 3)`` [rad]."""
        a, b = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
        if not self.balls:
            return np.zeros((0, 3))
        return np.stack([quat_log(quat_multiply(conj(a[j.q]), b[j.q])) for j in self.balls])

    def ball_violation(self, qs: npt.ArrayLike, tol: float = 1e-9
                       ) -> tuple[int, js.BallJoint, str, float, float, float] | None:
        """The first sample (row of ``qs`` ``(N, nq)``) where a ball joint leaves its limits.

        Returns:
            ``(row, joint, what, value, lower, upper)`` with ``what`` ``"swing"`` (the twist
            axis's angle from its rest direction [rad], limits ``0..swing``) or ``"twist"``
            (the turn about the axis [rad]); ``None`` when every sample is inside.
        """
        arr = np.atleast_2d(np.asarray(qs, dtype=float))
        first: tuple[int, js.BallJoint, str, float, float, float] | None = None
        for b in self.balls:
            if not b.limited:
                continue
            swing, twist = swing_twist_many(arr[:, b.q], b.axis)
            bad_s = swing > b.swing + tol
            bad_t = (twist < b.lower - tol) | (twist > b.upper + tol)
            bad = np.flatnonzero(bad_s | bad_t)
            if bad.size and (first is None or int(bad[0]) < first[0]):
                k = int(bad[0])
                if bad_s[k]:
                    first = (k, b, "swing", float(swing[k]), 0.0, b.swing)
                else:
                    first = (k, b, "twist", float(twist[k]), b.lower, b.upper)
        return first


def swing_twist_many(quats: npt.ArrayLike, axis: npt.ArrayLike) -> tuple[Array, Array]:
    """Swing and twist angles [rad] of quaternions ``(N, 4)`` about a unit axis.

    The split ``q = swing ⊗ twist`` of :func:`armctl.spatial.swing_twist` for many at once:
    with ``q`` taken with ``w >= 0`` and ``p`` the projection of its vector part on the axis,
    the twist is ``2 atan2(p, w)`` and the swing ``2 atan2(sqrt(1 - n^2), n)``,
    ``n = sqrt(w^2 + p^2)`` (a half turn about an axis across the twist axis has no twist).
    """
    q = np.atleast_2d(np.asarray(quats, dtype=float))
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    q = np.where(q[:, :1] < 0.0, -q, q)
    w = q[:, 0]
    p = q[:, 1:] @ np.asarray(axis, dtype=float)
    n = np.sqrt(w * w + p * p)
    tiny = n < 1e-12
    twist = np.where(tiny, 0.0, 2.0 * np.arctan2(p, np.where(tiny, 1.0, w)))
    twist = np.where(twist > math.pi, twist - 2.0 * math.pi, twist)
    swing = 2.0 * np.arctan2(np.sqrt(np.maximum(0.0, 1.0 - n * n)), n)
    return swing, twist


class GeodesicMove(Trajectory):
    """A synchronised move of the reduced coordinates, mapped back to ``q``.

    The reduced coordinates are the scalar entries of ``q`` (1-DOF joints, universal angles),
    then each ball joint's angle along its arc from ``q0`` (0 to its geodesic angle). A ball
    joint ``b`` is at ``q0_b ⊗ exp(u_b r_b)`` (``u_b`` the unit axis of its rotation from
    ``q0_b`` to ``q1_b``), its angular velocity ``u_b r_b'`` and acceleration ``u_b r_b''``:
    slerp, timed by the profile.

    Args:
        q0: Start configuration ``(nq,)``.
        layout: The arm's layout.
        axes: Per ball joint the unit axis ``(len(balls), 3)`` of its turn (any for none).
        reduced: The profile of the reduced coordinates (a Ruckig move or a hold).
    """

    def __init__(self, q0: npt.ArrayLike, layout: JointLayout, axes: npt.ArrayLike,
                 reduced: Trajectory):
        self.q0 = np.array(q0, dtype=float)
        self.layout = layout
        self.axes = np.asarray(axes, dtype=float).reshape(len(layout.balls), 3)
        self.reduced = reduced
        self.dof = layout.nv
        self._ns = int(layout.scalar_q.size)

    @property
    def nq(self) -> int:  # noqa: D102
        return self.layout.nq

    @property
    def duration(self) -> float:  # noqa: D102
        return self.reduced.duration

    def breakpoints(self) -> Array:  # noqa: D102
        return self.reduced.breakpoints()

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:  # noqa: D102
        r, rd, rdd = self.reduced.sample_many(ts)
        n = r.shape[0]
        lay, ns = self.layout, self._ns
        q = np.tile(self.q0, (n, 1))
        qd = np.zeros((n, lay.nv))
        qdd = np.zeros((n, lay.nv))
        q[:, lay.scalar_q] = r[:, :ns]
        qd[:, lay.scalar_v] = rd[:, :ns]
        qdd[:, lay.scalar_v] = rdd[:, :ns]
        for k, b in enumerate(lay.balls):
            u = self.axes[k]
            q[:, b.q] = quat_multiply(self.q0[b.q], quat_exp(r[:, ns + k, None] * u))
            qd[:, b.v] = rd[:, ns + k, None] * u
            qdd[:, b.v] = rdd[:, ns + k, None] * u
        return q, qd, qdd

    def sample(self, t: float) -> Sampled:  # noqa: D102
        q, qd, qdd = self.sample_many([t])
        return q[0], qd[0], qdd[0]

    def position_extrema(self) -> tuple[Array, Array]:
        """Exact lowest and highest value ``(nq,)`` of each scalar entry (0 for quaternions)."""
        lo, hi = np.zeros(self.layout.nq), np.zeros(self.layout.nq)
        if isinstance(self.reduced, RuckigTrajectory):
            rlo, rhi = self.reduced.position_extrema()
        else:
            r = self.reduced.sample(0.0)[0]
            rlo = rhi = r
        lo[self.layout.scalar_q] = rlo[:self._ns]
        hi[self.layout.scalar_q] = rhi[:self._ns]
        return lo, hi
