"""Joint limits for motion, the speed factor, and the check of a whole trajectory before motion."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.config.schema import JointType
from armctl.errors import InputError
from armctl.kinematics.model import KinematicModel
from armctl.motion.errors import LimitViolation
from armctl.motion.layout import GeodesicMove, JointLayout
from armctl.motion.trajectory import Chain, RuckigTrajectory, TimeScaled, Trajectory
from armctl.typing import Array

__all__ = [
    "DEFAULT_ACCELERATION",
    "DEFAULT_VELOCITY",
    "MAX_RECORDED_SPEED",
    "MIN_SPEED",
    "MotionLimits",
    "check_speed",
    "check_trajectory",
]


#: Velocity used for a joint whose YAML gives none: [rad/s] for rotary, [m/s] for prismatic.
DEFAULT_VELOCITY = {"rotary": 1.0, "prismatic": 0.05}
#: Acceleration used for a joint whose YAML gives none: [rad/s^2] / [m/s^2].
DEFAULT_ACCELERATION = {"rotary": 3.0, "prismatic": 0.15}

#: Relative slack allowed by the check, for rounding in the planners [-].
_REL_TOL = 1e-6
_POS_TOL = 1e-9
_POSITION_HINT = ("The path swings outside the joint's range: add a keyframe there, stop at "
                  "keyframes, or use linear interpolation")


#: Slowest speed factor [-]: slower moves take over 100 times as long as at the limits (and
#: break the trajectory generator).
MIN_SPEED = 0.01
#: Fastest speed factor of a recording played by its time stamps [-].
MAX_RECORDED_SPEED = 4.0


def check_speed(speed: float, upper: float = 1.0, what: str = "speed factor") -> float:
    """A speed factor, checked: a finite number from :data:`MIN_SPEED` to ``upper``.

    The one check of every speed factor (command line, Python API, keyframe playback), so a
    bad factor is refused before anything is planned or a bus is opened.

    Args:
        speed: The factor [-]; 1 plans at the joint limits.
        upper: The largest factor allowed: 1 for moves timed by the joint limits,
            :data:`MAX_RECORDED_SPEED` for recordings played by their time stamps.
        what: What the factor is, for the message.

    Returns:
        ``speed`` as a float.

    Raises:
        InputError: For NaN, inf, zero, a negative factor, or one outside the range; the
            message gives the valid range.
    """
    try:
        value = float(speed)
    except (TypeError, ValueError):
        raise InputError(f"{what} {speed!r} is not a number; use {MIN_SPEED:g} to "
                         f"{upper:g}") from None
    valid = f"the valid range is {MIN_SPEED:g} to {upper:g}"
    if not math.isfinite(value):
        raise InputError(f"{what} {value} is not a finite number; {valid}")
    if value <= 0.0:
        raise InputError(f"{what} {value:g} must be positive; {valid} (1 = at the limits)")
    if value < MIN_SPEED:
        raise InputError(f"{what} {value:g} is too slow: {valid} ({value:g} makes every move "
                         f"{1.0 / value:.0f} times as long as at the limits: a move of 1 s "
                         f"would take {_duration_text(1.0 / value)})")
    if value > upper:
        above = ("; factors above 1 would exceed the joint limits" if upper == 1.0 else "")
        raise InputError(f"{what} {value:g} is too fast: {valid}{above}; use {upper:g} or "
                         "lower")
    return value


def _duration_text(seconds: float) -> str:
    """A duration [s] for messages: seconds, minutes, hours or days."""
    for unit, size in (("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


@dataclass(frozen=True)
class MotionLimits:
    """Per-joint limits used to plan and check motion, all ``(dof,)`` in SI units.

    For an arm with universal or ball joints (``layout`` set) ``lower`` and ``upper`` have one
    entry per entry of ``q`` (``nq``; a ball joint's are infinite, its swing and twist limits are
    in the layout) and the rest one per velocity entry (``nv == dof``; a ball joint's three
    are the same and bound the norm of its angular velocity, acceleration and jerk).

    Attributes:
        names: Joint names (per velocity entry).
        lower: Lowest position [rad]/[m] (``-inf`` for continuous joints).
        upper: Highest position.
        velocity: Highest speed [rad/s]/[m/s].
        acceleration: Highest acceleration [rad/s^2]/[m/s^2].
        jerk: Highest jerk [rad/s^3]/[m/s^3]; ``inf`` where not configured.
        units: Each joint's unit, ``"rad"`` or ``"m"``, for messages; empty when unknown.
        layout: Where universal and ball joints sit in ``q`` and the velocity (``None``: an
            arm of 1-DOF joints, where ``q`` and the velocity have the same entries).
    """

    names: tuple[str, ...]
    lower: Array
    upper: Array
    velocity: Array
    acceleration: Array
    jerk: Array
    units: tuple[str, ...] = ()
    layout: JointLayout | None = None

    def unit(self, i: int) -> str:
        """The unit of joint ``i`` (``"rad"``, ``"m"``; empty when unknown)."""
        return self.units[i] if self.units else ""

    @property
    def dof(self) -> int:
        """Number of joints."""
        return len(self.names)

    @classmethod
    def from_model(cls, model: KinematicModel) -> MotionLimits:
        """The limits of an arm; joints without velocity/acceleration limits get defaults.

        Defaults are :data:`DEFAULT_VELOCITY` and :data:`DEFAULT_ACCELERATION`; a joint without a
        jerk limit is planned with unbounded jerk. A universal joint's angles and a ball joint
        take the rotary defaults (a ball joint's bound the norm of its angular velocity and
        acceleration).
        """
        layout = JointLayout.of(model)
        if layout is not None:
            return cls._of_layout(model, layout)
        prismatic = np.array([t is JointType.PRISMATIC for t in model.joint_types])
        v, a, j = _rate_limits(model, prismatic)
        return cls(tuple(model.joint_names), np.array(model.lower, dtype=float),
                   np.array(model.upper, dtype=float), v, a, j,
                   tuple("m" if p else "rad" for p in prismatic))

    @classmethod
    def _of_layout(cls, model: KinematicModel, layout: JointLayout) -> MotionLimits:
        v_units = ["rad"] * layout.nv
        names = [""] * layout.nv
        for i, name in enumerate(model.joint_names):
            sl = model.v_index(i)
            for k in range(sl.start, sl.stop):
                names[k] = name
                if model.joint_types[i] is JointType.PRISMATIC:
                    v_units[k] = "m"
        prismatic = np.array([u == "m" for u in v_units])
        v, a, j = _rate_limits(model, prismatic)
        return cls(tuple(names), np.array(model.lower, dtype=float),
                   np.array(model.upper, dtype=float), v, a, j, tuple(v_units), layout)

    def scaled(self, speed: float) -> MotionLimits:
        """Limits for a speed factor: velocity x s, acceleration x s^2, jerk x s^3.

        Scaling this way slows every planned motion down uniformly in time by ``1 / speed``.

        Args:
            speed: The factor, :data:`MIN_SPEED` to 1 (see :func:`check_speed`).

        Raises:
            InputError: If ``speed`` is not a number from :data:`MIN_SPEED` to 1.
        """
        speed = check_speed(speed)
        return MotionLimits(self.names, self.lower, self.upper, self.velocity * speed,
                            self.acceleration * speed**2, self.jerk * speed**3, self.units,
                            self.layout)

    def subset(self, index: npt.ArrayLike) -> MotionLimits:
        """The limits of some joints only (an arm of 1-DOF joints).

        Raises:
            InputError: For the limits of an arm with universal or ball joints.
        """
        if self.layout is not None:
            raise InputError("a subset of the joint limits is taken for arms of 1-DOF joints "
                             "only")
        idx = np.asarray(index, dtype=int)
        return MotionLimits(tuple(self.names[i] for i in idx), self.lower[idx], self.upper[idx],
                            self.velocity[idx], self.acceleration[idx], self.jerk[idx],
                            tuple(self.units[i] for i in idx) if self.units else ())

    def check_position(self, q: npt.ArrayLike, context: str) -> None:
        """Raise :class:`LimitViolation` if ``q`` lies outside the position limits.

        A ball joint is checked against its swing and twist limits (``kind`` ``"swing"`` or
        ``"twist"``).
        """
        arr = np.asarray(q, dtype=float)
        bad = np.flatnonzero((arr < self.lower - _POS_TOL) | (arr > self.upper + _POS_TOL))
        hint = f"({context}) choose a target inside the joint limits"
        if bad.size:
            i = int(bad[0])
            bound = self.lower[i] if arr[i] < self.lower[i] else self.upper[i]
            name, unit = ((self.layout.q_names[i], self.layout.q_units[i]) if self.layout
                          else (self.names[i], self.unit(i)))
            raise LimitViolation(name, "position", float(arr[i]), float(bound), 0.0, hint, unit)
        if self.layout is not None:
            _ball_violation(self.layout, arr[None, :], np.zeros(1), hint)

    def rates(self, values: npt.ArrayLike) -> Array:
        """Velocities (accelerations, jerks) ``(..., dof)`` as the quantities the limits bound.

        Unchanged for an arm of 1-DOF joints; with ball joints one entry per scalar coordinate
        and one per ball joint (the norm of its three), in the order of :meth:`rate_limits`.
        """
        if self.layout is None:
            return np.asarray(values, dtype=float)
        return self.layout.rates(values)

    def rate_limits(self) -> tuple[Array, Array, Array]:
        """Velocity, acceleration and jerk limits of the entries of :meth:`rates`."""
        if self.layout is None:
            return self.velocity, self.acceleration, self.jerk
        lay = self.layout
        return (lay.rate_limits(self.velocity), lay.rate_limits(self.acceleration),
                lay.rate_limits(self.jerk))


def _ruckig_parts(traj: Trajectory, offset: float = 0.0, factor: float = 1.0
                  ) -> list[tuple[float, float, RuckigTrajectory | GeodesicMove]]:
    if isinstance(traj, (RuckigTrajectory, GeodesicMove)):
        return [(offset, factor, traj)]
    if isinstance(traj, TimeScaled):
        return _ruckig_parts(traj.inner, offset, factor * traj.factor)
    if isinstance(traj, Chain):
        out = []
        for part, start in zip(traj.parts, traj.offsets, strict=False):
            out += _ruckig_parts(part, offset + float(start) * factor, factor)
        return out
    return []


def check_trajectory(traj: Trajectory, limits: MotionLimits, dt: float = 0.002,
                     check_jerk: bool = False, hint: str = "", ball_jerk: bool = True) -> int:
    """Check every sample of a trajectory against the limits before anything moves.

    The trajectory is sampled every ``dt`` and at every breakpoint; Ruckig pieces are also
    checked with their exact position extrema (the free Ruckig ignores position limits).

    Args:
        traj: The trajectory.
        limits: The hard limits (not the speed-scaled ones).
        dt: Sampling step [s].
        check_jerk: Also check jerk, by finite differences of the acceleration samples.
        hint: Appended to the error message, e.g. how to make the motion feasible.
        ball_jerk: With ``check_jerk``, check ball joints' jerk too (their spline runs are
            C1 on the sphere: the angular acceleration steps at keyframes, as a cubic
            spline's acceleration does at the ends of a run).

    Returns:
        The number of samples checked.

    Raises:
        LimitViolation: For the first sample beyond a limit, naming the joint, the limit and the
            time.
    """
    n = max(2, math.ceil(traj.duration / dt) + 1)
    ts = np.unique(np.concatenate([np.linspace(0.0, traj.duration, n), traj.breakpoints()]))
    q, qd, qdd = traj.sample_many(ts)
    if limits.layout is not None:
        return _check_layout(traj, limits, limits.layout, ts, q, qd, qdd, check_jerk, hint,
                             ball_jerk)
    _first_violation(ts, q, limits.lower, limits.upper, limits, "position", _POSITION_HINT)
    vmax = limits.velocity * (1 + _REL_TOL) + 1e-12
    _first_violation(ts, qd, -vmax, vmax, limits, "velocity", hint)
    amax = limits.acceleration * (1 + _REL_TOL) + 1e-12
    _first_violation(ts, qdd, -amax, amax, limits, "acceleration", hint)
    if check_jerk and np.any(np.isfinite(limits.jerk)) and ts.size > 2:
        # Mid-point finite differences of the acceleration; breakpoints (where jerk may jump)
        # are separate samples, so a jump does not smear across them.
        dts = np.diff(ts)
        keep = dts > 1e-6
        jerk = np.diff(qdd, axis=0)[keep] / dts[keep, None]
        tj = (ts[:-1] + ts[1:])[keep] / 2
        jmax = limits.jerk * 1.02 + 1e-9
        _first_violation(tj, jerk, -jmax, jmax, limits, "jerk", hint)
    for start, _factor, part in _ruckig_parts(traj):
        lo, hi = part.position_extrema()
        bad_lo = np.flatnonzero(lo < limits.lower - _POS_TOL)
        bad_hi = np.flatnonzero(hi > limits.upper + _POS_TOL)
        for bad, vals, bounds in ((bad_lo, lo, limits.lower), (bad_hi, hi, limits.upper)):
            if bad.size:
                i = int(bad[0])
                raise LimitViolation(limits.names[i], "position", float(vals[i]),
                                     float(bounds[i]), start, _POSITION_HINT, limits.unit(i))
    return int(ts.size)


def _first_violation(ts: Array, values: Array, lo: Array, hi: Array, limits: MotionLimits,
                     kind: str, hint: str, names: tuple[str, ...] = (),
                     units: tuple[str, ...] = ()) -> None:
    tol = _POS_TOL if kind == "position" else 0.0
    bad = (values < lo - tol) | (values > hi + tol)
    if not bad.any():
        return
    k, i = np.argwhere(bad)[0]
    v = float(values[k, i])
    bound = float(lo[i] if v < lo[i] else hi[i])
    name = names[int(i)] if names else limits.names[int(i)]
    unit = units[int(i)] if units else limits.unit(int(i))
    raise LimitViolation(name, kind, v, bound if kind == "position" else abs(bound),
                         float(ts[k]), hint, unit)


_BALL_HINT = ("The path turns the ball joint outside its {what} range: add a keyframe there, "
              "or choose keyframes whose arc between them stays inside")


def _ball_violation(layout: JointLayout, q: Array, ts: Array, hint: str = "") -> None:
    """Raise :class:`LimitViolation` for the first sample of ``q`` outside a ball's limits."""
    found = layout.ball_violation(q)
    if found is None:
        return
    k, ball, what, value, lo, hi = found
    bound = hi if value > hi else lo
    raise LimitViolation(ball.name, what, value, bound, float(ts[k]),
                         hint or _BALL_HINT.format(what=what), "rad")


def _check_layout(traj: Trajectory, limits: MotionLimits, layout: JointLayout, ts: Array,
                  q: Array, qd: Array, qdd: Array, check_jerk: bool, hint: str,
                  ball_jerk: bool) -> int:
    """:func:`check_trajectory` for an arm with universal or ball joints.

    Scalar coordinates are checked entry by entry; a ball joint's quaternion against its swing
    and twist limits and the norms of its angular velocity, acceleration and jerk against its
    limits.
    """
    for b in layout.balls:
        norm = np.linalg.norm(q[:, b.q], axis=1)
        off = np.flatnonzero(np.abs(norm - 1.0) > 1e-6)
        if off.size:
            raise LimitViolation(b.name, "quaternion norm", float(norm[off[0]]), 1.0,
                                 float(ts[off[0]]), "a ball joint's value is a unit quaternion")
    _first_violation(ts, q, limits.lower, limits.upper, limits, "position", _POSITION_HINT,
                     layout.q_names, layout.q_units)
    _ball_violation(layout, q, ts)
    vel, acc, jerk_lim = limits.rate_limits()
    names, units = layout.rate_names, layout.rate_units
    rv, ra = layout.rates(qd), layout.rates(qdd)
    vmax = vel * (1 + _REL_TOL) + 1e-12
    _first_violation(ts, rv, -vmax, vmax, limits, "velocity", hint, names, units)
    amax = acc * (1 + _REL_TOL) + 1e-12
    _first_violation(ts, ra, -amax, amax, limits, "acceleration", hint, names, units)
    if check_jerk and np.any(np.isfinite(jerk_lim)) and ts.size > 2:
        dts = np.diff(ts)
        keep = dts > 1e-6
        jerk = layout.rates(np.diff(qdd, axis=0)[keep] / dts[keep, None])
        tj = (ts[:-1] + ts[1:])[keep] / 2
        jmax = jerk_lim * 1.02 + 1e-9
        if not ball_jerk:
            jmax = np.concatenate([jmax[:layout.scalar_v.size],
                                   np.full(len(layout.balls), np.inf)])
        _first_violation(tj, jerk, -jmax, jmax, limits, "jerk", hint, names, units)
    for start, _factor, part in _ruckig_parts(traj):
        lo, hi = part.position_extrema()
        for i in layout.scalar_q:
            for val, bound, out in ((lo[i], limits.lower[i], lo[i] < limits.lower[i] - _POS_TOL),
                                    (hi[i], limits.upper[i], hi[i] > limits.upper[i] + _POS_TOL)):
                if out:
                    raise LimitViolation(layout.q_names[i], "position", float(val),
                                         float(bound), start, _POSITION_HINT,
                                         layout.q_units[i])
    return int(ts.size)


def _rate_limits(model: KinematicModel, prismatic: Array) -> tuple[Array, Array, Array]:
    """Velocity, acceleration and jerk limits per velocity entry, defaults where none is given.

    Args:
        model: The arm.
        prismatic: Which velocity entries belong to prismatic joints.
    """
    vdef = np.where(prismatic, DEFAULT_VELOCITY["prismatic"], DEFAULT_VELOCITY["rotary"])
    adef = np.where(prismatic, DEFAULT_ACCELERATION["prismatic"], DEFAULT_ACCELERATION["rotary"])
    v = np.where(np.isfinite(model.velocity_limits), model.velocity_limits, vdef)
    a = np.where(np.isfinite(model.acceleration_limits), model.acceleration_limits, adef)
    j = np.where(np.isfinite(model.jerk_limits), model.jerk_limits, np.inf)
    return v, a, j
