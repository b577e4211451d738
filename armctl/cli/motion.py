"""Motion commands: move-to-pose, move-joints, home, park, teach, play."""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from armctl.cli._common import (
    add_config,
    add_json,
    emit,
    finite,
    fmt,
    is_keyframe_file,
    load_arm_arg,
    parse_angles,
    positive_int,
    table,
)
from armctl.config.schema import JointType
from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.motion import MotionPlan
    from armctl.robot import CycleInfo, MoveReport, Robot

ORDER = 40

#: A plan shorter than this [s] does not move the arm.
_STILL_TIME = 1e-6
#: Start and goal closer than this [rad]/[m] are the same position.
_STILL_GAP = 1e-6


# ---- arguments -------------------------------------------------------------------------------
def _add_move_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--speed", type=finite, default=None,
                   help="speed factor of the joint limits, 0.01 to 1 (default: the config's)")
    p.add_argument("--dry-run", action="store_true", help="print the plan, move nothing")
    p.add_argument("--exit-policy", choices=["hold", "park", "release"], default=None,
                   help="what to do when the command ends normally (default: hold); a stopped "
                        "motion always holds where it stopped")
    p.set_defaults(stop_signals=True)  # SIGINT, SIGTERM, SIGHUP stop the motion (cli main)


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the motion commands."""
    p = sub.add_parser("move-to-pose", help="move the tool to a position (and orientation)",
                       description="Solve IK for the goal, plan a synchronised move (or a "
                       "straight line with --linear), stream it, and report the reached pose "
                       "(FK of the joints read back). Unreachable goals move nothing (exit 3).")
    add_config(p)
    from armctl.cli.ik import add_goal_arguments

    add_goal_arguments(p)  # --xyz, --rpy/--quat/--direction, --frame, --tol-pos, --tol-rot
    p.add_argument("--deg", action="store_true", help="--rpy in degrees")
    p.add_argument("--linear", action="store_true", help="move the tool along a straight line")
    p.add_argument("--solver", default="auto", help="IK solver (default auto)")
    p.add_argument("--force-pose", action="store_true",
                   help="move to a full pose (--rpy/--quat) even when fewer than 6 joints move "
                        "the frame (such a pose is reachable only on a 5-DOF subset)")
    _add_move_options(p)
    add_json(p)
    p.set_defaults(func=cmd_move_to_pose)

    p = sub.add_parser("move-joints", help="move every joint to the given values together")
    add_config(p)
    p.add_argument("values", nargs="+", metavar="Q", help="one value per joint [rad] or [m]")
    p.add_argument("--deg", action="store_true", help="rotary joint values in degrees")
    _add_move_options(p)
    add_json(p)
    p.set_defaults(func=cmd_move_joints)

    for name, what in (("home", "the 'home' pose"), ("park", "the 'park' rest pose")):
        p = sub.add_parser(name, help=f"move to {what}")
        add_config(p)
        _add_move_options(p)
        add_json(p)
        p.set_defaults(func=cmd_named, pose=name)

    p = sub.add_parser("teach", help="record keyframes by hand-guiding or jogging",
                       description="Torque goes off for the released joints (grippers stay "
                       "stiff); guide the arm and press Enter to record a keyframe. The file is "
                       "rewritten atomically after every keyframe. Type 'help' for commands.")
    add_config(p)
    p.add_argument("-o", "--output", required=True, help="keyframe file to write")
    existing = p.add_mutually_exclusive_group()
    existing.add_argument("--force", action="store_true",
                          help="overwrite an existing keyframe file")
    existing.add_argument("--append", action="store_true",
                          help="add to an existing keyframe file (same arm; its units are kept)")
    p.add_argument("--release", nargs="+", default=None, metavar="JOINT",
                   help="joints to release for hand-guiding (default: all but the gripper)")
    p.add_argument("--stiff", action="store_true", help="start with torque on (jog mode)")
    p.add_argument("--deg", action="store_true",
                   help="write angles in degrees (with --append: the file's unit is kept)")
    add_json(p)
    p.set_defaults(func=cmd_teach)

    p = sub.add_parser("play", help="play a keyframe file",
                       description="Plan the whole program first (every sample is checked "
                       "against the position, velocity and acceleration limits), then play it.")
    p.add_argument("file", metavar="FILE", help="keyframe file")
    add_config(p)
    p.add_argument("--interpolation", choices=["linear", "cubic", "min-jerk"],
                   default="min-jerk", help="how keyframes are joined (default min-jerk)")
    p.add_argument("--stop-at-keyframes", action="store_true",
                   help="stop at every keyframe instead of passing through")
    p.add_argument("--loop", type=positive_int, default=1, metavar="N", help="play N times")
    p.add_argument("--reverse", action="store_true", help="play the keyframes backwards")
    p.add_argument("--no-ease-in", action="store_true",
                   help="do not move slowly to the first keyframe (the arm must be there)")
    p.add_argument("--ignore-times", action="store_true",
                   help="time a recording by the joint limits, not its time stamps")
    p.add_argument("--preview", metavar="PNG",
                   help="write a plot of the plan (.png .svg .pdf .jpg; no motion)")
    p.add_argument("--solver", default="auto", help="IK solver for pose keyframes")
    p.add_argument("--speed", type=finite, default=1.0,
                   help="speed factor: 0.01-4 for recordings played by their time stamps, "
                        "0.01-1 of the joint limits otherwise (default 1)")
    p.add_argument("--dry-run", action="store_true", help="print the plan, move nothing")
    p.add_argument("--exit-policy", choices=["hold", "park", "release"], default=None,
                   help="what to do when playback ends normally (default: hold); a stopped "
                        "motion always holds where it stopped")
    add_json(p)
    p.set_defaults(func=cmd_play, stop_signals=True)


# ---- shared ------------------------------------------------------------------------------------
def _open(args: argparse.Namespace, arm: Arm, hold: bool = False) -> Robot:
    """Open the arm's robot (and its bus), with the command's exit policy (default: hold).

    Without ``hold`` nothing is written to the servos until the first motion (which holds the
    present pose first), so a plan is checked against the effective limits before torque comes
    on, and a dry run never switches torque on. With ``--exit-policy park`` the park pose is
    checked against the config's limits before the bus opens and against the effective limits
    right after, before anything moves.

    Raises:
        InputError: ``--exit-policy park`` for an arm without a 'park' pose.
        JointLimitError: A 'park' pose outside the config's or the effective limits.
    """
    from armctl.cli import _checks
    from armctl.config.motion import ExitPolicy
    from armctl.robot import Robot

    policy = ExitPolicy(getattr(args, "exit_policy", None) or "hold")
    if policy is ExitPolicy.PARK:
        _checks.check_park_pose(arm)
    speed = getattr(args, "speed", None)
    robot = Robot.open(arm, speed=speed if speed is not None and speed <= 1 else None,
                       exit_policy=policy, hold=hold)
    try:
        if policy is ExitPolicy.PARK:
            robot.effective.check(robot.arm.named_pose("park"),
                                  "the 'park' pose of --exit-policy park")
    except BaseException:
        robot.close_holding("the park pose was refused")
        raise
    if robot.simulated and not getattr(args, "json", False):
        print(f"--- SIMULATED BUS: arm {robot.arm.name!r}, no hardware ---", file=sys.stderr)
    return robot


class _Progress:
    """A one-line progress bar with the live tracking error, on a terminal only."""

    def __init__(self, enabled: bool, unit: str = "rad"):
        self.enabled = enabled and sys.stderr.isatty()
        self.unit = unit
        self._last = 0.0

    def __call__(self, info: CycleInfo) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self._last < 0.1 and info.t < info.duration:
            return
        self._last = now
        frac = min(info.t / info.duration, 1.0) if info.duration > 0 else 1.0
        bar = "#" * int(frac * 30)
        state = "stopping" if info.stopping else "moving"
        sys.stderr.write(f"\r{state} [{bar:<30}] {frac:4.0%}  t {info.t:5.2f}/"
                         f"{info.duration:.2f} s  error {math.degrees(info.tracking_error):5.2f}"
                         " deg ")
        sys.stderr.flush()

    def done(self) -> None:
        """End the bar's line (once, and only if a bar was drawn)."""
        if self.enabled and self._last:
            sys.stderr.write("\n")
            self._last = 0.0


def _plan_data(robot: Robot, plan: MotionPlan) -> dict[str, Any]:
    vr, ar = plan.peak_ratios()
    return {"description": plan.description, "duration": plan.duration,
            "planning_time": plan.planning_time, "samples_checked": plan.samples_checked,
            "start": robot.arm.values_by_name(plan.start),
            "target": robot.arm.values_by_name(plan.goal),
            "peak_velocity_ratio": vr, "peak_acceleration_ratio": ar}


def _shown(arm: Arm, i: int, value: float) -> tuple[str, str]:
    """A joint value for text output: degrees for rotary joints, millimetres for prismatic."""
    from armctl.config.schema import JointType

    if arm.joint_types[i] is JointType.PRISMATIC:
        return fmt(value * 1000.0, 2), "mm"
    return fmt(math.degrees(value), 2), "deg"


def _plan_text(robot: Robot, plan: MotionPlan, head: str) -> str:
    arm = robot.arm
    rows = [[n, _shown(arm, i, a)[0], *_shown(arm, i, b)]
            for i, (n, a, b) in enumerate(zip(arm.joint_names, plan.start, plan.goal,
                                              strict=True))]
    vr, ar = plan.peak_ratios()
    return (f"{head}\nplan: {plan.description}, duration {plan.duration:.2f} s, planned in "
            f"{plan.planning_time * 1000:.1f} ms ({plan.samples_checked} samples checked; peak "
            f"velocity {vr:.0%}, acceleration {ar:.0%} of the limits)\n"
            + table(["joint", "from", "to", "unit"], rows, right=[1, 2]))


def _nothing_to_do(plan: MotionPlan, endpoints: bool = True,
                   still: float | np.ndarray = _STILL_GAP) -> bool:
    """Whether a plan does not move the arm (zero duration, or start = goal without events).

    ``still``: start and goal closer than this on every joint are the same position [rad]/[m]
    (a scalar or ``(dof,)``, e.g. one servo tick).
    """
    if plan.duration < _STILL_TIME:
        return True
    gap = np.abs(plan.goal - plan.start)
    return endpoints and not plan.events and bool(np.all(gap < still))


def _stream_text(robot: Robot, report: MoveReport, idle: str | None = None
                 ) -> tuple[dict[str, Any], str]:
    """Streaming figures; ``idle`` is the message when the plan did not move the arm."""
    res = report.result
    if idle is not None:
        return {"moved": False, "nothing_to_do": True}, idle
    if res is None:
        return {"moved": False}, "dry run: nothing moved"
    s = res.stats
    data = {"moved": True, "final_joints": robot.arm.values_by_name(res.final),
            "loop_rate": s.achieved_rate, "jitter_p99": s.jitter_p99,
            "max_tracking_error": float(np.max(s.max_tracking_error, initial=0.0)),
            "settle_time": s.settle_time}
    text = (f"streamed {s.cycles} cycles at {s.achieved_rate:.1f} Hz (target {s.rate_hz:g}), "
            f"jitter p99 {s.jitter_p99 * 1000:.2f} ms, max tracking error "
            f"{math.degrees(float(np.max(s.max_tracking_error, initial=0.0))):.2f} deg")
    mapping = getattr(robot.bus, "mapping", None)
    names = {j.servo_id: j.name for j in mapping.joints} if mapping is not None else {}
    data["bus_retries"] = [{"servo_id": sid, "joint": names.get(sid), "count": n}
                           for sid, n in s.retries.items()]
    if s.retries:  # retries hide intermittent faults: never a silent success
        text += ("\nbus retries (replies missing, corrupt or late): " + ", ".join(
            f"servo {sid}" + (f" ({names[sid]})" if sid in names else "") + f" {n}"
            for sid, n in s.retries.items()))
    return data, text


def _run(args: argparse.Namespace, fn: Any, arm: Arm) -> Any:
    """Open the robot, run ``fn(robot, progress)`` and close.

    The exit policy applies only when the command ends normally after a real run: a dry run
    writes nothing at all; a stop, an error or a signal holds the arm where it is.
    """
    from armctl.config.motion import ExitPolicy
    from armctl.robot import MotionStopped

    robot = _open(args, arm)
    dry = getattr(args, "dry_run", False)
    progress = _Progress(not args.json and not dry)
    try:
        result = fn(robot, progress)
        progress.done()
    except BaseException as exc:
        progress.done()
        if isinstance(exc, MotionStopped) and not args.json:
            print(_stop_text(robot, exc), flush=True)
        robot.close_holding("the motion was stopped" if isinstance(exc, MotionStopped)
                            else "the command failed")
        raise
    guard = getattr(args, "signal_guard", None)
    if dry:  # nothing was written to the servos, and nothing will be
        if robot.exit_policy is not ExitPolicy.HOLD:
            print(f"armctl: dry run: --exit-policy {robot.exit_policy.value} not applied "
                  "(nothing was written to the servos)", file=sys.stderr)
        robot.close(ExitPolicy.HOLD)
    elif guard is not None and guard.signalled:  # a signal after the motion: no exit policy
        robot.close_holding("signal received")
    else:
        robot.close()
    return robot, result


def _stop_text(robot: Robot, stopped: Any) -> str:
    """Where a stopped motion left the arm: joints (deg, mm) and the tool pose."""
    where = stopped.stopped_at
    head = f"stopped {stopped.time:.2f} s into the motion"
    if where is None:
        return head + "; the position could not be read back"
    arm = robot.arm
    joints = where["joints"]
    rows = [[n, *_shown(arm, i, float(joints[n]))] for i, n in enumerate(arm.joint_names)]
    rpy = np.degrees(np.asarray(where["rpy"], dtype=float))
    return (f"{head}; the arm holds here (joints read back):\n"
            + table(["joint", "stopped at", "unit"], rows, right=[1]) + "\n"
            f"tool xyz {np.round(np.asarray(where['xyz'], dtype=float), 4).tolist()} m, rpy "
            f"{np.round(rpy, 1).tolist()} deg (FK of the joints read back)")


# ---- commands -----------------------------------------------------------------------------------
def cmd_move_to_pose(args: argparse.Namespace) -> int:
    """``armctl move-to-pose``."""
    from armctl.cli import _checks
    from armctl.cli.ik import build_goals, check_pose_dof

    if args.xyz is None:
        raise InputError("move-to-pose needs --xyz X Y Z (optionally with --rpy, --quat or "
                         "--direction)")
    arm = load_arm_arg(args)
    (goal,) = build_goals(args, arm)
    if not args.force_pose:  # as armctl ik: a 6-DOF pose for fewer joints, refused at once
        check_pose_dof(arm, (goal,))
    _checks.check_speed_arg(args, arm)
    _checks.check_solver(args.solver)
    _checks.check_goal_reach(arm, goal, args.solver)

    def go(robot: Robot, progress: _Progress) -> MoveReport:
        plan, ik = robot.plan_pose(goal, linear=args.linear, speed=args.speed,
                                   solver=args.solver)
        head = (f"arm {robot.arm.name}: goal xyz {np.round(args.xyz, 4).tolist()} m "
                f"({type(goal).__name__}); "
                + (f"IK solver {ik.solver} ({ik.iterations} iterations, "
                   f"{ik.position_error * 1000:.3f} mm)" if ik else "straight line"))
        if _nothing_to_do(plan):
            from armctl.robot import MoveReport

            return MoveReport(plan, None, ik)
        if not args.json:
            print(_plan_text(robot, plan, head), flush=True)
        if args.dry_run:
            from armctl.robot import MoveReport

            return MoveReport(plan, None, ik)
        res = robot.execute(plan, progress)
        reached = robot.arm.fk(res.final, goal.frame)
        dp, dr = goal.errors(reached)
        from armctl.robot import MoveReport

        return MoveReport(plan, res, ik, reached, dp, dr)

    robot, report = _run(args, go, arm)
    data: dict[str, Any] = {"plan": _plan_data(robot, report.plan),
                            "solver": report.ik.solver if report.ik else None}
    idle = "already at the goal; nothing to do" if _nothing_to_do(report.plan) else None
    sdata, stext = _stream_text(robot, report, idle)
    data.update(sdata)
    text = stext
    if report.reached is not None:
        from armctl.spatial import matrix_to_rpy

        rpy_rad = matrix_to_rpy(report.reached[:3, :3])
        rpy = np.degrees(rpy_rad)
        data.update({"reached_xyz": report.reached[:3, 3], "reached_rpy": rpy_rad,
                     "position_error": report.position_error,
                     "rotation_error": report.rotation_error})
        text += (f"\nreached xyz {np.round(report.reached[:3, 3], 4).tolist()} m, rpy "
                 f"{np.round(rpy, 1).tolist()} deg (FK of the joints read back)\n"
                 f"remaining error {report.position_error * 1000:.2f} mm, "
                 f"{math.degrees(report.rotation_error):.2f} deg")
    emit(args, data, text)
    return 0


def cmd_move_joints(args: argparse.Namespace) -> int:
    """``armctl move-joints``."""
    from armctl.cli import _checks

    arm = load_arm_arg(args)
    q = parse_angles(args.values, args.deg, arm, "move-joints values")
    _check_values(arm, q, args.deg)
    _checks.check_speed_arg(args, arm)
    return _joint_command(args, arm, lambda robot: q, "move to joint values",
                          "already at these joint values; nothing to do")


def cmd_named(args: argparse.Namespace) -> int:
    """``armctl home`` and ``armctl park``."""
    from armctl.cli import _checks

    arm = load_arm_arg(args)
    _checks.check_named_pose(arm, args.pose)
    _checks.check_speed_arg(args, arm)
    return _joint_command(args, arm, lambda robot: robot.arm.named_pose(args.pose),
                          f"move to the {args.pose!r} pose",
                          f"already at the {args.pose!r} pose; nothing to do")


def _check_values(arm: Arm, q: np.ndarray, deg: bool) -> None:
    """Refuse joint values outside the limits, saying so in the unit they were given in.

    The message names the limit's source as the effective limits do (the config's file, line
    and key, and how to change it); ``details["limit_source"]`` is ``"config"`` (the
    calibration and the servo registers are checked once the bus is open).

    Raises:
        JointValueError: For the first joint outside its limits; without ``--deg`` a rotary
            value that would be inside its limits in degrees adds "did you forget --deg?".
    """
    from armctl.config.schema import JointType
    from armctl.robot.errors import JointValueError
    from armctl.servo.effective_limits import effective_limits

    for i, name in enumerate(arm.joint_names):
        v, lo, hi = float(q[i]), float(arm.lower[i]), float(arm.upper[i])
        if lo - 1e-9 <= v <= hi + 1e-9:
            continue
        limits = effective_limits(arm.spec)
        hint = limits.explain(name, v)
        if arm.joint_types[i] is JointType.PRISMATIC:
            unit, scale = "m", 1.0
        elif deg:
            unit, scale = "deg", math.degrees(1.0)
        else:
            unit, scale = "rad", 1.0
            if lo <= math.radians(v) <= hi:
                hint = f"Did you forget --deg? ({v:g} deg is inside the limits) {hint}"
        exc = JointValueError(
            name, v, lo, hi, f"joint {name!r}: {v * scale:.6g} {unit} is outside its limits "
            f"[{lo * scale:.6g}, {hi * scale:.6g}] {unit} (goal of move-joints); nothing was "
            f"sent. {hint}")
        exc.details["limit_source"] = limits.joint(name).bound(v).source.value
        raise exc


def _joint_command(args: argparse.Namespace, arm: Arm, target: Any, what: str, idle: str
                   ) -> int:
    still: list[bool] = []

    def go(robot: Robot, progress: _Progress) -> MoveReport:
        from armctl.robot import MoveReport

        plan = robot.plan_joints(target(robot), args.speed, what)
        if _nothing_to_do(plan, still=_one_tick(robot)):  # a servo cannot get any closer
            still.append(True)
            if not args.json:  # before what the exit policy says
                print(idle, flush=True)
            return MoveReport(plan)
        if not args.json:
            print(_plan_text(robot, plan, f"arm {robot.arm.name}"), flush=True)
        if args.dry_run:
            return MoveReport(plan)
        res = robot.execute(plan, progress)
        return MoveReport(plan, res, reached=robot.arm.fk(res.final))

    robot, report = _run(args, go, arm)
    data: dict[str, Any] = {"plan": _plan_data(robot, report.plan)}
    if still:
        data.update(moved=False, nothing_to_do=True)
        if args.json:
            emit(args, data, idle)
        return 0
    sdata, text = _stream_text(robot, report)
    data.update(sdata)
    if report.result is not None and report.reached is not None:
        rdata, rtext = _reached_joints(robot, report.plan.goal, report.result.final,
                                       report.reached)
        data.update(rdata)
        text += "\n" + rtext
    emit(args, data, text)
    return 0


def _one_tick(robot: Robot) -> np.ndarray:
    """One servo tick of every joint in joint units ``(dof,)`` [rad]/[m] (at least 1e-6)."""
    eff = robot.effective
    tick = {j.name: j.margin / max(eff.margin_ticks, 1) for j in eff.joints}
    return np.maximum([tick.get(n, 0.0) for n in robot.arm.joint_names], _STILL_GAP)


def _reached_joints(robot: Robot, goal: np.ndarray, final: np.ndarray, reached: np.ndarray
                    ) -> tuple[dict[str, Any], str]:
    """The reached tool pose and the remaining error of a joint move (JSON fields, text).

    Args:
        robot: The robot.
        goal: The joint goal ``(dof,)`` [rad]/[m].
        final: The joints read back after the move ``(dof,)``.
        reached: FK of ``final`` (the tool) ``(4, 4)``.
    """
    from armctl.config.schema import JointRole
    from armctl.spatial import matrix_to_rpy

    arm = robot.arm
    aimed = arm.fk(goal)
    dp = float(np.linalg.norm(reached[:3, 3] - aimed[:3, 3]))
    cos = (float(np.trace(aimed[:3, :3].T @ reached[:3, :3])) - 1.0) / 2.0
    dr = math.acos(min(1.0, max(-1.0, cos)))
    err = np.asarray(final, dtype=float) - np.asarray(goal, dtype=float)
    rpy = matrix_to_rpy(reached[:3, :3])
    data = {"reached_xyz": reached[:3, 3], "reached_rpy": rpy, "position_error": dp,
            "rotation_error": dr, "joint_errors": arm.values_by_name(err)}
    arm_joints = [i for i, r in enumerate(arm.joint_roles) if r is not JointRole.GRIPPER]
    worst = max(arm_joints or range(arm.dof), key=lambda i: abs(err[i]))
    value, unit = _shown(arm, worst, abs(float(err[worst])))
    text = (f"reached xyz {np.round(reached[:3, 3], 4).tolist()} m, rpy "
            f"{np.round(np.degrees(rpy), 1).tolist()} deg (FK of the joints read back)\n"
            f"remaining error: tool {dp * 1000:.2f} mm, {math.degrees(dr):.2f} deg; joints at "
            f"most {value} {unit} ({arm.joint_names[worst]})")
    return data, text


def cmd_play(args: argparse.Namespace) -> int:
    """``armctl play``."""
    from dataclasses import replace

    from armctl.cli import _checks
    from armctl.motion import Interpolation, PlaybackOptions, load_keyframes
    from armctl.motion.playback import check_playback_speed

    _refuse_swapped(args.file, args.config)
    _checks.check_keyframe_path(args.file)
    arm = load_arm_arg(args)
    program = load_keyframes(args.file, arm)
    if not program.keyframes:
        from pathlib import Path

        from armctl.errors import ConfigError, KeyPath

        raise ConfigError("the keyframe file has no keyframes: nothing to play",
                          KeyPath(Path(args.file), ("keyframes",)),
                          f"record keyframes into it: armctl teach {args.config} -o "
                          f"{args.file} --append")
    options = PlaybackOptions(
        interpolation=Interpolation(args.interpolation), blend=not args.stop_at_keyframes,
        loops=args.loop, reverse=args.reverse, ease_in=not args.no_ease_in,
        use_times=not args.ignore_times)
    check_playback_speed(program, options, args.speed)  # the range that applies to this file
    options = replace(options, speed=args.speed)
    _checks.check_play(args, arm, program, options)
    if args.preview:
        args.dry_run = True

    def go(robot: Robot, progress: _Progress) -> MoveReport:
        from armctl.robot import MoveReport

        cal = robot.calibration_hash()
        if program.calibration and cal and program.calibration != cal:
            print(f"armctl: warning: the keyframes were taught with calibration "
                  f"{program.calibration}, the arm now uses {cal}", file=sys.stderr)
        plan = robot.plan_program(program, options, args.solver)
        if _nothing_to_do(plan, endpoints=False):
            return MoveReport(plan)
        if not args.json:
            print(_plan_text(robot, plan, f"arm {robot.arm.name}: play {args.file}"), flush=True)
        if args.preview:
            _preview(robot, plan, args.preview)
        if args.dry_run:
            return MoveReport(plan)
        res = robot.execute(plan, progress)
        return MoveReport(plan, res, reached=robot.arm.fk(res.final))

    robot, report = _run(args, go, arm)
    data: dict[str, Any] = {"plan": _plan_data(robot, report.plan),
                            "keyframes": [{"name": w.name, "time": w.time}
                                          for w in report.plan.waypoints],
                            "events": [{"time": e.time, "kind": e.kind, "name": e.name,
                                        "value": e.value} for e in report.plan.events]}
    idle = ("the program does not move the arm; nothing to do"
            if _nothing_to_do(report.plan, endpoints=False) else None)
    sdata, text = _stream_text(robot, report, idle)
    data.update(sdata)
    if args.preview:
        data["preview"] = args.preview
        text += f"\npreview written to {args.preview}"
    emit(args, data, text)
    return 0


def _refuse_swapped(file: str, config: str) -> None:
    """Refuse ``armctl play CONFIG KEYFRAMES``: the config position holds a keyframe file.

    Raises:
        InputError: If ``config`` is a YAML file with an ``armctl_keyframes`` key.
    """
    if not is_keyframe_file(config):
        return
    if is_keyframe_file(file):
        raise InputError(f"{config} is a keyframe file, not an arm config: give the arm config "
                         f"(a YAML or URDF file, or a bundled arm name such as so101) after the "
                         f"keyframe file: armctl play {file} CONFIG")
    raise InputError(f"{config} is a keyframe file, not an arm config: the arguments look "
                     f"swapped: use armctl play KEYFRAMES CONFIG (armctl play {config} "
                     f"{file})")


def _preview(robot: Robot, plan: MotionPlan, path: str) -> None:
    """Joint positions and velocities over time, with keyframes marked (matplotlib, headless)."""
    try:  # a bare Figure with the Agg canvas: no pyplot, no display, no global state
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - optional dependency
        raise InputError("--preview needs matplotlib (pip install 'armctl[render]')") from exc
    ts = np.linspace(0.0, plan.duration, max(2, int(plan.duration * 200)))
    q, qd, _ = plan.trajectory.sample_many(ts)
    fig = Figure(figsize=(9, 6))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for i, name in enumerate(robot.arm.joint_names):
        prismatic = robot.arm.joint_types[i] is JointType.PRISMATIC
        scale = 1000.0 if prismatic else math.degrees(1.0)
        ax1.plot(ts, scale * q[:, i], label=f"{name} [mm]" if prismatic else name)
        ax2.plot(ts, scale * qd[:, i])
    for w in plan.waypoints:
        ax1.axvline(w.time, color="0.8", lw=0.8, zorder=0)
    ax1.set_ylabel("position [deg; mm]")
    ax2.set_ylabel("velocity [deg/s; mm/s]")
    ax2.set_xlabel("time [s]")
    ax1.legend(fontsize=7, ncol=3)
    ax1.set_title(plan.description)
    fig.tight_layout()
    from armctl.render.plots import save_figure

    save_figure(fig, path, dpi=100)


TEACH_HELP = """commands (then Enter):
  <empty>                 record a keyframe at the present pose
  k [NAME] [dwell=S] [gripper=V|g]   record a named keyframe (g: the gripper's present value)
  g VALUE                 record a gripper event (VALUE in rad or m) at the present pose
  u                       undo the last keyframe
  c RATE [SECONDS]        continuous recording at RATE Hz (until Enter, or for SECONDS)
  j JOINT DELTA           jog one joint (DELTA in deg for rotary joints, mm for prismatic)
  x DX DY DZ              jog the tool along a straight line [mm]
  limp | stiff            torque off for the released joints / back on holding the pose
  p                       print the present joints and tool position
  q                       finish (torque back on, holding the pose)"""


def cmd_teach(args: argparse.Namespace) -> int:
    """``armctl teach``: an interactive, line-based teach session."""
    from pathlib import Path

    from armctl.cli import _checks
    from armctl.motion import AngleUnit
    from armctl.robot.teach import ExistingFile, TeachSession

    arm = load_arm_arg(args)
    _checks.check_teach_output(args, arm)
    existing = (ExistingFile.APPEND if args.append else
                ExistingFile.OVERWRITE if args.force else ExistingFile.REFUSE)
    robot = _open(args, arm, hold=True)  # the stiff joints (grippers) hold from the start
    try:
        session = TeachSession(robot, args.output, args.release,
                               AngleUnit.DEG if args.deg else AngleUnit.RAD, existing=existing)
        session.start(limp=not args.stiff)
        say = (lambda s: None) if args.json else (lambda s: print(s, flush=True))
        say(f"teaching {robot.arm.name} into {args.output}; torque off for: "
            f"{', '.join(session.release) if session.limp else '(none)'}\n"
            "  warning: released joints fall under gravity; support the arm\n" + TEACH_HELP)
        try:
            _teach_loop(session, robot, say, say if not args.json else (
                lambda s: print(f"armctl: {s}", file=sys.stderr, flush=True)))
        except KeyboardInterrupt:
            say("\ninterrupted: keeping what was recorded")
        finally:
            session.finish()
    finally:
        robot.close()
    n = len(session.program.keyframes)
    written = Path(args.output).exists()
    text = f"{n} keyframes in {args.output}"
    if not n:  # no empty keyframe file is left behind (an appended one is kept)
        text = f"nothing was recorded; {args.output} " + (
            "left as it was" if written else "was not written")
    emit(args, {"file": args.output, "keyframes": n, "written": written},
         f"{text}; torque on, holding the present pose")
    return 0


def _number(text: str) -> float:
    """A finite number typed in a teach session.

    Raises:
        ValueError: For text that is not a finite number.
    """
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise ValueError(f"{text!r} is not a finite number")
    return value


def _jog_joint(session: Any, robot: Robot, joint: str, delta: float) -> None:
    """Jog ``joint`` by ``delta`` as typed: degrees for a rotary joint, millimetres else.

    Raises:
        InputError: For a goal outside the effective limits, in the unit typed, with the
            limit's source; for an unknown joint.
    """
    from armctl.errors import JointLimitError

    arm = robot.arm
    prismatic = arm.joint_types[arm.joint_index(joint)] is JointType.PRISMATIC
    unit, scale = ("mm", 1000.0) if prismatic else ("deg", math.degrees(1.0))
    try:
        session.jog_joint(joint, delta / scale)
    except JointLimitError as exc:
        if exc.joint != joint:
            raise
        raise InputError(
            f"jogging {joint!r} by {delta:g} {unit} would take it to {exc.value * scale:.4g} "
            f"{unit}, outside its limits [{exc.lower * scale:.4g}, {exc.upper * scale:.4g}] "
            f"{unit}; nothing moved. {robot.effective.explain(joint, exc.value)}") from None


def _jog_tool(session: Any, delta_mm: np.ndarray) -> None:
    """Jog the tool along a straight line by ``delta_mm`` [mm].

    Raises:
        NoSolutionError: When the line cannot be followed, with advice for a teach session.
    """
    from armctl.errors import NoSolutionError
    from armctl.motion.errors import PathError

    try:
        session.jog_cartesian(delta_mm / 1000)
    except PathError as exc:
        raise NoSolutionError(
            f"the straight-line jog fails {exc.fraction:.0%} of the way: {exc.reason}; nothing "
            "was moved. Jog in smaller steps, or move single joints with 'j JOINT DELTA'"
        ) from None


def _teach_loop(session: Any, robot: Robot, say: Any, complain: Any) -> None:
    """Read and run teach commands until 'q' or the end of input.

    A command that fails for a user's reason (bad numbers, an unknown joint, a goal out of
    reach or outside the limits) is reported and the session goes on; bus failures and
    stopped motions end it. ``say`` prints progress, ``complain`` such errors.
    """
    import threading

    from armctl.errors import NoSolutionError

    while True:
        line = sys.stdin.readline()
        if not line:
            return
        parts = line.split()
        if not parts:
            kf = session.record()
            say(f"keyframe {len(session.program.keyframes)} recorded")
            continue
        cmd, rest = parts[0], parts[1:]
        try:
            if cmd == "q":
                return
            if cmd == "help":
                say(TEACH_HELP)
            elif cmd == "k":
                name = next((r for r in rest if "=" not in r), "")
                opts = dict(r.split("=", 1) for r in rest if "=" in r)
                grip = opts.get("gripper")
                kf = session.record(name, _number(opts.get("dwell", "0")),
                                    None if grip in (None, "g") else _number(grip),
                                    with_gripper=grip == "g")
                say(f"keyframe {len(session.program.keyframes)} {kf.name!r} recorded")
            elif cmd == "g":
                kf = session.record(gripper=_number(rest[0]))
                say(f"gripper event {kf.gripper} recorded")
            elif cmd == "u":
                say("removed the last keyframe" if session.undo() else "nothing to undo")
            elif cmd == "c":
                rate = _number(rest[0]) if rest else 20.0
                duration = _number(rest[1]) if len(rest) > 1 else None
                session.check_recording(rate, duration)
                stop = threading.Event()
                failure: list[BaseException] = []

                def record(rate: float = rate, duration: float | None = duration,
                           stop: threading.Event = stop,
                           failure: list[BaseException] = failure) -> None:
                    try:
                        session.record_continuous(rate, stop, duration)
                    except BaseException as exc:  # handed to the main thread below
                        failure.append(exc)

                worker = threading.Thread(target=record, daemon=True)
                worker.start()
                try:  # Ctrl-C (or anything) while waiting ends the recording too
                    say(f"recording at {rate:g} Hz; press Enter to stop")
                    if duration is None:
                        sys.stdin.readline()
                    else:
                        worker.join()
                finally:
                    stop.set()
                    worker.join()
                if failure:
                    raise failure[0]
                say(f"{len(session.program.keyframes)} keyframes in the file")
            elif cmd == "j":
                _jog_joint(session, robot, rest[0], _number(rest[1]))
                say(f"{rest[0]} moved")
            elif cmd == "x":
                if len(rest) != 3:
                    raise ValueError("x takes three numbers DX DY DZ [mm]")
                _jog_tool(session, np.array([_number(v) for v in rest]))
                say(f"tool at {np.round(robot.pose()[:3, 3], 4).tolist()} m")
            elif cmd == "limp":
                session.set_limp(True)
                say(f"torque off: {', '.join(session.release)}")
            elif cmd == "stiff":
                session.set_limp(False)
                say("torque on, holding the present pose")
            elif cmd == "p":
                q = robot.joints()
                say(f"joints [deg] {np.round(np.degrees(q), 1).tolist()}; tool "
                    f"{np.round(robot.pose()[:3, 3], 4).tolist()} m")
            else:
                complain(f"unknown command {cmd!r}; type 'help'")
        except (InputError, NoSolutionError) as exc:  # reported; the session goes on
            complain(f"error: {exc}")
        except (ValueError, IndexError) as exc:
            why = "a value is missing" if isinstance(exc, IndexError) else str(exc)
            complain(f"error: could not read {line.strip()!r}: {why}; type 'help'")
