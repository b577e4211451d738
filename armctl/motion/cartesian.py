"""Straight-line (Cartesian) moves: position along a line, orientation by SLERP, IK per sample.

The line is cut into samples no more than ``max_step`` apart (and ``max_rotation_step`` in
orientation). Each sample is solved by IK seeded with the previous solution and without random
restarts, so the arm stays on one branch; a sample that fails, or a joint that jumps between two
samples, stops planning and reports how far along the path it got. The joint path is then a C2
quintic spline over the path parameter ``s`` and is timed with a minimum-jerk ``s(t)`` scaled to
the velocity, acceleration and jerk limits and, when given, to the tool's linear and angular
speed limits (:class:`LineOptions` ``tcp_speed`` [m/s], ``tcp_angular_speed`` [rad/s]). Nothing
moves unless the whole path is planned and
checked.

An arm with universal or ball joints follows the same line: the IK samples are the same (the
tangent IK, seeded by the previous sample); a joint's jump between two samples is measured in
the tangent space (a ball joint's by its geodesic angle, each quaternion taken on the near side
of the one before), and every sample must lie inside the limits (a ball joint's swing and
twist). The joint path through the samples is then a keyframe-like run over ``s``
(:class:`SpherePath`): the scalar coordinates by the same C2 quintic spline, each ball joint by
the C1 quaternion spline on the sphere of :mod:`armctl.motion.multi_dof`'s keyframe runs. It is
timed with the same minimum-jerk ``s(t)``; the velocity and acceleration limits bound the norms
of a ball joint's angular velocity and acceleration, and its angular jerk is not bounded (its
angular acceleration steps at the samples, as in a keyframe spline run), the scalar
coordinates' jerk is.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.config.schema import JointType
from armctl.errors import InputError, JointLimitError
from armctl.ik import Goal, IKOptions
from armctl.kinematics.model import KinematicModel
from armctl.motion.errors import PathError
from armctl.motion.interpolate import Interpolation, spline_through
from armctl.motion.layout import JointLayout
from armctl.motion.limits import MotionLimits, check_trajectory
from armctl.motion.plan import MotionPlan, Waypoint
from armctl.motion.profiles import quintic_segment
from armctl.motion.quaternion_spline import QuaternionSpline
from armctl.motion.quaternions import conj, quat_log, quat_multiply
from armctl.motion.trajectory import PathTrajectory, PiecewisePolynomial, Sampled, Trajectory
from armctl.typing import Array

__all__ = ["LineOptions", "SpherePathTrajectory", "interpolate_goal", "plan_line"]



class SpherePath(Trajectory):
    """A joint path ``q(s)`` through the IK samples of an arm with ball joints, ``s`` in [0, 1].

    The scalar coordinates by the C2 quintic spline of an arm of 1-DOF joints, each ball joint
    by the C1 quaternion spline (:class:`~armctl.motion.quaternion_spline.QuaternionSpline`)
    over the same knots; at both ends each coordinate keeps the rate of the first and last
    chord (as the 1-DOF path does), so the frame goes along the line at a nearly even rate in
    ``s``. "Time" here is ``s``: velocities are ``dq/ds`` (a ball joint's body angular velocity
    per unit of ``s``).

    Args:
        knots: ``(n + 1,)`` increasing values of ``s`` from 0 to 1.
        qs: ``(n + 1, nq)`` the samples, each quaternion on the near side of the one before.
        layout: The arm's layout.
    """

    def __init__(self, knots: Array, qs: Array, layout: JointLayout):
        self.knots = np.asarray(knots, dtype=float)
        self.layout = layout
        self.dof = layout.nv
        first, last = self.knots[1] - self.knots[0], self.knots[-1] - self.knots[-2]
        sq = layout.scalar_q
        self.scalar: PiecewisePolynomial | None = (
            spline_through(self.knots, qs[:, sq], Interpolation.MIN_JERK,
                           (qs[1, sq] - qs[0, sq]) / first, (qs[-1, sq] - qs[-2, sq]) / last)
            if sq.size else None)
        self.splines = tuple(
            QuaternionSpline(self.knots, qs[:, b.q],
                             quat_log(quat_multiply(conj(qs[0, b.q]), qs[1, b.q])) / first,
                             quat_log(quat_multiply(conj(qs[-2, b.q]), qs[-1, b.q])) / last)
            for b in layout.balls)

    @property
    def nq(self) -> int:
        return self.layout.nq

    @property
    def duration(self) -> float:
        return float(self.knots[-1] - self.knots[0])

    def breakpoints(self) -> Array:
        return self.knots - self.knots[0]

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:
        s = np.clip(np.asarray(ts, dtype=float).reshape(-1), self.knots[0], self.knots[-1])
        lay = self.layout
        q = np.empty((s.size, lay.nq))
        qd = np.empty((s.size, lay.nv))
        qdd = np.empty((s.size, lay.nv))
        if self.scalar is not None:
            a, ad, add = self.scalar.sample_many(s - self.knots[0])
            q[:, lay.scalar_q], qd[:, lay.scalar_v], qdd[:, lay.scalar_v] = a, ad, add
        for b, spline in zip(lay.balls, self.splines, strict=True):
            q[:, b.q], qd[:, b.v], qdd[:, b.v] = spline.sample(s)
        return q, qd, qdd

    def sample(self, t: float) -> Sampled:
        q, qd, qdd = self.sample_many([t])
        return q[0], qd[0], qdd[0]


#: A joint path ``q(s)``, ``s`` in [0, 1]: a spline of 1-DOF joints, or one on the sphere.
JointPath = PiecewisePolynomial | SpherePath


@dataclass(frozen=True)
class LineOptions:
    """Resolution and tolerances of a straight-line move.

    Attributes:
        max_step: Largest distance between IK samples along the line [m].
        max_rotation_step: Largest rotation between IK samples [rad].
        max_joint_step: Largest change of any joint between two samples [rad]/[m]; more
            means the IK jumped to another branch or passed a singularity.
        path_tolerance: Largest distance of the tool from the line between samples [m].
        solver: IK solver name.
        ik_iterations: Iteration budget per sample.
        tcp_speed: Largest linear speed of the goal's frame along the line [m/s] (``None``:
            only the joint limits bound it).
        tcp_angular_speed: Largest angular speed of the goal's frame [rad/s] (``None``: only
            the joint limits bound it).

    Raises:
        ValueError: A TCP speed that is not a positive finite number.
    """

    max_step: float = 0.005
    max_rotation_step: float = 0.05
    max_joint_step: float = 0.25
    path_tolerance: float = 0.001
    solver: str = "auto"
    ik_iterations: int = 100
    tcp_speed: float | None = None
    tcp_angular_speed: float | None = None

    def __post_init__(self) -> None:
        for name in ("tcp_speed", "tcp_angular_speed"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"LineOptions.{name} must be a positive finite number, got {v!r}")


def interpolate_goal(start: Array, goal: Goal, s: float) -> Goal:
    """The goal at fraction ``s`` of the straight line from the start pose ``(4, 4)`` to ``goal``.

    Each goal type defines its line (:meth:`armctl.ik.goals.Goal.interpolate`): a position moves
    on the line; a full orientation is SLERPed; a direction turns on the great circle from the
    start direction of the tool axis; the point a look-at goal looks at moves on the line from
    the point the axis points at first.

    Raises:
        PathError: For a goal type without a straight line (an orientation goal).
    """
    if goal.line_span(start) is None:
        raise PathError(0.0, _no_line(goal))
    return goal.interpolate(start, s)


def _no_line(goal: Goal) -> str:
    return f"a straight line is not defined for {goal.label} goals ({type(goal).__name__})"


def _at_limit(model: KinematicModel, q: Array) -> str:
    near = np.minimum(np.abs(q - model.lower), np.abs(model.upper - q)) < 1e-3
    names = [model.joint_names[i] for i in np.flatnonzero(near)]
    return f"; at the limit: {', '.join(names)}" if names else ""


def _solve_path(model: KinematicModel, q0: Array, start: Array, goal: Goal,
                n: int, options: LineOptions) -> Array:
    ik_opts = IKOptions(max_iterations=options.ik_iterations, restarts=0, time_limit=0.5)
    qs = [q0]
    for i in range(1, n + 1):
        s = i / n
        res = model.ik(interpolate_goal(start, goal, s), q0=qs[-1],  # type: ignore[attr-defined]
                       solver=options.solver, options=ik_opts)
        if not res.success:
            raise PathError((i - 1) / n, f"no IK solution near the line ({res.status.value}, "
                            f"position error {res.position_error * 1000:.1f} mm, rotation error "
                            f"{math.degrees(res.rotation_error):.1f} deg"
                            f"{_at_limit(model, np.asarray(res.q))})")
        q = np.asarray(res.q, dtype=float)
        if model.multi_dof_joints:
            q = _near_side(model, model.normalize(q), qs[-1])
            step = _joint_steps(model, qs[-1], q)
            if not model.within_limits(q):
                raise PathError((i - 1) / n, "the IK solution near the line leaves the joint "
                                f"limits{_outside(model, q)}")
        else:
            step = np.abs(q - qs[-1])
        j = int(np.argmax(step))
        if step[j] > options.max_joint_step:
            raise PathError((i - 1) / n, f"joint {model.joint_names[j]!r} would jump by "
                            f"{step[j]:.2f} between two samples (IK branch change or "
                            f"singularity)", model.joint_names[j])
        qs.append(q)
    return np.stack(qs)


def _near_side(model: KinematicModel, q: Array, ref: Array) -> Array:
    """``q`` with each ball joint's quaternion on the near side of ``ref``'s (the same pose)."""
    out = np.array(q)
    for i, jtype in enumerate(model.joint_types):
        if jtype is JointType.BALL:
            sl = model.q_index(i)
            if out[sl] @ ref[sl] < 0.0:
                out[sl] = -out[sl]
    return out


def _joint_steps(model: KinematicModel, a: Array, b: Array) -> Array:
    """Per joint, how far it moves from ``a`` to ``b`` [rad]/[m].

    The largest change of its coordinates in the tangent space: a ball joint's geodesic angle
    (the norm of its rotation vector), the larger of a universal joint's two angles.
    """
    d = model.difference(a, b)
    steps = np.empty(len(model.joint_names))
    for i, jtype in enumerate(model.joint_types):
        part = d[model.v_index(i)]
        steps[i] = (float(np.linalg.norm(part)) if jtype is JointType.BALL
                    else float(np.max(np.abs(part))))
    return steps


def _outside(model: KinematicModel, q: Array) -> str:
    """``": <the first joint limit q breaks>"``, or ``""``."""
    try:
        model.check_limits(q)
    except JointLimitError as exc:
        return f": {exc}"
    return ""


def _line_deviation(model: KinematicModel, path: JointPath, start: Array,
                    goal: Goal, frame: str | None, n: int) -> tuple[float, float]:
    """Largest distance [m] of the frame from the line, and where (fraction of the path)."""
    s = (np.arange(n) + 0.5) / n
    q, _, _ = path.sample_many(s)
    pts = model.fk_batch(q, frame)[:, :3, 3]
    p0 = start[:3, 3]
    target = goal.target_position
    if target is None:  # the frame's position is free: no line for it to keep to
        return 0.0, 0.0
    seg = np.asarray(target) - p0
    length = float(seg @ seg)
    u = np.clip(((pts - p0) @ seg) / length, 0.0, 1.0) if length > 0 else np.zeros(n)
    dist = np.linalg.norm(pts - (p0 + u[:, None] * seg), axis=1)
    k = int(np.argmax(dist))
    return float(dist[k]), float(s[k])


def plan_line(model: KinematicModel, q0: npt.ArrayLike, goal: Goal, limits: MotionLimits,
              speed: float = 1.0, options: LineOptions = LineOptions()) -> MotionPlan:
    """A straight-line tool move from the present joints ``q0`` to ``goal``, fully checked.

    Args:
        model: The arm (an :class:`armctl.arm.Arm`, which has ``ik``).
        q0: Present joint values ``(dof,)``.
        goal: Where the goal's frame must go (a goal type with a straight line: position,
            direction, pose or look-at).
        limits: The arm's hard limits.
        speed: Speed factor in (0, 1].
        options: Sampling resolution, tolerances and the frame's speed limits.

    Returns:
        The checked plan; ``extra`` has the peak linear [m/s] and angular [rad/s] speeds of the
        goal's frame (``tcp_speed_peak``, ``tcp_angular_speed_peak``).

    Raises:
        PathError: With the fraction of the path that could be planned and why it fails.
        LimitViolation: If the timed path would exceed a limit.
        InputError: For an arm with universal or ball joints given limits without its layout.
    """
    t0 = time.perf_counter()
    layout = limits.layout
    if model.multi_dof_joints and layout is None:
        raise InputError(f"arm {model.name!r} has universal or ball joints "
                         f"({', '.join(model.multi_dof_joints)}) but the motion limits are of "
                         "an arm of 1-DOF joints: take them from the arm "
                         "(MotionLimits.from_model)")
    scaled = limits.scaled(speed)
    q_start = np.asarray(q0, dtype=float)
    start = model.fk(q_start, goal.frame)
    span = goal.line_span(start)
    if span is None:
        raise PathError(0.0, _no_line(goal))
    dist, turn = span
    n = max(8, math.ceil(dist / options.max_step), math.ceil(turn / options.max_rotation_step))
    for _ in range(3):
        qs = _solve_path(model, q_start, start, goal, n, options)
        knots = np.linspace(0.0, 1.0, n + 1)
        path: JointPath
        if layout is not None:
            path = SpherePath(knots, qs, layout)
        else:
            ends = (qs[1] - qs[0]) * n, (qs[-1] - qs[-2]) * n
            path = spline_through(knots, qs, Interpolation.MIN_JERK, ends[0], ends[1])
        dev, where = _line_deviation(model, path, start, goal, goal.frame, 4 * n)
        if dev <= options.path_tolerance:
            break
        n *= 2
    else:
        raise PathError(where, f"the tool would leave the line by {dev * 1000:.1f} mm between "
                        "IK samples (the path bends sharply near a singularity)")
    rates = _frame_rates(model, path, goal.frame, 40 * n)
    traj: Trajectory
    if isinstance(path, SpherePath):
        assert layout is not None
        timing = _sphere_timing(path, scaled, layout, _tcp_time(rates, options))
        traj = SpherePathTrajectory(path, timing)
        # a ball joint's angular acceleration steps at the samples (the C1 spline on the
        # sphere): its jerk is not bounded, the scalar coordinates' is
        checked = check_trajectory(traj, limits, check_jerk=True, hint="lower the speed factor",
                                   ball_jerk=False)
    else:
        timing = _timing(path, scaled, _tcp_time(rates, options))
        traj = PathTrajectory(path, timing)
        checked = check_trajectory(traj, limits, check_jerk=True, hint="lower the speed factor")
    wps = (Waypoint(0.0, q_start, "start"), Waypoint(traj.duration, qs[-1], "goal"))
    peak = _PEAK_SDOT / traj.duration  # largest ds/dt of the minimum-jerk timing
    return MotionPlan(traj, limits, (), wps, time.perf_counter() - t0, checked,
                      f"straight line, {dist * 1000:.0f} mm, {n} IK samples",
                      {"samples": n, "line_deviation": dev,
                       "tcp_speed_peak": rates[0] * peak,
                       "tcp_angular_speed_peak": rates[1] * peak})


#: Peak of ds/dt of a minimum-jerk ``s(t)`` from 0 to 1 over a unit time: 15/8 at t = 1/2.
_PEAK_SDOT = 15.0 / 8.0


def _frame_rates(model: KinematicModel, path: JointPath, frame: str | None,
                 n: int) -> tuple[float, float]:
    """Largest ``|dp/ds|`` [m] and ``|dtheta/ds|`` [rad] of a frame along a path ``q(s)``.

    By finite differences of the frame's pose (FK) at ``n + 1`` points of ``s`` in [0, 1]: the
    translation between neighbours, and the angle of the relative rotation.
    """
    s = np.linspace(0.0, 1.0, n + 1)
    q, _, _ = path.sample_many(s)
    poses = model.fk_batch(q, frame)
    dp = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
    rel = np.einsum("nji,njk->nik", poses[:-1, :3, :3], poses[1:, :3, :3])  # R_a^T R_b
    cos = np.clip((np.trace(rel, axis1=1, axis2=2) - 1.0) / 2.0, -1.0, 1.0)
    ds = 1.0 / n
    return float(np.max(dp, initial=0.0)) / ds, float(np.max(np.arccos(cos), initial=0.0)) / ds


def _tcp_time(rates: tuple[float, float], options: LineOptions) -> float:
    """The shortest duration [s] of a minimum-jerk ``s(t)`` that keeps the frame's speeds.

    With ``s(t)`` minimum-jerk over ``T``, the peak ``ds/dt`` is ``15 / (8 T)``, so a peak
    speed ``rate * 15 / (8 T) <= limit`` needs ``T >= 15 rate / (8 limit)``.
    """
    t = 0.0
    for rate, limit in zip(rates, (options.tcp_speed, options.tcp_angular_speed), strict=True):
        if limit is not None:
            t = max(t, _PEAK_SDOT * rate / limit)
    return t


def _timing(path: PiecewisePolynomial, limits: MotionLimits, at_least: float = 0.0
            ) -> PiecewisePolynomial:
    """A minimum-jerk ``s(t)`` from 0 to 1, as short as the limits allow, and ``at_least`` [s].

    Velocity, acceleration and jerk count; the jerk is estimated by differences of the sampled
    acceleration.
    """
    one = np.ones(1)
    zero = np.zeros(1)
    unit = PiecewisePolynomial([0.0, 1.0], quintic_segment(zero, zero, zero, one, zero, zero,
                                                           1.0)[None])
    nsamp = max(1000, 40 * (path.breakpoints().size - 1))
    ts = np.linspace(0.0, 1.0, nsamp)
    _, qd, qdd = PathTrajectory(path, unit).sample_many(ts)
    jerk = np.diff(qdd, axis=0) / (ts[1] - ts[0])
    ratio = max(float(np.max(np.abs(qd) / limits.velocity)),
                math.sqrt(float(np.max(np.abs(qdd) / limits.acceleration))),
                float(np.cbrt(np.max(np.abs(jerk) / limits.jerk))), 1e-3)
    t_total = max(ratio * 1.02, at_least)
    c = quintic_segment(zero, zero, zero, one, zero, zero, t_total)
    return PiecewisePolynomial([0.0, t_total], c[None])


def _unit_timing() -> PiecewisePolynomial:
    """A minimum-jerk ``s(t)`` from 0 to 1 over one second."""
    one, zero = np.ones(1), np.zeros(1)
    return PiecewisePolynomial([0.0, 1.0], quintic_segment(zero, zero, zero, one, zero, zero,
                                                           1.0)[None])


def _sphere_timing(path: SpherePath, limits: MotionLimits, layout: JointLayout,
                   at_least: float = 0.0) -> PiecewisePolynomial:
    """:func:`_timing` for a path on the sphere: the limits bound the rates.

    A ball joint's rates are the norms of its angular velocity and acceleration; the jerk is
    estimated (by differences of the sampled acceleration) for the scalar coordinates only.
    """
    nsamp = max(1000, 40 * (path.breakpoints().size - 1))
    ts = np.linspace(0.0, 1.0, nsamp)
    _, qd, qdd = SpherePathTrajectory(path, _unit_timing()).sample_many(ts)
    vel, acc, jerk_lim = limits.rate_limits()
    ns = layout.scalar_v.size
    jerk = np.diff(qdd[:, layout.scalar_v], axis=0) / (ts[1] - ts[0])
    ratio = max(float(np.max(np.abs(layout.rates(qd)) / vel)),
                math.sqrt(float(np.max(np.abs(layout.rates(qdd)) / acc))),
                float(np.cbrt(np.max(np.abs(jerk) / jerk_lim[:ns], initial=0.0))), 1e-3)
    t_total = max(ratio * 1.02, at_least)
    zero, one = np.zeros(1), np.ones(1)
    c = quintic_segment(zero, zero, zero, one, zero, zero, t_total)
    return PiecewisePolynomial([0.0, t_total], c[None])


class SpherePathTrajectory(Trajectory):
    """A joint path on the sphere (:class:`SpherePath`, ``s`` in [0, 1]) timed by ``s(t)``.

    The velocity is ``q'(s) s'`` and the acceleration ``q''(s) s'^2 + q'(s) s''`` (for a ball
    joint its body angular velocity and acceleration along ``s``, scaled the same way).

    Args:
        path: ``q(s)``, a run whose knot times are the path parameter ``s`` from 0 to 1.
        timing: ``s(t)`` as a one-joint piecewise polynomial from 0 to 1.
    """

    def __init__(self, path: SpherePath, timing: PiecewisePolynomial):
        self.path = path
        self.timing = timing
        self.dof = path.dof

    @property
    def nq(self) -> int:  # noqa: D102
        return self.path.nq

    @property
    def duration(self) -> float:  # noqa: D102
        return self.timing.duration

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:  # noqa: D102
        s, sd, sdd = self.timing.sample_many(ts)
        q, dq, ddq = self.path.sample_many(np.clip(s[:, 0], 0.0, 1.0))
        return q, dq * sd, ddq * sd**2 + dq * sdd

    def sample(self, t: float) -> Sampled:  # noqa: D102
        q, qd, qdd = self.sample_many([t])
        return q[0], qd[0], qdd[0]
