"""Motion commands that move to one goal: move-to-pose, move-joints, home, park."""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING, Any

from armctl.cli._bus_choice import add_bus_choice
from armctl.cli._checks import check_servo_arm as _check_servo_arm
from armctl.cli._common import (
    add_config,
    add_json,
    add_log_option,
    emit,
    finite,
    load_arm_arg,
    parse_angles,
    positive,
)
from armctl.cli._parser import add_later
from armctl.cli._progress import Progress
from armctl.cli._scene import add_scene_option
from armctl.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from armctl.arm import Arm
    from armctl.ik import Goal, IKResult
    from armctl.motion import MotionPlan
    from armctl.motion.detour import DetourOptions
    from armctl.robot import MoveReport, Robot

ORDER = 40


def add_move_options(p: argparse.ArgumentParser) -> None:
    """The options every streamed motion verb shares: speed, dry run, exit policy, bus, scene."""
    p.add_argument("--speed", type=finite, default=None,
                   help="speed factor of the joint limits, 0.01 to 1 (default: the config's)")
    p.add_argument("--dry-run", action="store_true", help="print the plan, move nothing")
    p.add_argument("--exit-policy", choices=["hold", "park", "release"], default=None,
                   help="what to do when the command ends normally (default: hold); a stopped "
                        "motion always holds where it stopped")
    add_bus_choice(p)  # --port PORT | --sim
    add_log_option(p)  # --log FILE.csv
    add_scene_option(p)  # --scene FILE
    p.set_defaults(stop_signals=True)  # SIGINT, SIGTERM, SIGHUP stop the motion (cli main)


def add_plan_option(p: argparse.ArgumentParser) -> None:
    """Add ``--plan``: find a collision-free joint path when the direct move collides."""
    p.add_argument("--plan", action="store_true",
                   help="when the direct joint move collides, find a collision-free joint path "
                        "around the obstacles (sampling-based planner; docs/collision.md); "
                        "nothing moves when none is found in time")
    p.add_argument("--plan-time", type=positive, default=None, metavar="S",
                   help="with --plan: time budget of the planning [s] (default 1)")


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add move-to-pose, move-joints, home and park."""
    p = sub.add_parser("move-to-pose", help="move the tool to a position (and orientation)",
                       description="Solve IK for the goal, plan a synchronised move (or a "
                       "straight line with --linear), stream it, and report the reached pose "
                       "(FK of the joints read back). Unreachable goals move nothing (exit 3).")
    p.set_defaults(func=cmd_move_to_pose)
    add_later(p, _move_to_pose_arguments)  # the goal flags need armctl.ik: only when used

    p = sub.add_parser("move-joints", help="move every joint to the given values together")
    add_config(p)
    p.add_argument("values", nargs="+", metavar="Q", help="one value per joint [rad] or [m]")
    p.add_argument("--deg", action="store_true", help="rotary joint values in degrees")
    add_move_options(p)
    add_plan_option(p)
    add_json(p)
    p.set_defaults(func=cmd_move_joints)

    for name, what in (("home", "the 'home' pose"), ("park", "the 'park' rest pose")):
        p = sub.add_parser(name, help=f"move to {what}")
        add_config(p)
        add_move_options(p)
        add_plan_option(p)
        add_json(p)
        p.set_defaults(func=cmd_named, pose=name)


def detour_options(args: argparse.Namespace) -> DetourOptions | None:
    """The detour planning that ``--plan`` and ``--plan-time`` ask for (``None``: none).

    Raises:
        InputError: ``--plan-time`` without ``--plan``.
    """
    budget = getattr(args, "plan_time", None)
    if not getattr(args, "plan", False):
        if budget is not None:
            raise InputError("--plan-time is the time budget of --plan: add --plan")
        return None
    from armctl.motion.detour import DetourOptions

    return DetourOptions() if budget is None else DetourOptions(time_budget=budget)


def _move_to_pose_arguments(p: argparse.ArgumentParser) -> None:
    from armctl.cli.ik import add_goal_arguments

    add_config(p)
    add_goal_arguments(p)  # --xyz, --rpy/--quat/--direction, --frame, --tol-pos, --tol-rot
    p.add_argument("--deg", action="store_true",
                   help="--rpy in degrees, --tcp-angular-speed in deg/s")
    p.add_argument("--relative", nargs="?", const="base", choices=["base", "tool"],
                   default=None, metavar="base|tool",
                   help="--xyz [m] and --rpy are offsets from the present pose, along and about "
                        "the base axes (default) or the tool's own axes ('--relative tool')")
    p.add_argument("--linear", action="store_true", help="move the tool along a straight line")
    p.add_argument("--tcp-speed", type=positive, default=None, metavar="M_PER_S",
                   help="with --linear: largest speed of the tool along the line [m/s]")
    p.add_argument("--tcp-angular-speed", type=positive, default=None, metavar="RAD_PER_S",
                   help="with --linear: largest angular speed of the tool [rad/s] (deg/s with "
                        "--deg)")
    p.add_argument("--solver", default="auto", help="IK solver (default auto)")
    p.add_argument("--force-pose", action="store_true",
                   help="move to a full pose (--rpy/--quat) even when fewer than 6 joints move "
                        "the frame (such a pose is reachable only on a 5-DOF subset)")
    add_move_options(p)
    add_plan_option(p)  # joint moves only: refused with --linear
    add_json(p)


def cmd_move_to_pose(args: argparse.Namespace) -> int:
    """``armctl move-to-pose``."""
    import numpy as np

    from armctl.cli import _checks
    from armctl.cli._motion_report import plan_data, plan_text, stream_text
    from armctl.cli._motion_run import nothing_to_do, run_motion
    from armctl.cli._relative import check_relative_args, relative_goal, tcp_speeds
    from armctl.cli.ik import build_goals, check_pose_dof

    if args.xyz is None and args.relative is None:
        raise InputError("move-to-pose needs --xyz X Y Z (optionally with --rpy, --quat or "
                         "--direction), or offsets with --relative")
    if args.plan and args.linear:
        raise InputError("--plan finds a joint-space path around obstacles and does not go with "
                         "--linear: a straight line that collides is refused, never replaced "
                         "by a detour; drop --linear to let --plan find a way, or drop --plan")
    detour = detour_options(args)
    arm = load_arm_arg(args)
    _check_servo_arm(arm)
    tcp_speed, tcp_angular_speed = tcp_speeds(args)
    axes = None
    fixed: Goal | None = None  # an absolute goal, known before the bus opens
    if args.relative is not None:  # the goal needs the present pose: built once the bus is open
        axes = check_relative_args(args, arm)
    else:
        (fixed,) = build_goals(args, arm)
        if not args.force_pose:  # as armctl ik: a 6-DOF pose for fewer joints, refused at once
            check_pose_dof(arm, (fixed,))
    _checks.check_speed_arg(args, arm)
    _checks.check_solver(args.solver)
    _checks.check_deg_applies(args)  # --deg on a move without angles: nothing in degrees
    if fixed is not None:
        _checks.check_goal_reach(arm, fixed, args.solver)
    relative: dict[str, Any] = {}

    def go(robot: Robot, progress: Progress) -> MoveReport:
        if axes is None:
            assert fixed is not None  # mypy: built above
            goal = fixed
        else:
            start = robot.plan_start()
            present = robot.arm.fk(start, args.frame)
            goal = relative_goal(robot.arm, start, args, axes)
            relative.update({"from_xyz": present[:3, 3], "goal": goal})

        def show(plan: MotionPlan, ik: IKResult | None) -> bool:
            """Print the plan; whether to run it (not when it does not move the arm)."""
            if nothing_to_do(plan):
                return False
            target = goal.target_position
            where = "" if target is None else f"xyz {np.round(target, 4).tolist()} m "
            line = ""
            if args.linear:
                v, w = plan.extra["tcp_speed_peak"], plan.extra["tcp_angular_speed_peak"]
                assert isinstance(v, float) and isinstance(w, float)  # plan_line's figures
                line = (f"straight line, peak tool speed {v:.4f} m/s, "
                        f"{math.degrees(w):.2f} deg/s")
            head = (f"arm {robot.arm.name}: goal {where}"
                    f"({type(goal).__name__}"
                    + (f", relative to the present pose in the {axes.value} frame"
                       if axes is not None else "") + "); "
                    + (f"IK solver {ik.solver} ({ik.iterations} iterations, "
                       f"{ik.position_error * 1000:.3f} mm)" if ik else line))
            if not args.json:
                print(plan_text(robot, plan, head), flush=True)
            return not args.dry_run

        return robot.move_to_pose(goal, linear=args.linear, speed=args.speed,
                                  solver=args.solver, on_cycle=progress, on_plan=show,
                                  tcp_speed=tcp_speed, tcp_angular_speed=tcp_angular_speed,
                                  detour=detour)

    robot, report = run_motion(args, go, arm)
    data: dict[str, Any] = {"plan": plan_data(robot, report.plan),
                            "solver": report.ik.solver if report.ik else None}
    if args.linear:
        data.update(tcp_speed_peak=report.plan.extra.get("tcp_speed_peak"),
                    tcp_angular_speed_peak=report.plan.extra.get("tcp_angular_speed_peak"),
                    tcp_speed=tcp_speed, tcp_angular_speed=tcp_angular_speed)
    if axes is not None and relative:
        data["relative"] = {"frame": axes.value, "from_xyz": relative["from_xyz"],
                            "goal_xyz": relative["goal"].target_position,
                            "goal_kind": type(relative["goal"]).__name__}
    idle = "already at the goal; nothing to do" if nothing_to_do(report.plan) else None
    sdata, stext = stream_text(robot, report, idle)
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
    _check_servo_arm(arm)
    q = parse_angles(args.values, args.deg, arm, "move-joints values")
    _check_values(arm, q, args.deg)
    _checks.check_speed_arg(args, arm)
    return joint_command(args, arm, lambda robot: q, "move to joint values",
                          "already at these joint values; nothing to do")

def cmd_named(args: argparse.Namespace) -> int:
    """``armctl home`` and ``armctl park``."""
    from armctl.cli import _checks

    arm = load_arm_arg(args)
    _check_servo_arm(arm)
    _checks.check_named_pose(arm, args.pose)
    _checks.check_speed_arg(args, arm)
    return joint_command(args, arm, lambda robot: robot.arm.named_pose(args.pose),
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

def joint_command(args: argparse.Namespace, arm: Arm, target: Any, what: str, idle: str,
                  extra: Any = None) -> int:
    """Open the robot, plan a joint move to ``target(robot)``, run it and report.

    Args:
        args: The command's arguments.
        arm: The arm (as loaded; ``--port``/``--sim`` choose its bus).
        target: ``target(robot)``: the goal joint vector ``(dof,)`` [rad]/[m].
        what: The plan's description.
        idle: The message when the arm is already there.
        extra: ``extra(robot, plan)``: more JSON fields (a dict), or ``None``.
    """
    from armctl.cli._motion_report import plan_data, plan_text, reached_joints, stream_text
    from armctl.cli._motion_run import nothing_to_do, one_tick, run_motion

    still: list[bool] = []
    detour = detour_options(args)  # --plan, --plan-time: checked before the bus opens

    def go(robot: Robot, progress: Progress) -> MoveReport:
        from armctl.robot import MoveReport

        plan = robot.plan_joints(target(robot), args.speed, what, detour=detour)
        if nothing_to_do(plan, still=one_tick(robot)):  # a servo cannot get any closer
            still.append(True)
            if not args.json:  # before what the exit policy says
                print(idle, flush=True)
            return MoveReport(plan)
        if not args.json:
            print(plan_text(robot, plan, f"arm {robot.arm.name}"), flush=True)
        if args.dry_run:
            return MoveReport(plan)
        res = robot.execute(plan, progress)
        return MoveReport(plan, res, reached=robot.arm.fk(res.final))

    robot, report = run_motion(args, go, arm)
    data: dict[str, Any] = {"plan": plan_data(robot, report.plan)}
    if extra is not None:
        data.update(extra(robot, report.plan))
    if still:
        data.update(moved=False, nothing_to_do=True)
        if args.json:
            emit(args, data, idle)
        return 0
    sdata, text = stream_text(robot, report)
    data.update(sdata)
    if report.result is not None and report.reached is not None:
        rdata, rtext = reached_joints(robot, report.plan.goal, report.result.final,
                                       report.reached)
        data.update(rdata)
        text += "\n" + rtext
    emit(args, data, text)
    return 0
