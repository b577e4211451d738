"""Trajectories through a run of keyframes: linear (S-curve), C2 cubic spline, minimum jerk.

A *run* is a list of keyframes that starts and ends at rest and passes through the ones between
without stopping. Untimed runs are timed near-optimally: segment durations start from a per-segment
estimate, are stretched or shrunk where the samples are above or below the limits, and the whole
run is finally scaled uniformly so that the largest velocity, acceleration (and for minimum jerk
the jerk) ratio to its limit is just below one.
"""

from __future__ import annotations

from enum import Enum

import numpy as np
import numpy.typing as npt

from armctl.errors import PlanningError
from armctl.motion.limits import MotionLimits
from armctl.motion.profiles import quintic_segment, ruckig_move
from armctl.motion.trajectory import Chain, PiecewisePolynomial, RuckigTrajectory, Trajectory
from armctl.typing import Array

__all__ = ["Interpolation", "cubic_knot_velocities", "piece_extrema", "plan_run", "spline_through",
           "split_knot"]


_MARGIN = 1.01  # final uniform slow-down so that samples between the test points stay inside
_SAMPLES_PER_SEGMENT = 48
#: Slack of the position limits in the overshoot test [rad]/[m], that of the final check.
_LIMIT_TOL = 1e-9


class Interpolation(Enum):
    """How keyframes are joined."""

    LINEAR = "linear"  # straight joint-space segments, jerk-limited S-curve (Ruckig)
    CUBIC = "cubic"  # C2 cubic spline, velocity zero at the ends of a run
    MIN_JERK = "min-jerk"  # quintic (minimum-jerk) segments, C2, rest at the ends of a run


def cubic_knot_velocities(times: Array, q: Array, v_start: Array | None = None,
                          v_end: Array | None = None) -> Array:
    """Knot velocities ``(n, dof)`` of the C2 cubic spline through ``q``.

    The end velocities are ``v_start`` and ``v_end`` (rest when ``None``).

    Solves the tridiagonal continuity equations
    ``h_k v_{k-1} + 2 (h_{k-1} + h_k) v_k + h_{k-1} v_{k+1} = 3 (h_k d_{k-1} + h_{k-1} d_k)``
    (``d`` the chord slopes) by the Thomas algorithm.
    """
    n = q.shape[0]
    v = np.zeros_like(q)
    if v_start is not None:
        v[0] = v_start
    if v_end is not None:
        v[-1] = v_end
    if n <= 2:
        return v
    h = np.diff(times)
    d = np.diff(q, axis=0) / h[:, None]
    m = n - 2  # unknowns v_1 .. v_{n-2}
    sub = h[2:].copy()  # coefficient of v_{k-1} in row k (k >= 2)
    diag = 2.0 * (h[:-1] + h[1:])
    sup = h[:-2].copy()  # coefficient of v_{k+1} in row k (k <= n-3)
    rhs = 3.0 * (h[1:, None] * d[:-1] + h[:-1, None] * d[1:])
    rhs[0] -= h[1] * v[0]
    rhs[-1] -= h[-2] * v[-1]
    cp = np.zeros(m)
    dp = np.zeros((m, q.shape[1]))
    cp[0] = sup[0] / diag[0] if m > 1 else 0.0
    dp[0] = rhs[0] / diag[0]
    for k in range(1, m):
        den = diag[k] - sub[k - 1] * cp[k - 1]
        cp[k] = sup[k] / den if k < m - 1 else 0.0
        dp[k] = (rhs[k] - sub[k - 1] * dp[k - 1]) / den
    x = np.zeros((m, q.shape[1]))
    x[-1] = dp[-1]
    for k in range(m - 2, -1, -1):
        x[k] = dp[k] - cp[k] * x[k + 1]
    v[1:-1] = x
    return v


def spline_through(times: Array, q: Array, kind: Interpolation, v_start: Array | None = None,
                   v_end: Array | None = None) -> PiecewisePolynomial:
    """The C2 spline through keyframes ``q`` ``(n, dof)`` at ``times``.

    Args:
        times: ``(n,)`` increasing knot times [s] from 0.
        q: Keyframe positions.
        kind: :attr:`Interpolation.CUBIC` or :attr:`Interpolation.MIN_JERK`.
        v_start: Velocity at the first knot (rest when ``None``).
        v_end: Velocity at the last knot (rest when ``None``).
    """
    v = cubic_knot_velocities(times, q, v_start, v_end)
    h = np.diff(times)
    if kind is Interpolation.CUBIC:
        d = np.diff(q, axis=0)
        c2 = (3.0 * d / h[:, None] - 2.0 * v[:-1] - v[1:]) / h[:, None]
        c3 = (-2.0 * d / h[:, None] + v[:-1] + v[1:]) / h[:, None] ** 2
        coeffs = np.stack([q[:-1], v[:-1], c2, c3], axis=1)
        return PiecewisePolynomial(times, coeffs)
    # Minimum jerk: quintic segments matching the C2 cubic's knot velocities and accelerations,
    # zero acceleration at the ends of the run.
    acc = np.zeros_like(q)
    if q.shape[0] > 2:
        d = np.diff(q, axis=0)
        c2 = (3.0 * d / h[:, None] - 2.0 * v[:-1] - v[1:]) / h[:, None]
        acc[1:-1] = 2.0 * c2[1:]
    coeffs = np.stack([quintic_segment(q[k], v[k], acc[k], q[k + 1], v[k + 1], acc[k + 1],
                                       float(h[k])) for k in range(h.size)])
    return PiecewisePolynomial(times, coeffs)


def _segment_ratios(poly: PiecewisePolynomial, limits: MotionLimits, jerk: bool) -> Array:
    """Per segment, the largest ratio of velocity, sqrt(acceleration), cbrt(jerk) to its limit."""
    breaks = poly.breakpoints()
    m = breaks.size - 1
    u = np.linspace(0.0, 1.0, _SAMPLES_PER_SEGMENT)
    ts = (breaks[:-1, None] + np.diff(breaks)[:, None] * u[None, :]).reshape(-1)
    _, qd, qdd = poly.sample_many(ts)
    rv = np.abs(qd) / limits.velocity
    ra = np.sqrt(np.abs(qdd) / limits.acceleration)
    r = np.maximum(rv, ra).reshape(m, u.size, -1).max(axis=(1, 2))
    if jerk and np.any(np.isfinite(limits.jerk)):
        c = poly._c  # piecewise jerk: third derivative of each piece, checked at its samples
        taus = np.diff(breaks)[:, None] * u[None, :]
        j3 = np.zeros((m, u.size, poly.dof))
        for i in range(3, c.shape[1]):
            fact = i * (i - 1) * (i - 2)
            j3 += fact * c[:, i, None, :] * taus[:, :, None] ** (i - 3)
        rj = np.cbrt(np.abs(j3) / limits.jerk).max(axis=(1, 2))
        r = np.maximum(r, rj)
    return np.asarray(r)


def _initial_durations(q: Array, limits: MotionLimits) -> Array:
    d = np.abs(np.diff(q, axis=0))
    h = np.maximum(d / limits.velocity, 2.0 * np.sqrt(d / limits.acceleration)).max(axis=1)
    return np.maximum(h, 1e-3)


def plan_run(q: npt.ArrayLike, limits: MotionLimits, kind: Interpolation,
             durations: npt.ArrayLike | None = None) -> tuple[Trajectory, Array]:
    """A trajectory through keyframes ``q`` ``(n, dof)``, at rest at the first and last.

    Args:
        q: Keyframes; consecutive ones must differ.
        limits: Speed-scaled limits to plan with.
        kind: The interpolation.
        durations: ``(n - 1,)`` segment durations [s] to keep (recorded timing); ``None`` plans
            near-time-optimal durations within the limits.

    Returns:
        The trajectory, and the time [s] at which it passes each keyframe ``(n,)``.

    Raises:
        PlanningError: If it cannot be planned.
    """
    pts = np.asarray(q, dtype=float)
    if pts.ndim != 2 or pts.shape[0] < 2:
        raise PlanningError("a run needs at least two keyframes")
    if durations is None and kind is not Interpolation.LINEAR:
        # A keyframe equal to the one before (a pause in a recording) adds no segment: the
        # spline goes through the distinct ones and passes the repeats at the same time.
        keep = np.concatenate([[True], np.any(np.diff(pts, axis=0) != 0.0, axis=1)])
        if not keep.all():
            if int(keep.sum()) < 2:
                return _linear_run(pts, limits, None)
            traj, knots = plan_run(pts[keep], limits, kind)
            return traj, knots[np.cumsum(keep) - 1]
    if kind is Interpolation.LINEAR:
        return _linear_run(pts, limits, None if durations is None else np.asarray(durations))
    traj = _spline_run(pts, limits, kind, durations)
    split = _overshoot_knot(traj, limits)
    if split is None:
        return traj, traj.breakpoints()
    # The spline swings past a position limit next to this keyframe: stop there instead.
    first, t1 = plan_run(pts[: split + 1], limits, kind,
                         None if durations is None else np.asarray(durations)[:split])
    second, t2 = plan_run(pts[split:], limits, kind,
                          None if durations is None else np.asarray(durations)[split:])
    return Chain([first, second]), np.concatenate([t1, t2[1:] + first.duration])


def piece_extrema(poly: PiecewisePolynomial) -> tuple[Array, Array]:
    """Exact lowest and highest value of every coordinate on every piece ``(m, dof)`` each.

    A polynomial piece takes its extremes at its ends or where its derivative vanishes: for a
    cubic at the roots of a quadratic (closed form), for a quintic (minimum jerk) at the roots
    of a quartic (the eigenvalues of its companion matrix, as :func:`numpy.roots` finds them).
    Every candidate is a point of the piece (a root's real part, clipped to the piece), so the
    result never exceeds the piece's true range, and it reaches it up to the rounding of the
    roots (a double root is found to ``sqrt(eps)`` of its place, where the value is flat to
    second order).
    """
    breaks = poly.breakpoints()
    c = poly._c  # (m, order, dof), ascending powers of the time within the piece
    m, order, dof = c.shape
    h = np.diff(breaks)
    taus = [np.zeros((m, dof)), np.broadcast_to(h[:, None], (m, dof))]
    if order == 4:
        # derivative 3 c3 t^2 + 2 c2 t + c1: both roots by the cancellation-free formula
        a, b, k = 3.0 * c[:, 3], 2.0 * c[:, 2], c[:, 1]
        disc = np.maximum(b * b - 4.0 * a * k, 0.0)
        qq = -0.5 * (b + np.copysign(np.sqrt(disc), b))
        with np.errstate(divide="ignore", invalid="ignore"):
            taus += [np.where(a != 0.0, qq / a, -k / b), np.where(qq != 0.0, k / qq, 0.0)]
    elif order > 2:
        # roots of the derivative as the eigenvalues of its companion matrix (as numpy.roots
        # finds them), all pieces and coordinates at once; a zero leading coefficient (a piece
        # of lower degree) by numpy.roots, which drops it
        deg = order - 2
        deriv = (c[:, 1:, :] * np.arange(1, order, dtype=float)[None, :, None])[:, ::-1, :]
        flat = np.moveaxis(deriv, 1, -1).reshape(m * dof, deg + 1)  # highest power first
        roots = np.zeros((m * dof, deg))  # 0: the piece's start, a candidate anyway
        full = flat[:, 0] != 0.0
        if full.any():
            comp = np.zeros((int(full.sum()), deg, deg))
            comp[:, 0, :] = -flat[full, 1:] / flat[full, :1]
            comp[:, np.arange(1, deg), np.arange(deg - 1)] = 1.0
            roots[full] = np.linalg.eigvals(comp).real
        for row in np.flatnonzero(~full & np.any(flat != 0.0, axis=1)):
            r = np.roots(flat[row]).real
            roots[row, : r.size] = r
        taus += list(np.moveaxis(roots.reshape(m, dof, deg), -1, 0))
    lo = np.full((m, dof), np.inf)
    hi = np.full((m, dof), -np.inf)
    for tau in taus:
        t = np.clip(np.nan_to_num(np.asarray(tau, dtype=float), nan=0.0), 0.0, h[:, None])
        val = c[:, -1]
        for p in range(order - 2, -1, -1):
            val = val * t + c[:, p]
        lo = np.minimum(lo, val)
        hi = np.maximum(hi, val)
    return lo, hi


def _overshoot_pieces(traj: PiecewisePolynomial, limits: MotionLimits) -> Array:
    """Per piece, whether it leaves the position limits ``(m,)``.

    Exact: from each piece's extremes (:func:`piece_extrema`), beyond a limit by more than the
    tolerance of the final check; a piece with one of its 48 evenly spaced samples outside a
    limit at all counts too (the test of earlier versions, kept so that every plan it
    accepted is planned as before).
    """
    breaks = traj.breakpoints()
    m = breaks.size - 1
    lo, hi = piece_extrema(traj)
    out = np.any((lo < limits.lower - _LIMIT_TOL) | (hi > limits.upper + _LIMIT_TOL), axis=1)
    u = np.linspace(0.0, 1.0, _SAMPLES_PER_SEGMENT)
    ts = (breaks[:-1, None] + np.diff(breaks)[:, None] * u[None, :]).reshape(-1)
    q, _, _ = traj.sample_many(ts)
    sampled = ((q < limits.lower) | (q > limits.upper)).reshape(m, u.size, -1).any(axis=(1, 2))
    return np.asarray(out | sampled)


def split_knot(out: npt.ArrayLike) -> int | None:
    """The inner knot at which to stop a run whose pieces ``out`` leave the limits, if any.

    The end of the first piece that leaves them (its start when it is the last piece): the
    run is planned again as two runs, at rest at that knot, each split again until no piece
    leaves. A run of one piece starts and ends at rest and is monotone in every scalar
    coordinate, so the splitting ends inside the limits.
    """
    bad = np.asarray(out, dtype=bool)
    m = bad.size
    if m < 2 or not bad.any():
        return None
    k = int(np.argmax(bad))
    return k + 1 if k + 1 < m else k


def _overshoot_knot(traj: PiecewisePolynomial, limits: MotionLimits) -> int | None:
    """An inner knot next to the first piece that leaves the position limits, if any."""
    if traj.breakpoints().size < 3:
        return None
    return split_knot(_overshoot_pieces(traj, limits))


def _spline_run(pts: Array, limits: MotionLimits, kind: Interpolation,
                durations: npt.ArrayLike | None) -> PiecewisePolynomial:
    if durations is not None:
        h = np.asarray(durations, dtype=float)
        return spline_through(np.concatenate([[0.0], np.cumsum(h)]), pts, kind)
    h = _initial_durations(pts, limits)
    jerk = kind is Interpolation.MIN_JERK
    for _ in range(8):
        poly = spline_through(np.concatenate([[0.0], np.cumsum(h)]), pts, kind)
        r = _segment_ratios(poly, limits, jerk)
        if np.all(np.abs(r - 1.0) < 0.05):
            break
        h = h * np.clip(r, 0.5, 2.0) ** 0.8
    poly = spline_through(np.concatenate([[0.0], np.cumsum(h)]), pts, kind)
    h = h * float(np.max(_segment_ratios(poly, limits, jerk))) * _MARGIN
    return spline_through(np.concatenate([[0.0], np.cumsum(h)]), pts, kind)


def _via_velocities(q: Array, limits: MotionLimits, cautious: bool = False) -> Array:
    """Velocities at the inner keyframes of a blended S-curve run (rest at both ends).

    By default the velocities of a C2 cubic spline through the keyframes (timed by the
    per-segment estimate), capped by what the acceleration limit can build up or shed over the
    shorter neighbouring distance and by 90% of the velocity limit. ``cautious``: a joint keeps
    moving through a keyframe only if it moves the same way before and after, at the slower of
    the two neighbouring chord speeds (no overshoot past a turning point).
    """
    v = np.zeros_like(q)
    if q.shape[0] <= 2:
        return v
    d = np.diff(q, axis=0)
    h = _initial_durations(q, limits)
    reach = np.sqrt(limits.acceleration * np.minimum(np.abs(d[:-1]), np.abs(d[1:])))
    cap = np.minimum(reach, 0.9 * limits.velocity)
    if not cautious:
        spline = cubic_knot_velocities(np.concatenate([[0.0], np.cumsum(h)]), q)
        v[1:-1] = np.clip(spline[1:-1], -cap, cap)
        return v
    chord = d / h[:, None]
    same = np.sign(d[:-1]) * np.sign(d[1:]) > 0
    speed = np.minimum(np.minimum(np.abs(chord[:-1]), np.abs(chord[1:])), cap)
    v[1:-1] = np.where(same, np.sign(d[1:]) * speed, 0.0)
    return v


def _leaves_limits(part: RuckigTrajectory, limits: MotionLimits) -> bool:
    lo, hi = part.position_extrema()
    return bool(np.any(lo < limits.lower) or np.any(hi > limits.upper))


def _recorded_state(q: Array, durations: Array, limits: MotionLimits) -> tuple[Array, Array]:
    """Velocities and accelerations at the inner keyframes of a recording.

    Central differences of the samples, within 90% of the limits; rest at both ends.
    """
    v = np.zeros_like(q)
    acc = np.zeros_like(q)
    if q.shape[0] > 2:
        t = np.concatenate([[0.0], np.cumsum(durations)])
        v[1:-1] = (q[2:] - q[:-2]) / (t[2:] - t[:-2])[:, None]
        v = np.clip(v, -0.9 * limits.velocity, 0.9 * limits.velocity)
        acc[1:-1] = (v[2:] - v[:-2]) / (t[2:] - t[:-2])[:, None]
        acc = np.clip(acc, -0.9 * limits.acceleration, 0.9 * limits.acceleration)
    return v, acc


def _linear_run(q: Array, limits: MotionLimits, durations: Array | None,
                cautious: bool = False) -> tuple[Trajectory, Array]:
    if durations is None:
        v, acc = _via_velocities(q, limits, cautious), np.zeros_like(q)
    else:
        v, acc = _recorded_state(q, durations, limits)
    parts = []
    for k in range(q.shape[0] - 1):
        rest = not (v[k].any() or v[k + 1].any() or acc[k].any() or acc[k + 1].any())
        try:
            part = ruckig_move(q[k], q[k + 1], limits, v0=v[k], v1=v[k + 1], a0=acc[k],
                               a1=acc[k + 1], straight=rest,
                               min_duration=None if durations is None else float(durations[k]))
        except PlanningError:
            if rest:
                raise
            v[k + 1] = 0.0  # the blend was not feasible: stop at this keyframe instead
            acc[k + 1] = 0.0
            part = ruckig_move(q[k], q[k + 1], limits, v0=v[k], a0=acc[k], straight=False)
        if (durations is None and not cautious and isinstance(part, RuckigTrajectory)
                and _leaves_limits(part, limits)):
            # Blending through a turning point swings past a position limit: use the cautious
            # velocities (no overshoot at turning points) for this run.
            return _linear_run(q, limits, durations, cautious=True)
        parts.append(part)
    knots = np.concatenate([[0.0], np.cumsum([p.duration for p in parts])])
    return (parts[0] if len(parts) == 1 else Chain(parts)), knots
