"""Plan the playback of a keyframe program: order, loops, ease-in, dwell, gripper events.

The program is turned into a list of stops (the first and last keyframe, every keyframe with a
dwell or a gripper change, and every keyframe when blending is off). Between two stops the
keyframes are joined by the chosen interpolation without stopping; at a stop the arm rests for
the dwell, and a gripper change is a separate gripper-only move while the arm holds still.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.config.schema import JointRole, JointType
from armctl.errors import ConfigError, InputError, KeyPath, NoSolutionError
from armctl.kinematics.model import KinematicModel
from armctl.motion.errors import LimitViolation
from armctl.motion.interpolate import Interpolation, plan_run
from armctl.motion.keyframes import AngleUnit, Keyframe, KeyframeProgram, LengthUnit
from armctl.motion.layout import JointLayout
from armctl.motion.limits import (
    MAX_RECORDED_SPEED,
    MIN_SPEED,
    MotionLimits,
    check_speed,
    check_trajectory,
)
from armctl.motion.multi_dof import geodesic_move, plan_layout_run
from armctl.motion.plan import Event, MotionPlan, Waypoint
from armctl.motion.profiles import ruckig_move
from armctl.motion.trajectory import Chain, Hold, Trajectory
from armctl.typing import Array

__all__ = ["IKFunction", "PlaybackOptions", "check_keyframe_values", "check_playback_speed",
           "plan_program", "resolve_keyframes"]


#: Solves a tool pose ``(4, 4)`` for joint values, seeded with ``(dof,)``; the flag says whether
#: the orientation counts (else only the position). Raises :class:`NoSolutionError` when the pose
#: cannot be reached.
IKFunction = Callable[[Array, Array, bool], Array]

_SAME = 1e-9
#: Slack of the keyframe limit check [rad]/[m].
_LIMIT_TOL = 1e-9


@dataclass(frozen=True)
class PlaybackOptions:
    """How to play a keyframe program.

    Attributes:
        interpolation: How keyframes are joined.
        blend: Pass through keyframes without stopping (stops remain at dwells, gripper
            changes and the ends).
        speed: Speed factor: 0.01-4 for recordings played by their time stamps, where it
            scales the recorded time; 0.01-1 otherwise, where it scales the joint limits
            (see :func:`check_playback_speed`).
        loops: How many times to play the program (>= 1).
        reverse: Play the keyframes in reverse order.
        ease_in: Start with a slow move from the present pose to the first keyframe.
        ease_in_speed: Speed factor of that move, 0.01-1 (never faster than ``speed`` for
            a program timed by the limits).
        use_times: Follow the recorded time stamps when every keyframe has one.
    """

    interpolation: Interpolation = Interpolation.MIN_JERK
    blend: bool = True
    speed: float = 1.0
    loops: int = 1
    reverse: bool = False
    ease_in: bool = True
    ease_in_speed: float = 0.3
    use_times: bool = True

    def __post_init__(self) -> None:
        check_speed(self.speed, MAX_RECORDED_SPEED)
        if self.loops < 1:
            raise InputError(f"loop count must be at least 1, got {self.loops}")
        check_speed(self.ease_in_speed, 1.0, "ease-in speed factor")

    def timed(self, program: KeyframeProgram) -> bool:
        """Whether ``program`` plays by its time stamps (else it is timed by the joint limits)."""
        return self.use_times and program.timed and not self.reverse


def check_playback_speed(program: KeyframeProgram, options: PlaybackOptions,
                         speed: float | None = None) -> None:
    """Refuse a speed factor that does not apply to how ``program`` is timed.

    A recording played by its time stamps takes :data:`MIN_SPEED` to
    :data:`MAX_RECORDED_SPEED`; every other program is timed by the joint limits and takes
    :data:`MIN_SPEED` to 1. The message gives the range that applies to this program.

    Args:
        program: The program.
        options: How it is played.
        speed: The factor to check [-]; ``None``: ``options.speed`` (a factor can be checked
            before options are built with it, which accept up to :data:`MAX_RECORDED_SPEED`).

    Raises:
        InputError: For a factor outside the range that applies (above 1 on a program timed
            by the limits says why).
    """
    value = options.speed if speed is None else speed
    if options.timed(program):
        check_speed(value, MAX_RECORDED_SPEED)
        return
    try:
        above = float(value) > 1.0
    except (TypeError, ValueError):
        above = False
    if not above:
        check_speed(value, 1.0)
        return
    if not program.timed:
        why = "its keyframes have no time stamps"
    elif options.reverse:
        why = "a recording played in reverse is timed by the joint limits"
    else:
        why = "the time stamps are ignored"
    raise InputError(
        f"speed factor {value:g} is above 1, which applies only to recordings played "
        f"by their time stamps; this program is timed by the joint limits ({why}), where the "
        f"factor is {MIN_SPEED:g} to 1 (1 = at the limits): try --speed 1 or lower")


@dataclass(frozen=True)
class _Stop:
    q: Array
    name: str
    dwell: float
    gripper: float | None
    time: float | None
    stop: bool
    interpolation: Interpolation | None = None  # of the segment arriving here


def _q_entries(model: KinematicModel, joints: tuple[str, ...]) -> list[int]:
    """The entries of ``q`` of some joints, in their order (a ball joint's four, ...)."""
    if not model.multi_dof_joints:
        return [model.joint_index(j) for j in joints]
    out: list[int] = []
    for j in joints:
        sl = model.q_index(j)
        out += range(sl.start, sl.stop)
    return out


def _program_entries(program: KeyframeProgram, model: KinematicModel) -> list[int]:
    """The entries of ``q`` that a program's joint keyframes give, checked against its widths.

    Raises:
        InputError: If the program's values per keyframe do not fit its joints on this arm.
    """
    idx = _q_entries(model, program.joints)
    if len(idx) != (sum(program.widths) if program.widths else len(program.joints)):
        raise InputError(f"the program's joints {', '.join(program.joints)} take {len(idx)} "
                         f"values on arm {model.name!r} (a ball joint 4, a universal joint 2); "
                         "give the program their widths, as load_keyframes does")
    return idx


def _gripper_entries(model: KinematicModel) -> list[int]:
    """The entries of ``q`` of the gripper joints (1-DOF joints)."""
    return [model.q_index(i).start if model.multi_dof_joints else i
            for i, r in enumerate(model.joint_roles) if r is JointRole.GRIPPER]


def _move(q0: Array, q1: Array, limits: MotionLimits) -> Trajectory:
    """A rest-to-rest joint move: ball joints on the great circle (arms that have them)."""
    if limits.layout is not None:
        return geodesic_move(q0, q1, limits)
    return ruckig_move(q0, q1, limits)


def resolve_keyframes(program: KeyframeProgram, model: KinematicModel, q_start: npt.ArrayLike,
                      ik: IKFunction | None = None) -> list[Array]:
    """Full joint vectors ``(nq,)`` for every keyframe, in program order.

    Joints the program does not list keep their value from ``q_start`` (gripper joints follow
    the keyframes' ``gripper`` values: the value a keyframe arrives with is the one in force
    before it). Cartesian keyframes are solved by ``ik`` seeded with the previous keyframe.
    A ball joint's quaternion is returned with unit norm and ``w >= 0``.

    Raises:
        InputError: For a Cartesian keyframe without an IK function.
        NoSolutionError: If a Cartesian keyframe cannot be reached (names the keyframe).
    """
    q = np.array(q_start, dtype=float)
    idx = _program_entries(program, model)
    grip = _gripper_entries(model)
    out = []
    for k, kf in enumerate(program.keyframes):
        cur = q.copy()
        if kf.q is not None:
            cur[idx] = kf.q
        else:
            if ik is None:
                raise InputError(f"keyframe {k} ({kf.label}) is a pose and needs IK")
            try:
                sol = np.asarray(ik(np.asarray(kf.pose), q, kf.orientation), dtype=float)
            except NoSolutionError as exc:
                raise NoSolutionError(f"keyframe {k} ({kf.label}, {kf.where.where()}): the pose "
                                      f"cannot be reached: {exc}") from exc
            keep = cur[grip].copy()
            cur = sol.copy()
            cur[grip] = keep
        if model.multi_dof_joints:
            cur = model.normalize(cur)
        out.append(cur)
        q = cur
        if kf.gripper is not None:
            if not grip:
                raise InputError(f"keyframe {k} ({kf.label}) sets a gripper value but arm "
                                 f"{model.name!r} has no gripper joint")
            q = q.copy()
            q[grip] = kf.gripper
    return out


def plan_program(program: KeyframeProgram, model: KinematicModel, limits: MotionLimits,
                 q_start: npt.ArrayLike, options: PlaybackOptions | None = None,
                 ik: IKFunction | None = None) -> MotionPlan:
    """Plan a keyframe program from the present pose, checked against the limits.

    Args:
        program: The keyframes.
        model: The arm.
        limits: The arm's hard limits.
        q_start: The present joint values.
        options: Playback options.
        ik: Solver for Cartesian keyframes.

    Returns:
        The checked plan; its waypoints are the keyframes with the time the arm passes them.

    Raises:
        LimitViolation: If any sample would exceed a limit (with the fastest feasible speed
            factor for recorded programs).
        PlanningError: If the program cannot be planned.
    """
    t0 = time.perf_counter()
    options = options or PlaybackOptions()
    if not program.keyframes:
        raise InputError("the keyframe program has no keyframes")
    check_playback_speed(program, options)
    start = np.asarray(q_start, dtype=float)
    if model.multi_dof_joints:
        start = model.normalize(start)
    qs = resolve_keyframes(program, model, start, ik)
    for k, (q, kf) in enumerate(zip(qs, program.keyframes, strict=True)):
        _check_keyframe(program, model, k, kf, q)
    grip = _gripper_entries(model)
    stops = [_Stop(q, kf.label if kf.name else f"#{k}", kf.dwell, kf.gripper, kf.time,
                   not options.blend or kf.dwell > 0 or kf.gripper is not None,
                   kf.interpolation)
             for k, (q, kf) in enumerate(zip(qs, program.keyframes, strict=False))]
    if options.reverse:
        stops = stops[::-1]
    seq = stops * options.loops
    if options.loops > 1:  # stop where each pass ends, before returning to the first keyframe
        ends = range(len(stops) - 1, len(seq) - 1, len(stops))
        for i in [*ends, *(e + 1 for e in ends)]:
            seq[i] = _Stop(seq[i].q, seq[i].name, seq[i].dwell, seq[i].gripper, seq[i].time,
                           True, seq[i].interpolation)
    timed = options.timed(program)
    for st in seq:
        limits.check_position(st.q, f"keyframe {st.name}")
    scaled = limits.scaled(min(options.speed, 1.0)) if not timed else limits
    parts: list[Trajectory] = []
    events: list[Event] = []
    waypoints: list[Waypoint] = []
    clock = 0.0
    cur = start
    if options.ease_in:
        ease_speed = options.ease_in_speed if timed else min(options.ease_in_speed,
                                                              options.speed)
        ease = _move(start, seq[0].q, limits.scaled(ease_speed))
        parts.append(ease)
        clock += ease.duration
        cur = seq[0].q
    elif (np.max(np.abs(model.difference(start, seq[0].q))) if model.multi_dof_joints
          else np.max(np.abs(seq[0].q - start))) > 1e-3:
        raise InputError("the arm is not at the first keyframe; enable ease-in to move there")
    first = seq[0]
    waypoints.append(Waypoint(clock, first.q, first.name, True))
    stop_limits = limits.scaled(min(options.speed, 1.0))
    clock, cur = _emit_stop(first, cur, grip, stop_limits, parts, events, clock)
    run: list[_Stop] = [_Stop(cur, first.name, 0.0, None, first.time, True)]
    for st in seq[1:]:
        if timed or np.max(np.abs(st.q - run[-1].q)) >= _SAME:
            run.append(st)  # a recording standing still keeps its timing
        elif not st.stop:
            continue  # the same position again, passing through: nothing to do
        if st.stop:
            if len(run) > 1:
                clock, cur = _emit_run(run, scaled, options, timed, parts, waypoints, clock)
            else:
                waypoints.append(Waypoint(clock, cur, st.name, True))
            clock, cur = _emit_stop(st, cur, grip, stop_limits, parts, events, clock)
            run = [_Stop(cur, st.name, 0.0, None, st.time, True)]
    if len(run) > 1:
        clock, cur = _emit_run(run, scaled, options, timed, parts, waypoints, clock)
    parts = [p for p in parts if p.duration > 0] or [Hold(cur, 0.0, limits.dof)]
    traj = parts[0] if len(parts) == 1 else Chain(parts)
    hint = "lower the speed factor"
    if timed:
        hint = f"lower the speed factor (now {options.speed:g})"
    try:
        kinds = {options.interpolation, *(kf.interpolation for kf in program.keyframes)}
        n = check_trajectory(traj, limits, check_jerk=Interpolation.CUBIC not in kinds,
                             hint=hint, ball_jerk=kinds == {Interpolation.LINEAR})
    except LimitViolation as exc:
        if exc.kind in ("swing", "twist"):
            raise _ball_limit_error(exc, waypoints) from None
        if timed and exc.kind in ("velocity", "acceleration", "jerk"):
            best = _fastest_recorded_speed(traj, limits, options.speed, exc)
            advice = (f"try --speed {math.floor(best * 0.95 * 100) / 100:.2f} or lower"
                      if best * 0.95 >= MIN_SPEED else
                      "the recording is too fast for this arm at any speed factor; play it "
                      "with --ignore-times (timed by the joint limits)")
            raise LimitViolation(exc.joint, exc.kind, exc.value, exc.bound, exc.time,
                                 f"the recorded timing is too fast at speed {options.speed:g};"
                                 f" {advice}", exc.unit) from None
        raise
    desc = (f"{len(program.keyframes)} keyframes, {options.interpolation.value}, "
            f"{'blended' if options.blend else 'stop at each'}, x{options.loops}")
    return MotionPlan(traj, limits, tuple(sorted(events, key=lambda e: e.time)),
                      tuple(waypoints), time.perf_counter() - t0, n, desc)


def _ball_limit_error(exc: LimitViolation, waypoints: list[Waypoint]) -> LimitViolation:
    """A ball joint leaving its swing or twist range between keyframes, naming them.

    Both keyframes are inside the limits (each is checked); the arc between them is not: the
    set of rotations inside a twist range or a swing cone is not convex on the sphere.
    """
    before = [w for w in waypoints if w.time <= exc.time + 1e-9]
    after = [w for w in waypoints if w.time > exc.time + 1e-9]
    where = (f"between keyframes {before[-1].name!r} and {after[0].name!r}" if before and after
             else (f"after keyframe {before[-1].name!r}" if before else
                   "on the way to the first keyframe"))
    hint = (f"the {exc.kind} of ball joint {exc.joint!r} leaves its range {where} (both "
            "keyframes are inside; the turn between them is not): add a keyframe between "
            "them inside the range, or change one of them")
    return LimitViolation(exc.joint, exc.kind, exc.value, exc.bound, exc.time, hint, exc.unit)


def _fastest_recorded_speed(traj: Trajectory, limits: MotionLimits, speed: float,
                            first: LimitViolation, dt: float = 0.002) -> float:
    """The largest speed factor at which a recording's timing stays inside the limits [-].

    Played ``k`` times faster, a timed motion has ``k`` times the velocity, ``k^2`` the
    acceleration and ``k^3`` the jerk, so the worst ratio of each over the whole plan (not only
    the first violation) gives the factor.
    """
    n = max(2, math.ceil(traj.duration / dt) + 1)
    ts = np.unique(np.concatenate([np.linspace(0.0, traj.duration, n), traj.breakpoints()]))
    _, qd, qdd = traj.sample_many(ts)
    vel, acc, jerk_lim = limits.rate_limits()
    qd, qdd = limits.rates(qd), limits.rates(qdd)
    worst = max(float(np.max(np.abs(qd) / vel, initial=0.0)),
                math.sqrt(float(np.max(np.abs(qdd) / acc, initial=0.0))),
                abs(first.value) / first.bound if first.kind == "velocity" else 0.0,
                math.sqrt(abs(first.value) / first.bound) if first.kind == "acceleration"
                else 0.0,
                (abs(first.value) / first.bound) ** (1 / 3) if first.kind == "jerk" else 0.0)
    if np.any(np.isfinite(jerk_lim)) and ts.size > 2:
        dts = np.diff(ts)
        keep = dts > 1e-6
        jerk = np.diff(qdd, axis=0)[keep] / dts[keep, None]
        worst = max(worst, float(np.max(np.abs(jerk) / jerk_lim, initial=0.0)) ** (1 / 3))
    return speed / worst if worst > 1.0 else speed


def check_keyframe_values(program: KeyframeProgram, model: KinematicModel) -> None:
    """Refuse joint and gripper values of the program outside the limits of ``model``.

    Needs neither the present pose nor IK (pose keyframes are checked when planned), so it
    runs before a bus is opened.

    Raises:
        ConfigError: In the file's units, naming the file, line, keyframe, joint and limits.
    """
    idx = _program_entries(program, model)
    for k, kf in enumerate(program.keyframes):
        q = np.full(model.nq, np.nan)
        if kf.q is not None:
            q[idx] = kf.q
        _check_keyframe(program, model, k, kf, q)


def _check_keyframe(program: KeyframeProgram, model: KinematicModel, k: int, kf: Keyframe,
                    q: Array) -> None:
    """Refuse a keyframe (or its gripper value) outside the joint limits, naming file and line.

    Entries of ``q`` that are NaN are not checked.

    Raises:
        ConfigError: In the file's angle unit, naming the keyframe, the joint and the limits.
    """
    if model.multi_dof_joints:
        _check_multi_dof_keyframe(program, model, k, kf, q)
        return
    grip = [i for i, r in enumerate(model.joint_roles) if r is JointRole.GRIPPER]
    checks = [(i, float(q[i]), "") for i in range(model.dof) if not math.isnan(q[i])]
    if kf.gripper is not None:
        checks += [(i, float(kf.gripper), "gripper value for ") for i in grip]
    for i, v, what in checks:
        lo, hi = float(model.lower[i]), float(model.upper[i])
        if lo - _LIMIT_TOL <= v <= hi + _LIMIT_TOL:
            continue
        unit, scale = "rad", 1.0
        if model.joint_types[i] is JointType.PRISMATIC:
            unit, scale = program.length_unit.value, 1.0 / program.length_unit.metres
        elif program.angle_unit is AngleUnit.DEG:
            unit, scale = "deg", float(np.degrees(1.0))
        source = "" if kf.q is not None else " (IK solution of the pose)"
        where = kf.where if kf.where.keys else KeyPath(keys=("keyframes", k), label=kf.label)
        fix = "change the keyframe to a value inside the joint limits"
        if kf.q is not None or what:  # a value of the file: perhaps written in another unit
            fix = _unit_hint(program, model.joint_types[i], v, lo, hi) + fix
        raise ConfigError(
            f"{what}joint {model.joint_names[i]!r} would be "
            f"{v * scale:.6g} {unit}{source}, outside its limits [{lo * scale:.6g}, "
            f"{hi * scale:.6g}] {unit}; nothing was moved", where, fix)


def _check_multi_dof_keyframe(program: KeyframeProgram, model: KinematicModel, k: int,
                              kf: Keyframe, q: Array) -> None:
    """:func:`_check_keyframe` for an arm with universal or ball joints.

    1-DOF joints and a universal joint's angles against their ranges, a ball joint's rotation
    against its swing cone and twist range (angles in the file's angle unit).

    Raises:
        ConfigError: Naming the keyframe, the joint (and angle) and the limits.
    """
    where = kf.where if kf.where.keys else KeyPath(keys=("keyframes", k), label=kf.label)
    source = "" if kf.q is not None else " (IK solution of the pose)"
    deg = program.angle_unit is AngleUnit.DEG
    grip = _gripper_entries(model)
    layout = JointLayout.of(model)
    assert layout is not None
    values = q.copy()
    if kf.gripper is not None:
        values[grip] = kf.gripper
    for i, name in enumerate(model.joint_names):
        sl = model.q_index(i)
        part = values[sl]
        if np.isnan(part).any():
            continue
        jtype = model.joint_types[i]
        what = "gripper value for " if kf.gripper is not None and sl.start in grip else ""
        if jtype is JointType.BALL:
            ball = next(x for x in layout.balls if x.name == name)
            row = model.neutral()  # every other ball joint at rest, inside its limits
            row[ball.q] = part / np.linalg.norm(part)
            found = layout.ball_violation(row[None, :])
            if found is not None:
                _, _, kind, value, lo, hi = found
                scale, unit = (float(np.degrees(1.0)), "deg") if deg else (1.0, "rad")
                raise ConfigError(
                    f"the {kind} of ball joint {name!r} would be {value * scale:.6g} {unit}"
                    f"{source}, outside its limits [{lo * scale:.6g}, {hi * scale:.6g}] "
                    f"{unit}; nothing was moved", where,
                    "change the keyframe's rotation to one inside the swing cone and twist "
                    "range")
            continue
        for n, v in enumerate(part):
            j = sl.start + n
            lo, hi = float(model.lower[j]), float(model.upper[j])
            if lo - _LIMIT_TOL <= v <= hi + _LIMIT_TOL:
                continue
            unit, scale = "rad", 1.0
            if jtype is JointType.PRISMATIC:
                unit, scale = program.length_unit.value, 1.0 / program.length_unit.metres
            elif deg:
                unit, scale = "deg", float(np.degrees(1.0))
            label = f"angle {n + 1} of universal joint" if jtype is JointType.UNIVERSAL else (
                "joint")
            fix = "change the keyframe to a value inside the joint limits"
            if kf.q is not None or what:
                fix = _unit_hint(program, jtype, float(v), lo, hi) + fix
            raise ConfigError(
                f"{what}{label} {name!r} would be {v * scale:.6g} {unit}{source}, outside its "
                f"limits [{lo * scale:.6g}, {hi * scale:.6g}] {unit}; nothing was moved",
                where, fix)


def _unit_hint(program: KeyframeProgram, jtype: JointType, value: float, lo: float,
               hi: float) -> str:
    """A question when a file value [rad]/[m] outside ``[lo, hi]`` fits them in another unit.

    Radians that fit as degrees suggest ``units: {angle: deg}``; metres that fit as millimetres
    ``units: {length: mm}``. Empty when neither applies.
    """
    if jtype is JointType.PRISMATIC:
        if program.length_unit is LengthUnit.M and lo <= value / 1000.0 <= hi:
            return ("the values look like millimetres: set 'units: {length: mm}' at the top of "
                    "the file? Or ")
    elif program.angle_unit is AngleUnit.RAD and lo <= math.radians(value) <= hi:
        return ("the values look like degrees: set 'units: {angle: deg}' at the top of the "
                "file? Or ")
    return ""


def _emit_run(run: list[_Stop], limits: MotionLimits, options: PlaybackOptions, timed: bool,
              parts: list[Trajectory], waypoints: list[Waypoint], clock: float
              ) -> tuple[float, Array]:
    q = np.stack([s.q for s in run])
    durations = None
    if timed:
        stamps = np.diff(np.array([s.time for s in run], dtype=float))
        if np.all(stamps > 0):
            durations = stamps / options.speed
        else:  # from the end of one loop back to its start: no recorded timing
            limits = limits.scaled(min(options.speed, 1.0))
    # The segment into a keyframe takes that keyframe's interpolation (else the option's);
    # consecutive segments of one kind form one run, at rest where the kind changes.
    kinds = [s.interpolation or options.interpolation for s in run[1:]]
    a = 0
    while a < len(kinds):
        b = a
        while b + 1 < len(kinds) and kinds[b + 1] is kinds[a]:
            b += 1
        planner = plan_run if limits.layout is None else plan_layout_run
        traj, knots = planner(q[a:b + 2], limits, kinds[a],
                              None if durations is None else durations[a:b + 1])
        for k, (s, t) in enumerate(zip(run[a + 1:b + 2], knots[1:], strict=False)):
            at_rest = s.stop or (k == b - a and b + 1 < len(kinds))  # the kind changes here
            waypoints.append(Waypoint(clock + t, s.q, s.name, at_rest))
        parts.append(traj)
        clock += traj.duration
        a = b + 1
    return clock, run[-1].q


def _gripper_move(q: Array, value: float, grip: list[int], limits: MotionLimits) -> Trajectory:
    goal = q.copy()
    goal[grip] = value
    return _move(q, goal, limits)


def _emit_stop(st: _Stop, cur: Array, grip: list[int], limits: MotionLimits,
               parts: list[Trajectory], events: list[Event], clock: float) -> tuple[float, Array]:
    if st.dwell > 0:
        parts.append(Hold(cur, st.dwell, limits.dof))
        events.append(Event(clock, "dwell", st.name, st.dwell))
        clock += st.dwell
    if st.gripper is not None and grip:
        move = _gripper_move(cur, st.gripper, grip, limits)
        events.append(Event(clock, "gripper", st.name, st.gripper))
        if move.duration > 0:
            parts.append(move)
            clock += move.duration
        cur = move.end
    return clock, cur
