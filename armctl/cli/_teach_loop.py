"""The interactive loop of ``armctl teach``: typed commands, one a line, run on a session."""

from __future__ import annotations

import math
import sys
from typing import TYPE_CHECKING, Any

import numpy as np

from armctl.config.schema import JointType
from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.robot import Robot

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

def teach_loop(session: Any, robot: Robot, say: Any, complain: Any) -> None:
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
