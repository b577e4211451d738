"""The teach command: record keyframes by hand-guiding or jogging."""

from __future__ import annotations

import argparse
import sys

from armctl.cli._bus_choice import add_bus_choice
from armctl.cli._checks import check_servo_arm as _check_servo_arm
from armctl.cli._common import add_config, add_json, add_log_option, emit, load_arm_arg
from armctl.cli._scene import add_scene_option

ORDER = 41


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the teach command."""
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
    add_bus_choice(p)  # --port PORT | --sim
    add_scene_option(p)  # --scene FILE
    add_log_option(p)  # --log FILE.csv: every jog of the session
    add_json(p)
    p.set_defaults(func=cmd_teach)


def cmd_teach(args: argparse.Namespace) -> int:
    """``armctl teach``: an interactive, line-based teach session."""
    from pathlib import Path

    from armctl.cli import _checks
    from armctl.cli._motion_run import _CycleRecorder, open_robot
    from armctl.cli._teach_loop import TEACH_HELP, teach_loop
    from armctl.motion import AngleUnit
    from armctl.robot.teach import ExistingFile, TeachSession

    arm = load_arm_arg(args)
    _check_servo_arm(arm)
    _checks.check_teach_output(args, arm)
    existing = (ExistingFile.APPEND if args.append else
                ExistingFile.OVERWRITE if args.force else ExistingFile.REFUSE)
    if args.log is not None:
        from armctl.robot.motion_log import check_log_target

        check_log_target(args.log)  # before the bus opens
    robot = open_robot(args, arm, hold=True)  # the stiff joints (grippers) hold from the start
    # --log: the cycles of every move the session makes (the jogs), on one time axis
    recorder = _CycleRecorder(robot, args.log) if args.log is not None else None
    ended = False
    try:
        session = TeachSession(robot, args.output, args.release,
                               AngleUnit.DEG if args.deg else AngleUnit.RAD, existing=existing)
        session.start(limp=not args.stiff)
        say = (lambda s: None) if args.json else (lambda s: print(s, flush=True))
        say(f"teaching {robot.arm.name} into {args.output}; torque off for: "
            f"{', '.join(session.release) if session.limp else '(none)'}\n"
            "  warning: released joints fall under gravity; support the arm\n" + TEACH_HELP)
        try:
            teach_loop(session, robot, say, say if not args.json else (
                lambda s: print(f"armctl: {s}", file=sys.stderr, flush=True)))
        except KeyboardInterrupt:
            say("\ninterrupted: keeping what was recorded")
        finally:
            session.finish()
        ended = True
    finally:
        try:
            if recorder is not None and ended:
                recorder.write(quiet=args.json)
            elif recorder is not None:  # what ran before the failure; never masks it
                recorder.write_after_failure()
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
