"""The play command: plan a keyframe program whole, then play it."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from armctl.cli._bus_choice import add_bus_choice
from armctl.cli._common import (
    add_config,
    add_json,
    add_log_option,
    emit,
    finite,
    is_keyframe_file,
    load_arm_arg,
    positive_int,
)
from armctl.cli._progress import Progress
from armctl.cli._scene import add_scene_option
from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.robot import MoveReport, Robot

ORDER = 42


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the play command."""
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
    add_bus_choice(p)  # --port PORT | --sim
    add_log_option(p)  # --log FILE.csv
    add_scene_option(p)  # --scene FILE
    add_json(p)
    p.set_defaults(func=cmd_play, stop_signals=True)


def cmd_play(args: argparse.Namespace) -> int:
    """``armctl play``."""
    from dataclasses import replace

    from armctl.cli import _checks
    from armctl.cli._motion_report import plan_data, plan_text, stream_text
    from armctl.cli._motion_run import nothing_to_do, run_motion
    from armctl.cli._preview import write_preview
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

    def go(robot: Robot, progress: Progress) -> MoveReport:
        from armctl.robot import MoveReport

        cal = robot.calibration_hash()
        if program.calibration and cal and program.calibration != cal:
            print(f"armctl: warning: the keyframes were taught with calibration "
                  f"{program.calibration}, the arm now uses {cal}", file=sys.stderr)
        plan = robot.plan_program(program, options, args.solver)
        if nothing_to_do(plan, endpoints=False):
            return MoveReport(plan)
        if not args.json:
            print(plan_text(robot, plan, f"arm {robot.arm.name}: play {args.file}"), flush=True)
        if args.preview:
            write_preview(robot, plan, args.preview)
        if args.dry_run:
            return MoveReport(plan)
        res = robot.execute(plan, progress)
        return MoveReport(plan, res, reached=robot.arm.fk(res.final))

    robot, report = run_motion(args, go, arm)
    data: dict[str, Any] = {"plan": plan_data(robot, report.plan),
                            "keyframes": [{"name": w.name, "time": w.time}
                                          for w in report.plan.waypoints],
                            "events": [{"time": e.time, "kind": e.kind, "name": e.name,
                                        "value": e.value} for e in report.plan.events]}
    idle = ("the program does not move the arm; nothing to do"
            if nothing_to_do(report.plan, endpoints=False) else None)
    sdata, text = stream_text(robot, report, idle)
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
