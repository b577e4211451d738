"""Checks of a motion command's arguments that run before the bus opens.

Everything that can be refused without the arm (numbers, speed factors, names, files, output
paths, goals beyond the arm's reach, values outside the config's limits) is refused here, so a
mistake never opens the port or switches torque on.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from armctl.errors import InputError, NoSolutionError

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.ik import Goal
    from armctl.motion import KeyframeProgram, PlaybackOptions

__all__ = ["check_deg_applies", "check_goal_reach", "check_keyframe_path", "check_named_pose",
           "check_park_pose", "check_play", "check_solver", "check_speed_arg",
           "check_teach_output"]


def check_speed_arg(args: argparse.Namespace, arm: Arm) -> None:
    """Refuse a ``--speed`` of a move timed by the joint limits outside 0.01 to 1.

    Without ``--speed`` the config's ``motion.speed`` (capped at 1) is checked.

    Raises:
        InputError: Saying the valid range.
    """
    from armctl.motion import check_speed

    if getattr(args, "speed", None) is not None:
        check_speed(args.speed)
    elif arm.spec.motion is not None:
        check_speed(min(arm.spec.motion.speed, 1.0), what="the arm config's motion.speed")


def check_deg_applies(args: argparse.Namespace) -> None:
    """Refuse ``--deg`` on a ``move-to-pose`` that has no angle to read in degrees.

    ``--deg`` applies to ``--rpy`` and ``--tcp-angular-speed``; positions and offsets are in
    metres whatever it says, so on a move without either it would be silently ignored.

    Raises:
        InputError: Saying what ``--deg`` applies to and that ``--xyz`` is in metres.
    """
    if not args.deg or args.rpy is not None or args.tcp_angular_speed is not None:
        return
    raise InputError("--deg: this move has no angle (--deg applies to --rpy and "
                     "--tcp-angular-speed; --xyz is in metres with or without it): drop --deg")


def check_solver(name: str) -> None:
    """Refuse an IK solver name that is not registered.

    Raises:
        UnknownNameError: Listing the solvers, the nearest first.
    """
    from armctl.errors import UnknownNameError
    from armctl.ik.registry import available_solvers

    if name not in available_solvers():
        raise UnknownNameError("IK solver", name, available_solvers())


def check_goal_reach(arm: Arm, goal: Goal, solver: str = "auto") -> None:
    """Refuse a goal farther from the arm's first joint than the arm can reach (exit code 3).

    Only this bound decides before the bus opens: whether IK finds a solution can depend on the
    start (the present pose), which the bus gives. For the report, IK then finds the closest
    configuration from the middle of the joint ranges.

    Raises:
        IKFailedError: Giving the distance, the reach and the closest configuration found
            (``details`` as for a goal found unreachable after the bus opened).
    """
    from armctl.cli.ik import reach_hint
    from armctl.robot.unreachable import unreachable

    hint = reach_hint(arm, goal)
    if not hint:
        return
    raise unreachable(arm, goal, arm.ik(goal, solver=solver), hint, bus_opened=False)


def check_keyframe_path(path: str) -> None:
    """Refuse an arm (a bundled name or a URDF) given where a keyframe file belongs.

    Raises:
        InputError: Saying what was given and where the keyframe file goes.
    """
    from pathlib import Path

    from armctl.config import bundled_configs

    p = Path(path)
    if not p.exists() and path in bundled_configs():
        raise InputError(f"{path!r} is the name of a bundled arm, not a keyframe file: give the "
                         "keyframe file there (written by 'armctl teach'); the arm is CONFIG")
    if p.suffix.lower() == ".urdf":
        raise InputError(f"{path} is a URDF (an arm model), not a keyframe file: give the "
                         "keyframe file there (written by 'armctl teach'); the arm is CONFIG")


def check_servo_arm(arm: Arm) -> None:
    """Refuse, before anything else, a motion command for an arm no servo can drive.

    Raises:
        InputError: For an arm with ball or universal joints (no servos, no simulated bus),
            saying how to draw its motions instead.
    """
    if arm.multi_dof_joints:
        raise InputError(f"arm {arm.name!r} cannot be moved by servos: "
                         f"{arm.spec.no_bus_fix()}")


def check_named_pose(arm: Arm, name: str) -> None:
    """Refuse a named pose that the config lacks or that lies outside the config's limits.

    Raises:
        UnknownNameError: For a pose the config does not define.
        JointLimitError: For a pose value outside its joint's limits.
    """
    arm.check_limits(arm.named_pose(name), f"the config's {name!r} pose")


def check_park_pose(arm: Arm) -> None:
    """Refuse ``--exit-policy park`` for an arm without a 'park' pose inside the config's limits.

    Raises:
        InputError: The config defines no 'park' pose (saying how to add one).
        JointLimitError: A value of the pose outside its joint's limits.
    """
    if "park" not in arm.spec.poses:
        known = ", ".join(arm.spec.poses) or "none"
        raise InputError(f"--exit-policy park: arm {arm.name!r} has no 'park' pose (poses: "
                         f"{known}); add one under 'poses:' in the arm config, or use "
                         "--exit-policy hold or release")
    check_named_pose(arm, "park")


def check_play(args: argparse.Namespace, arm: Arm, program: KeyframeProgram,
               options: PlaybackOptions) -> None:
    """Refuse what ``armctl play`` can refuse before the bus opens.

    The speed factor must suit how the program is timed, the joint and gripper values must lie
    inside the config's limits, the IK solver must exist and pose keyframes must lie within the
    arm's reach, and a ``--preview`` file must be writable with a known image type.

    Raises:
        InputError: For any of these (ConfigError, with file and line, for keyframe values).
        NoSolutionError: For a pose keyframe beyond the arm's reach.
    """
    from armctl.motion.playback import check_keyframe_values, check_playback_speed

    check_playback_speed(program, options)
    check_keyframe_values(program, arm)
    if any(kf.pose is not None for kf in program.keyframes):
        check_solver(args.solver)
    from armctl.cli.ik import reach_hint
    from armctl.ik import PositionGoal

    for k, kf in enumerate(program.keyframes):
        if kf.pose is None:
            continue
        hint = reach_hint(arm, PositionGoal(kf.pose[:3, 3], frame=program.frame or None))
        if hint:
            raise NoSolutionError(f"keyframe {k} ({kf.label}, {kf.where.where()}): the pose "
                                  f"cannot be reached: {hint}; nothing was moved (the bus was "
                                  "not opened)")
    if args.preview:
        from armctl.render.plots import check_output

        check_output(args.preview)


def check_teach_output(args: argparse.Namespace, arm: Arm) -> None:
    """Refuse a teach output file that would be overwritten or cannot be appended to.

    Raises:
        InputError: For an existing file without ``--force`` or ``--append``, an arm config as
            the output, a missing folder; with ``--append``, a file of another arm (ConfigError).
    """
    from armctl.robot.teach import ExistingFile, appendable, check_output, load_for_append

    existing = (ExistingFile.APPEND if args.append else
                ExistingFile.OVERWRITE if args.force else ExistingFile.REFUSE)
    path = check_output(args.output, existing)
    if existing is ExistingFile.APPEND and path.exists():
        appendable(load_for_append(path, arm), arm, path)  # the calibration: once the bus is open
    if args.release:
        for name in args.release:
            arm.joint_index(name)

