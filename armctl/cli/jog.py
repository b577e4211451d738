"""The jog command: move the arm with single keypresses, one checked step per key."""

from __future__ import annotations

import argparse
import sys

from armctl.cli._bus_choice import add_bus_choice
from armctl.cli._checks import check_servo_arm as _check_servo_arm
from armctl.cli._common import add_config, add_json, emit, finite, load_arm_arg
from armctl.cli._scene import add_scene_option
from armctl.errors import InputError

ORDER = 43


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the jog command."""
    p = sub.add_parser(
        "jog", help="jog the arm with single keys (joints, base or tool frame); record keyframes",
        description="Single keypresses in a terminal (no Enter): each jog key is one small step "
                    "of a joint, or a straight-line move of the tool along or about an axis of "
                    "the base or the tool frame, checked like every motion (effective limits, "
                    "contacts, velocity, acceleration and jerk limits); a refused step moves "
                    "nothing and the status line says why. Press ? in jog for the keys "
                    "(docs/cli.md lists them).")
    add_config(p)
    p.add_argument("-o", "--output", default=None, metavar="FILE",
                   help="keyframe file to record into (the format 'armctl teach' writes and "
                        "'armctl play' replays)")
    existing = p.add_mutually_exclusive_group()
    existing.add_argument("--force", action="store_true",
                          help="overwrite an existing keyframe file")
    existing.add_argument("--append", action="store_true",
                          help="add to an existing keyframe file (same arm; its units are kept)")
    p.add_argument("--deg", action="store_true",
                   help="write the keyframes' angles in degrees")
    p.add_argument("--speed", type=finite, default=None,
                   help="speed factor of the joint limits for every step, 0.01 to 1 (default: "
                        "0.3, or the config's motion.speed if lower); , and . change it")
    p.add_argument("--deg-steps", type=finite, nargs="+", default=None, metavar="DEG",
                   help="the rotary step sizes to choose from with [ and ] [deg] (default 1 5 "
                        "10); the first is used at the start")
    p.add_argument("--mm-steps", type=finite, nargs="+", default=None, metavar="MM",
                   help="the linear step sizes [mm], as many as --deg-steps (default 1 5 20)")
    p.add_argument("--exit-policy", choices=["hold", "park", "release"], default=None,
                   help="what to do when jog ends with the quit key (default: hold); Ctrl-C "
                        "and a stopped step always hold where the arm is")
    add_bus_choice(p)  # --port PORT | --sim
    add_scene_option(p)  # --scene FILE
    add_json(p)
    p.set_defaults(func=cmd_jog, stop_signals=True)


def _steps(args: argparse.Namespace) -> object:
    """The step sizes of ``--deg-steps`` and ``--mm-steps`` in SI."""
    import math

    from armctl.robot.jog import JogSteps

    default = JogSteps()
    rotary = (tuple(math.radians(v) for v in args.deg_steps) if args.deg_steps is not None
              else default.rotary)
    linear = (tuple(v / 1000 for v in args.mm_steps) if args.mm_steps is not None
              else default.linear)
    if args.deg_steps is not None and args.mm_steps is None and len(rotary) != len(linear):
        raise InputError(f"--deg-steps gives {len(rotary)} steps: give as many --mm-steps too")
    if args.mm_steps is not None and args.deg_steps is None and len(rotary) != len(linear):
        raise InputError(f"--mm-steps gives {len(linear)} steps: give as many --deg-steps too")
    return JogSteps(rotary, linear)


def cmd_jog(args: argparse.Namespace) -> int:
    """``armctl jog``: an interactive jog session on single keys."""
    import signal

    from armctl.cli import _checks
    from armctl.cli._jog_loop import JogEnd, StatusLine, final_state, jog_loop
    from armctl.cli._keys import KeyReader
    from armctl.cli._motion_run import close_with_policy, open_robot
    from armctl.motion import AngleUnit, check_speed
    from armctl.robot.jog import Jogger, JogSteps
    from armctl.robot.teach import ExistingFile, TeachSession

    arm = load_arm_arg(args)
    _check_servo_arm(arm)
    steps = _steps(args)
    assert isinstance(steps, JogSteps)
    _checks.check_speed_arg(args, arm)
    speed = args.speed if args.speed is not None else min(
        0.3, arm.spec.motion.speed if arm.spec.motion is not None else 0.3)
    check_speed(speed)
    existing = (ExistingFile.APPEND if args.append else
                ExistingFile.OVERWRITE if args.force else ExistingFile.REFUSE)
    if args.output is None and (args.append or args.force or args.deg):
        flag = "--append" if args.append else "--force" if args.force else "--deg"
        raise InputError(f"{flag} applies to the keyframe file: give it with -o FILE")
    if args.output is not None:
        _checks.check_teach_output(argparse.Namespace(
            output=args.output, append=args.append, force=args.force, release=None), arm)
    reader = KeyReader()  # after the arguments: a bad one is named even without a terminal
    if not reader.active:
        raise InputError("armctl jog needs a terminal: it reads single keypresses, and its "
                         "standard input is not a terminal. Run it in a terminal; to move "
                         "from a script use move-joints, move-to-pose --relative or gripper, and "
                         "to record keyframes from typed lines use 'armctl teach --stiff'")
    guard = getattr(args, "signal_guard", None)
    robot = open_robot(args, arm, hold=True)
    session = None
    end = JogEnd.QUIT
    interrupted: int | None = None  # a stop signal before anything moved
    screen = StatusLine(sys.stderr if args.json else sys.stdout)
    try:
        if args.output is not None:
            session = TeachSession(robot, args.output, None,
                                   AngleUnit.DEG if args.deg else AngleUnit.RAD,
                                   existing=existing)
        jogger = Jogger(robot, steps, speed, session)
        where = f"; keyframes into {args.output}" if args.output else ""
        screen.say(f"jogging {robot.arm.name}{where}; press ? for the keys, q to quit")
        with reader:
            try:
                end = jog_loop(jogger, reader, screen, guard)
            except KeyboardInterrupt as exc:  # a stop signal before anything had moved
                end = JogEnd.SIGNAL
                interrupted = int(getattr(exc, "signum", signal.SIGINT))
            finally:
                screen.close()
        data = final_state(jogger)
        if session is not None:
            session.finish()  # torque stays on, holding; an empty file it wrote is removed
    except BaseException:
        robot.close_holding("jog ended with an error")
        raise
    if end is JogEnd.SIGNAL or (guard is not None and guard.signalled):
        robot.close_holding("a stop signal ended jog")
    else:
        close_with_policy(robot)
    data.update({"file": args.output, "ended": end.value,
                 "written": session.written if session is not None else False})
    if end is JogEnd.SIGNAL or (guard is not None and guard.signalled):
        data["ok"] = False  # ended by a stop signal: the command exits 5 (or 128 + N)
    n = data["keyframes"]
    text = (f"{data['steps']} steps, {data['refused']} refused"
            + (f"; {n} keyframes in {args.output}" if args.output else "")
            + ("; holding where the arm is" if end is JogEnd.SIGNAL else ""))
    emit(args, data, text)
    if interrupted is not None:
        print(f"armctl: interrupted by {signal.Signals(interrupted).name}; nothing moved",
              file=sys.stderr)
        return 128 + interrupted
    return 0
