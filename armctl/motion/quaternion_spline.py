"""Interpolation of ball-joint keyframes on the unit sphere: slerp and a C1 quaternion spline.

A ball joint's value is a unit quaternion ``(w, x, y, z)`` (the convention of
:mod:`armctl.spatial`). Interpolating its four numbers one by one, or three Euler angles, leaves
the great circle between two keyframes: the rotation takes a longer way round and does not
turn about one axis. Here keyframes of a ball joint are joined on the sphere:

- **linear**: spherical linear interpolation (slerp) per segment, the shorter arc, at a uniform
  angular rate within each segment;
- **cubic**: the cumulative cubic Bézier quaternion curve of M.-J. Kim, M.-S. Kim and S. Y. Shin,
  "A General Construction Scheme for Unit Quaternion Curves with Simple High Order
  Derivatives", SIGGRAPH 1995. Segment ``k`` from keyframe ``p_k`` to ``p_k+1`` (duration
  ``h_k``) is ``q(u) = c0 · exp(w1 B1(u)) · exp(w2 B2(u)) · exp(w3 B3(u))`` with control
  quaternions ``c0 = p_k``, ``c1 = p_k exp(h_k ω_k / 3)``, ``c2 = p_k+1 exp(-h_k ω_k+1 / 3)``,
  ``c3 = p_k+1``, ``w_i = log(c_i-1^-1 c_i)`` and the cumulative Bernstein basis
  ``B1 = 1 - (1 - u)^3``, ``B2 = 3u^2 - 2u^3``, ``B3 = u^3``. Its body angular velocity at
  the ends of the segment is ``ω_k`` and ``ω_k+1``, so neighbouring segments meet with the
  same angular velocity: the curve is C1 on the sphere. The knot velocities are the
  Catmull-Rom choice (the mean of the rates of the two neighbouring chords, in the body frame
  of the knot), and zero at the ends of a run (the run starts and ends at rest).

Here ``exp`` and ``log`` map a rotation vector [rad] to a unit quaternion and back (the half
angle is applied inside), and angular velocities are body-frame rotation vectors per second.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from armctl.errors import PlanningError
from armctl.motion.interpolate import Interpolation, spline_through
from armctl.motion.quaternions import conj as _conj
from armctl.motion.quaternions import quat_exp, quat_log, quat_multiply
from armctl.typing import Array

__all__ = [
    "QuaternionSpline",
    "keyframe_positions",
    "quat_exp",
    "quat_log",
    "quat_multiply",
    "slerp_path",
]


def _aligned(knots: Array) -> Array:
    """Knots with signs flipped so that each is on the near side of the one before."""
    out = np.array(knots, dtype=float)
    out /= np.linalg.norm(out, axis=-1, keepdims=True)
    for i in range(1, len(out)):
        if out[i] @ out[i - 1] < 0.0:
            out[i] = -out[i]
    return out


def _check(times: npt.ArrayLike, knots: npt.ArrayLike) -> tuple[Array, Array]:
    t = np.asarray(times, dtype=float)
    q = np.asarray(knots, dtype=float)
    if q.ndim != 2 or q.shape[1] != 4 or len(q) != len(t) or len(t) < 2:
        raise PlanningError(f"quaternion keyframes must be (n, 4) with n >= 2 and one time "
                            f"each, found {q.shape} and {t.shape}")
    norms = np.linalg.norm(q, axis=1)
    if not np.all(np.isfinite(q)) or np.any(np.abs(norms - 1.0) > 1e-6):
        raise PlanningError("quaternion keyframes must be unit quaternions (w, x, y, z)")
    if np.any(np.diff(t) <= 0.0):
        raise PlanningError("keyframe times must increase")
    return t, _aligned(q)


def _segment(times: Array, t: Array) -> tuple[npt.NDArray[np.intp], Array]:
    k = np.clip(np.searchsorted(times, t, side="right") - 1, 0, len(times) - 2).astype(np.intp)
    h = times[k + 1] - times[k]
    u = np.clip((t - times[k]) / h, 0.0, 1.0)
    return k, u


def slerp_path(times: npt.ArrayLike, knots: npt.ArrayLike, t: npt.ArrayLike) -> Array:
    """Piecewise slerp through quaternion keyframes.

    Args:
        times: ``(n,)`` increasing keyframe times [s].
        knots: ``(n, 4)`` unit quaternions ``(w, x, y, z)``.
        t: Sample times [s] (clamped to the keyframe times).

    Returns:
        ``(len(t), 4)`` unit quaternions, each on the great circle of its segment.

    Raises:
        PlanningError: For keyframes that are not unit quaternions, or times that do not increase.
    """
    tk, q = _check(times, knots)
    k, u = _segment(tk, np.atleast_1d(np.asarray(t, dtype=float)))
    rel = quat_log(quat_multiply(_conj(q[k]), q[k + 1]))
    return quat_multiply(q[k], quat_exp(u[:, None] * rel))


class QuaternionSpline:
    """The C1 cumulative cubic Bézier quaternion spline of Kim, Kim and Shin (1995).

    Args:
        times: ``(n,)`` increasing keyframe times [s].
        knots: ``(n, 4)`` unit quaternions ``(w, x, y, z)`` it passes through.
        omega_start: Body angular velocity ``(3,)`` [rad/s] at the first keyframe (rest when
            ``None``).
        omega_end: The same at the last keyframe.

    Raises:
        PlanningError: For keyframes that are not unit quaternions, or times that do not increase.
    """

    def __init__(self, times: npt.ArrayLike, knots: npt.ArrayLike,
                 omega_start: npt.ArrayLike | None = None,
                 omega_end: npt.ArrayLike | None = None):
        self.times, self.knots = _check(times, knots)
        q, h = self.knots, np.diff(self.times)
        chord = quat_log(quat_multiply(_conj(q[:-1]), q[1:])) / h[:, None]  # body rates
        omega = np.zeros((len(q), 3))
        omega[1:-1] = 0.5 * (chord[:-1] + chord[1:])
        if omega_start is not None:
            omega[0] = np.asarray(omega_start, dtype=float)
        if omega_end is not None:
            omega[-1] = np.asarray(omega_end, dtype=float)
        #: Body angular velocity at each keyframe ``(n, 3)`` [rad/s].
        self.knot_omega = omega
        c0, c3 = q[:-1], q[1:]
        c1 = quat_multiply(c0, quat_exp(h[:, None] * omega[:-1] / 3.0))
        c2 = quat_multiply(c3, quat_exp(-h[:, None] * omega[1:] / 3.0))
        self._w = np.stack([quat_log(quat_multiply(_conj(a), b))
                            for a, b in ((c0, c1), (c1, c2), (c2, c3))], 1)  # (n-1, 3, 3)

    def speed_bound(self, k: npt.ArrayLike, u0: npt.ArrayLike, u1: npt.ArrayLike) -> Array:
        """A bound [rad/s] that the angular speed never exceeds on part of a segment.

        The body angular velocity is a sum of turned vectors ``w_i B_i'(u) / h`` (see
        :meth:`sample`), so its norm is at most ``Σ_i |w_i| |B_i'(u)| / h``. On ``u0 <= u <= u1``
        ``B1' = 3 (1 - u)^2`` is largest at ``u0``, ``B3' = 3 u^2`` at ``u1`` and
        ``B2' = 6 u (1 - u)`` at the point of the part nearest to ``u = 1/2``; at an end at rest
        (``w1`` or ``w3`` zero) the bound falls to zero with the distance to that end.

        Args:
            k: Segment indices.
            u0: Start of each part, as a fraction of its segment (0 to 1).
            u1: End of each part (``u0 <= u1 <= 1``).

        Returns:
            One bound per part.
        """
        seg = np.asarray(k, dtype=np.intp)
        a, b = np.asarray(u0, dtype=float), np.asarray(u1, dtype=float)
        norms = np.linalg.norm(self._w[seg], axis=-1)  # (..., 3)
        mid = np.clip(0.5, a, b)
        rate = (norms[..., 0] * 3.0 * (1.0 - a) ** 2 + norms[..., 1] * 6.0 * mid * (1.0 - mid)
                + norms[..., 2] * 3.0 * b**2)
        return np.asarray(rate / (self.times[seg + 1] - self.times[seg]))

    def sample(self, t: npt.ArrayLike) -> tuple[Array, Array, Array]:
        """Rotation, body angular velocity and acceleration at times ``t`` [s].

        Differentiates the product ``c0 · A1 · A2 · A3`` (``A_i = exp(w_i B_i(u))`` turns about
        the fixed axis of ``w_i``): with ``ω_0 = α_0 = 0`` and ``R_i`` the rotation of ``A_i``,
        ``ω_i = R_i^T ω_i-1 + w_i B_i'`` and
        ``α_i = R_i^T α_i-1 - (w_i B_i') × (R_i^T ω_i-1) + w_i B_i''`` (derivatives in time).

        Returns:
            ``(len(t), 4)`` unit quaternions, ``(len(t), 3)`` angular velocities [rad/s] and
            ``(len(t), 3)`` angular accelerations [rad/s^2], both in the moved (body) frame.
        """
        k, u = _segment(self.times, np.atleast_1d(np.asarray(t, dtype=float)))
        h = (self.times[k + 1] - self.times[k])[:, None]
        basis = np.stack([1.0 - (1.0 - u) ** 3, 3.0 * u**2 - 2.0 * u**3, u**3], 1)
        d1 = np.stack([3.0 * (1.0 - u) ** 2, 6.0 * u - 6.0 * u**2, 3.0 * u**2], 1)
        d2 = np.stack([-6.0 * (1.0 - u), 6.0 - 12.0 * u, 6.0 * u], 1)
        out = self.knots[k]
        omega = np.zeros((k.size, 3))
        alpha = np.zeros((k.size, 3))
        for i in range(3):
            w = self._w[k, i]
            step = quat_exp(basis[:, i:i + 1] * w)
            out = quat_multiply(out, step)
            back = _conj(step)
            rot_omega = _rotate(back, omega)
            rate = w * d1[:, i:i + 1] / h
            alpha = _rotate(back, alpha) - np.cross(rate, rot_omega) + w * d2[:, i:i + 1] / h**2
            omega = rot_omega + rate
        return out / np.linalg.norm(out, axis=1, keepdims=True), omega, alpha

    def __call__(self, t: npt.ArrayLike) -> Array:
        """Unit quaternions ``(len(t), 4)`` at times ``t`` [s] (clamped to the keyframes)."""
        k, u = _segment(self.times, np.atleast_1d(np.asarray(t, dtype=float)))
        basis = np.stack([1.0 - (1.0 - u) ** 3, 3.0 * u**2 - 2.0 * u**3, u**3], 1)
        out = self.knots[k]
        for i in range(3):
            out = quat_multiply(out, quat_exp(basis[:, i:i + 1] * self._w[k, i]))
        return out / np.linalg.norm(out, axis=1, keepdims=True)


def _rotate(quat: Array, vec: Array) -> Array:
    """Vectors ``(N, 3)`` turned by unit quaternions ``(N, 4)``."""
    w, u = quat[:, :1], quat[:, 1:]
    c = np.cross(u, vec)
    return vec + 2.0 * w * c + 2.0 * np.cross(u, c)


def keyframe_positions(times: npt.ArrayLike, q: npt.ArrayLike, quaternions: Sequence[int],
                       kind: Interpolation, t: npt.ArrayLike) -> Array:
    """Positions along a run of keyframes whose joint vectors hold ball joints as quaternions.

    The coordinates ``quaternions[i] .. quaternions[i] + 3`` of each ball joint are joined on
    the sphere (:func:`slerp_path` for :attr:`Interpolation.LINEAR`, :class:`QuaternionSpline`
    for the cubic kinds); every other coordinate exactly as the planner joins it for an arm of
    1-DOF joints (:func:`~armctl.motion.interpolate.spline_through` for the cubic and minimum
    jerk kinds, straight lines between keyframes for linear), at rest at both ends of the run.

    Args:
        times: ``(n,)`` increasing keyframe times [s], from 0.
        q: ``(n, nq)`` keyframe joint vectors.
        quaternions: Index of the first coordinate ``w`` of each ball joint in the joint vector.
        kind: The interpolation.
        t: Sample times [s].

    Returns:
        ``(len(t), nq)`` joint vectors.

    Raises:
        PlanningError: For a ball joint's keyframe that is not a unit quaternion, overlapping
            or out-of-range quaternion blocks, or times that do not increase.
    """
    tk = np.asarray(times, dtype=float)
    qk = np.asarray(q, dtype=float)
    ts = np.atleast_1d(np.asarray(t, dtype=float))
    nq = qk.shape[1]
    blocks = sorted(int(i) for i in quaternions)
    ball = np.zeros(nq, dtype=bool)
    for i in blocks:
        if i < 0 or i + 4 > nq or ball[i:i + 4].any():
            raise PlanningError(f"quaternion block at coordinate {i} overlaps another or is "
                                f"outside the joint vector of {nq} coordinates")
        ball[i:i + 4] = True
    out = np.empty((ts.size, nq))
    rest = ~ball
    if rest.any():
        if kind is Interpolation.LINEAR:
            for j in np.flatnonzero(rest):
                out[:, j] = np.interp(ts, tk, qk[:, j])
        else:
            out[:, rest] = spline_through(tk, qk[:, rest], kind).sample_many(ts)[0]
    for i in blocks:
        knots = qk[:, i:i + 4]
        out[:, i:i + 4] = (slerp_path(tk, knots, ts) if kind is Interpolation.LINEAR
                           else QuaternionSpline(tk, knots)(ts))
    return out
