"""Moves and keyframe runs of arms with universal and ball joints.

The scalar coordinates (1-DOF joints, a universal joint's two angles) are planned exactly as
for an arm of 1-DOF joints; a ball joint turns on the sphere:

- a move, and a ``linear`` segment, turns it on the great circle (slerp) timed by its geodesic
  angle, in one synchronised Ruckig profile with the other coordinates
  (:class:`~armctl.motion.layout.GeodesicMove`); the ball joint rests at every keyframe of a
  linear run (the axis of its turn changes there), the scalar coordinates blend through them as
  in :func:`~armctl.motion.interpolate.plan_run`;
- a ``cubic`` or ``min-jerk`` run joins its keyframes by the C1 quaternion spline of Kim, Kim
  and Shin (:class:`~armctl.motion.quaternion_spline.QuaternionSpline`): the angular velocity
  is continuous through the keyframes. The segment durations are timed near-optimally as for
  1-DOF arms, the ball joint's rates being the norms of its angular velocity and acceleration.
  A run that leaves a position limit between keyframes (a scalar coordinate, found from its
  segments' exact extremes, or a ball joint's swing or twist, found by a bound on its spline's
  angular speed that cannot miss) stops at the keyframe next to it, as a 1-DOF arm's run does.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt

from armctl.errors import PlanningError
from armctl.kinematics.joint_space import BallJoint
from armctl.motion.interpolate import (
    Interpolation,
    _overshoot_pieces,
    _recorded_state,
    _segment_ratios,
    _via_velocities,
    spline_through,
    split_knot,
)
from armctl.motion.layout import GeodesicMove, JointLayout, swing_twist_many
from armctl.motion.limits import MotionLimits
from armctl.motion.profiles import ruckig_move
from armctl.motion.quaternion_spline import QuaternionSpline
from armctl.motion.trajectory import Chain, PiecewisePolynomial, Sampled, Trajectory
from armctl.typing import Array

__all__ = ["SphereRun", "geodesic_move", "plan_layout_run"]

_MARGIN = 1.01
_SAMPLES_PER_SEGMENT = 48
#: How far [rad] a ball joint's swing or twist may pass its limit on the path (that of the
#: final check of a plan).
_BALL_TOL = 1e-9
#: Most intervals the ball-limit test bisects at once before it takes a segment as leaving.
_MAX_INTERVALS = 20000
#: Most halvings of one interval (from 1/47 of a segment) before it counts as leaving.
_MAX_HALVINGS = 60


def _layout(limits: MotionLimits) -> JointLayout:
    if limits.layout is None:
        raise PlanningError("these limits are of an arm of 1-DOF joints; plan it with "
                            "plan_run or ruckig_move")
    return limits.layout


def reduced_limits(limits: MotionLimits) -> MotionLimits:
    """The limits of the reduced coordinates: scalar coordinates, then ball joints' angles."""
    lay = _layout(limits)
    vel, acc, jerk = limits.rate_limits()
    lo = np.concatenate([limits.lower[lay.scalar_q], np.full(len(lay.balls), -np.inf)])
    hi = np.concatenate([limits.upper[lay.scalar_q], np.full(len(lay.balls), np.inf)])
    return MotionLimits(lay.rate_names, lo, hi, vel, acc, jerk, lay.rate_units)


def _scalar_limits(limits: MotionLimits) -> MotionLimits:
    lay = _layout(limits)
    return reduced_limits(limits).subset(np.arange(lay.scalar_q.size))


def geodesic_move(q0: npt.ArrayLike, q1: npt.ArrayLike, limits: MotionLimits, *,
                  v0: npt.ArrayLike | None = None, v1: npt.ArrayLike | None = None,
                  a0: npt.ArrayLike | None = None, a1: npt.ArrayLike | None = None,
                  min_duration: float | None = None) -> GeodesicMove:
    """A time-optimal, jerk-limited move with every joint synchronised, ball joints on arcs.

    Args:
        q0: Start configuration ``(nq,)``.
        q1: Goal configuration ``(nq,)``.
        limits: Speed-scaled limits of the arm (with a layout).
        v0: Start velocities of the scalar coordinates (rest when ``None``); ball joints start
            and end at rest.
        v1: Goal velocities of the scalar coordinates.
        a0: Start accelerations of the scalar coordinates.
        a1: Goal accelerations of the scalar coordinates.
        min_duration: Make the move last at least this long [s].

    Raises:
        PlanningError: If Ruckig cannot compute the move.
    """
    lay = _layout(limits)
    start, goal = lay.normalize(q0), lay.normalize(q1)
    rot = lay.ball_angles(start, goal)
    angles = np.linalg.norm(rot, axis=1)
    axes = np.where(angles[:, None] > 1e-15, rot / np.maximum(angles, 1e-300)[:, None],
                    np.array([1.0, 0.0, 0.0]))
    nb = len(lay.balls)
    r0 = np.concatenate([start[lay.scalar_q], np.zeros(nb)])
    r1 = np.concatenate([goal[lay.scalar_q], angles])

    def full(x: npt.ArrayLike | None) -> Array | None:
        return None if x is None else np.concatenate([np.asarray(x, dtype=float),
                                                      np.zeros(nb)])

    traj = ruckig_move(r0, r1, reduced_limits(limits), v0=full(v0), v1=full(v1), a0=full(a0),
                       a1=full(a1), straight=True, min_duration=min_duration)
    return GeodesicMove(start, lay, axes, traj)


class SphereRun(Trajectory):
    """A spline through keyframes: scalar coordinates by polynomials, ball joints on the sphere.

    Args:
        times: ``(n,)`` increasing keyframe times [s] from 0.
        knots: ``(n, nq)`` keyframe configurations.
        layout: The arm's layout.
        kind: :attr:`Interpolation.CUBIC` or :attr:`Interpolation.MIN_JERK` (of the scalar
            coordinates; ball joints take the C1 quaternion spline for both).
    """

    def __init__(self, times: npt.ArrayLike, knots: npt.ArrayLike, layout: JointLayout,
                 kind: Interpolation):
        self.times = np.asarray(times, dtype=float)
        pts = np.asarray(knots, dtype=float)
        self.layout = layout
        self.dof = layout.nv
        self.scalar: PiecewisePolynomial | None = (
            spline_through(self.times, pts[:, layout.scalar_q], kind)
            if layout.scalar_q.size else None)
        self.splines = tuple(QuaternionSpline(self.times, pts[:, b.q]) for b in layout.balls)

    @property
    def nq(self) -> int:  # noqa: D102
        return self.layout.nq

    @property
    def duration(self) -> float:  # noqa: D102
        return float(self.times[-1] - self.times[0])

    def breakpoints(self) -> Array:  # noqa: D102
        return self.times - self.times[0]

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:  # noqa: D102
        t = np.clip(np.asarray(ts, dtype=float).reshape(-1), 0.0, self.duration)
        lay = self.layout
        q = np.empty((t.size, lay.nq))
        qd = np.empty((t.size, lay.nv))
        qdd = np.empty((t.size, lay.nv))
        if self.scalar is not None:
            s, sd, sdd = self.scalar.sample_many(t)
            q[:, lay.scalar_q], qd[:, lay.scalar_v], qdd[:, lay.scalar_v] = s, sd, sdd
        for b, spline in zip(lay.balls, self.splines, strict=True):
            q[:, b.q], qd[:, b.v], qdd[:, b.v] = spline.sample(t + self.times[0])
        return q, qd, qdd

    def sample(self, t: float) -> Sampled:  # noqa: D102
        q, qd, qdd = self.sample_many([t])
        return q[0], qd[0], qdd[0]


def _aligned(pts: Array, layout: JointLayout) -> Array:
    """Keyframes with each ball joint's quaternion on the near side of the one before."""
    out = np.array(pts, dtype=float)
    for b in layout.balls:
        for k in range(1, len(out)):
            if out[k, b.q] @ out[k - 1, b.q] < 0.0:
                out[k, b.q] = -out[k, b.q]
    return out


def _sphere_ratios(run: SphereRun, limits: MotionLimits, jerk: bool) -> Array:
    """Per segment, the largest ratio of a rate, sqrt(acceleration) (scalar: cbrt(jerk))."""
    breaks = run.breakpoints()
    m = breaks.size - 1
    r = np.zeros(m)
    if run.scalar is not None:
        r = _segment_ratios(run.scalar, _scalar_limits(limits), jerk)
    if run.splines:
        lay = run.layout
        vel, acc, _ = limits.rate_limits()
        ns = lay.scalar_q.size
        # up to just before each segment's end: the angular acceleration steps at keyframes
        # (C1), and a sample at the end itself belongs to the next segment
        u = np.linspace(0.0, 1.0 - 1e-9, _SAMPLES_PER_SEGMENT)
        ts = (breaks[:-1, None] + np.diff(breaks)[:, None] * u[None, :]).reshape(-1)
        _, qd, qdd = run.sample_many(ts)
        rv = lay.rates(qd)[:, ns:] / vel[ns:]
        ra = np.sqrt(lay.rates(qdd)[:, ns:] / acc[ns:])
        r = np.maximum(r, np.maximum(rv, ra).reshape(m, u.size, -1).max(axis=(1, 2)))
    return r


def _sphere_spline(pts: Array, limits: MotionLimits, kind: Interpolation,
                   durations: npt.ArrayLike | None) -> SphereRun:
    lay = _layout(limits)
    if durations is not None:
        h = np.asarray(durations, dtype=float)
        return SphereRun(np.concatenate([[0.0], np.cumsum(h)]), pts, lay, kind)
    red = reduced_limits(limits)
    angles = np.array([np.linalg.norm(lay.ball_angles(a, b), axis=1)
                       for a, b in itertools.pairwise(pts)]).reshape(len(pts) - 1, -1)
    dist = np.concatenate([np.abs(np.diff(pts[:, lay.scalar_q], axis=0)), angles], axis=1)
    h = np.maximum(dist / red.velocity, 2.0 * np.sqrt(dist / red.acceleration)).max(axis=1)
    h = np.maximum(h, 1e-3)
    jerk = kind is Interpolation.MIN_JERK
    for _ in range(8):
        run = SphereRun(np.concatenate([[0.0], np.cumsum(h)]), pts, lay, kind)
        r = _sphere_ratios(run, limits, jerk)
        if np.all(np.abs(r - 1.0) < 0.05):
            break
        h = h * np.clip(r, 0.5, 2.0) ** 0.8
    run = SphereRun(np.concatenate([[0.0], np.cumsum(h)]), pts, lay, kind)
    h = h * float(np.max(_sphere_ratios(run, limits, jerk))) * _MARGIN
    return SphereRun(np.concatenate([[0.0], np.cumsum(h)]), pts, lay, kind)


def plan_layout_run(q: npt.ArrayLike, limits: MotionLimits, kind: Interpolation,
                    durations: npt.ArrayLike | None = None) -> tuple[Trajectory, Array]:
    """:func:`~armctl.motion.interpolate.plan_run` for an arm with universal or ball joints.

    Args:
        q: ``(n, nq)`` keyframe configurations (ball joints as unit quaternions).
        limits: Speed-scaled limits (with a layout).
        kind: The interpolation.
        durations: ``(n - 1,)`` segment durations [s] to keep; ``None``: near time-optimal.

    Returns:
        The trajectory, and the time [s] at which it passes each keyframe ``(n,)``.

    Raises:
        PlanningError: If it cannot be planned.
    """
    lay = _layout(limits)
    pts = np.asarray(q, dtype=float)
    if pts.ndim != 2 or pts.shape[0] < 2:
        raise PlanningError("a run needs at least two keyframes")
    pts = _aligned(np.stack([lay.normalize(p) for p in pts]), lay)
    if durations is None and kind is not Interpolation.LINEAR:
        keep = np.concatenate([[True], np.any(np.diff(pts, axis=0) != 0.0, axis=1)])
        if not keep.all():
            if int(keep.sum()) < 2:
                return _linear_layout_run(pts, limits, None)
            traj, knots = plan_layout_run(pts[keep], limits, kind)
            return traj, knots[np.cumsum(keep) - 1]
    if kind is Interpolation.LINEAR:
        return _linear_layout_run(pts, limits,
                                  None if durations is None else np.asarray(durations))
    run = _sphere_spline(pts, limits, kind, durations)
    out = np.zeros(len(pts) - 1, dtype=bool)
    if len(pts) > 2:
        if run.scalar is not None:
            out |= _overshoot_pieces(run.scalar, _scalar_limits(limits))
        for b, spline in zip(lay.balls, run.splines, strict=True):
            if b.limited:
                out |= np.array([_ball_leaves(spline, k, b) for k in range(len(pts) - 1)])
    split = split_knot(out)
    if split is None:
        return run, run.breakpoints()
    first, t1 = plan_layout_run(pts[: split + 1], limits, kind,
                                None if durations is None else np.asarray(durations)[:split])
    second, t2 = plan_layout_run(pts[split:], limits, kind,
                                 None if durations is None else np.asarray(durations)[split:])
    return Chain([first, second]), np.concatenate([t1, t2[1:] + first.duration])


def _ball_leaves(spline: QuaternionSpline, k: int, ball: BallJoint) -> bool:
    """Whether segment ``k`` of a ball joint's spline turns it outside its swing or twist limits.

    A bound that cannot miss: between two samples the angular speed is at most ``W``
    (:meth:`QuaternionSpline.speed_bound`, from the spline's control rotations). The swing (the
    angle of the twist axis from its rest direction) is 1-Lipschitz in the angle turned, so
    between samples ``a`` and ``b``, ``δ`` apart, it stays below ``(s_a + s_b + W δ) / 2``;
    the twist ``2 atan2(p, w)`` changes at most at ``W / cos(swing / 2)``
    (``|(w', p')| <= |q'| = |ω| / 2``), which bounds it the same way with the swing's bound in
    the cosine. Starting from 48 samples, an interval whose
    bounds do not prove it inside is halved until they do, a sample is outside, or it is short
    enough (``W δ / 2`` within the tolerance) that the samples decide. Too many intervals
    (a path running along its limit) or halvings count as leaving: the run then stops at a
    keyframe.
    """
    t0, t1 = float(spline.times[k]), float(spline.times[k + 1])
    half = _BALL_TOL / 2.0
    cone = ball.swing < math.pi
    twisted = math.isfinite(ball.lower) or math.isfinite(ball.upper)

    def values(ts: Array) -> tuple[Array, Array]:
        return swing_twist_many(spline(ts), ball.axis)

    ts = np.linspace(t0, t1, _SAMPLES_PER_SEGMENT)
    sw, tw = values(ts)
    ta, tb, sa, sb, wa, wb = ts[:-1], ts[1:], sw[:-1], sw[1:], tw[:-1], tw[1:]
    depth = 0
    while True:
        if cone and (np.any(sa > ball.swing + half) or np.any(sb > ball.swing + half)):
            return True
        if twisted and (np.any((wa < ball.lower - half) | (wa > ball.upper + half))
                        or np.any((wb < ball.lower - half) | (wb > ball.upper + half))):
            return True
        delta = tb - ta
        spread = spline.speed_bound(k, (ta - t0) / (t1 - t0), (tb - t0) / (t1 - t0)) * delta
        s_hi = np.minimum((sa + sb + spread) / 2.0, math.pi)
        ok = (s_hi <= ball.swing + _BALL_TOL) if cone else np.ones(s_hi.size, dtype=bool)
        short = spread <= half  # the samples (checked within half the tolerance) decide
        if twisted:
            with np.errstate(divide="ignore"):
                reach = np.where(s_hi < math.pi, spread / np.cos(s_hi / 2.0), np.inf)
            ok &= ((np.abs(wb - wa) <= reach + 1e-12)
                   & ((wa + wb + reach) / 2.0 <= ball.upper + _BALL_TOL)
                   & ((wa + wb - reach) / 2.0 >= ball.lower - _BALL_TOL))
            short &= reach <= half
        ok |= short
        if ok.all():
            return False
        keep = ~ok
        depth += 1
        if int(keep.sum()) > _MAX_INTERVALS or depth > _MAX_HALVINGS:
            return True
        ta, tb, sa, sb, wa, wb = ta[keep], tb[keep], sa[keep], sb[keep], wa[keep], wb[keep]
        tm = (ta + tb) / 2.0
        sm, wm = values(tm)
        ta, tb = np.concatenate([ta, tm]), np.concatenate([tm, tb])
        sa, sb = np.concatenate([sa, sm]), np.concatenate([sm, sb])
        wa, wb = np.concatenate([wa, wm]), np.concatenate([wm, wb])


def _linear_layout_run(pts: Array, limits: MotionLimits, durations: Array | None,
                       cautious: bool = False) -> tuple[Trajectory, Array]:
    """Geodesic segments; the scalar coordinates blend through the keyframes."""
    lay = _layout(limits)
    scalar = pts[:, lay.scalar_q]
    slim = _scalar_limits(limits)
    if scalar.shape[1] == 0:  # ball joints only: every one rests at every keyframe
        v, acc = np.zeros_like(scalar), np.zeros_like(scalar)
    elif durations is None:
        v, acc = _via_velocities(scalar, slim, cautious), np.zeros_like(scalar)
    else:
        v, acc = _recorded_state(scalar, durations, slim)
    parts: list[Trajectory] = []
    for k in range(pts.shape[0] - 1):
        try:
            part = geodesic_move(pts[k], pts[k + 1], limits, v0=v[k], v1=v[k + 1], a0=acc[k],
                                 a1=acc[k + 1],
                                 min_duration=None if durations is None else float(durations[k]))
        except PlanningError:
            if not (v[k + 1].any() or acc[k + 1].any()):
                raise
            v[k + 1] = 0.0  # the blend was not feasible: stop at this keyframe instead
            acc[k + 1] = 0.0
            part = geodesic_move(pts[k], pts[k + 1], limits, v0=v[k], a0=acc[k])
        if durations is None and not cautious:
            lo, hi = part.position_extrema()
            sq = lay.scalar_q
            if np.any(lo[sq] < limits.lower[sq]) or np.any(hi[sq] > limits.upper[sq]):
                return _linear_layout_run(pts, limits, durations, cautious=True)
        parts.append(part)
    knots = np.concatenate([[0.0], np.cumsum([p.duration for p in parts])])
    return (parts[0] if len(parts) == 1 else Chain(parts)), knots
