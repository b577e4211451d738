"""``move-to-pose --relative``: a goal given as an offset from the present pose of the tool.

``--relative base`` (the default) takes ``--xyz`` as a translation along the base frame's axes
and ``--rpy`` as a rotation about the base frame's axes through the tool point; ``--relative
tool`` takes both in the tool frame's own axes (``--rpy 0 0 30 --deg``: turn the tool 30 deg
about its own z). The present pose is FK of the joints read from the bus.
"""

from __future__ import annotations

import argparse
import math
from enum import Enum
from typing import TYPE_CHECKING

from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.ik import Goal
    from armctl.typing import Array

__all__ = ["OffsetFrame", "check_relative_args", "relative_goal", "tcp_speeds"]

#: A TCP angular speed beyond this [rad/s] without ``--deg`` can only be meant in degrees.
_TURN_PER_S = 2.0 * math.pi

#: A TCP speed beyond this [m/s] can only be meant in millimetres per second (no serial-bus
#: arm's tool comes near it).
_MAX_TCP_SPEED = 10.0


class OffsetFrame(Enum):
    """The axes a relative offset is given in."""

    BASE = "base"
    TOOL = "tool"


def check_relative_args(args: argparse.Namespace, arm: Arm) -> OffsetFrame:
    """Refuse what a relative move cannot take; the frame of the offset.

    Raises:
        InputError: ``--quat`` or another goal type's flags (a relative move takes ``--xyz``
            and ``--rpy`` only), neither ``--xyz`` nor ``--rpy``, or ``--frame`` naming the
            offset's axes instead of a frame of the arm.
    """
    from armctl.ik import goal_classes

    if args.quat is not None:
        raise InputError("--relative takes the rotation offset as --rpy R P Y (about the base "
                         "or tool axes), not --quat")
    others = [a.flag for c in goal_classes() for a in c.cli_arguments
              if getattr(args, a.dest, None) is not None]
    if others:
        raise InputError(f"--relative takes --xyz and --rpy offsets only, not {', '.join(others)}"
                         "; give an absolute goal without --relative")
    if args.xyz is None and args.rpy is None:
        raise InputError("--relative needs an offset: --xyz DX DY DZ [m] and/or --rpy R P Y "
                         "(e.g. up 5 cm: --relative --xyz 0 0 0.05)")
    if args.frame is not None and args.frame not in arm.frame_names and \
            args.frame in {f.value for f in OffsetFrame}:
        raise InputError(f"--frame names the arm's frame that moves (default: the tool "
                         f"{arm.tool!r}); the axes of a relative offset are chosen with "
                         f"--relative {args.frame}")
    if args.frame is not None:
        arm.frame_index(args.frame)  # an unknown frame: the error lists the arm's frames
    return OffsetFrame(args.relative)


def relative_goal(arm: Arm, present: Array, args: argparse.Namespace, axes: OffsetFrame
                  ) -> Goal:
    """The absolute goal of a relative move from the frame's present pose ``(4, 4)``.

    A pure translation keeps the present orientation when six or more joints move the frame
    (a pose goal), else it is a position goal (a 5-DOF arm cannot keep every orientation while
    it translates). With ``--rpy`` the goal is a pose.

    Raises:
        InputError: ``--rpy`` values that can only be degrees without ``--deg``.
    """
    import numpy as np

    from armctl.cli._common import check_rpy
    from armctl.ik import PoseGoal, PositionGoal, Tolerance
    from armctl.spatial import rpy_to_matrix

    check_rpy(args.rpy, args.deg)
    d = np.zeros(3) if args.xyz is None else np.asarray(args.xyz, dtype=float)
    rot = np.eye(3)
    if args.rpy is not None:
        rot = rpy_to_matrix(np.radians(args.rpy) if args.deg else np.asarray(args.rpy, float))
    pose = np.array(present, dtype=float)
    r0, p0 = pose[:3, :3], pose[:3, 3]
    if axes is OffsetFrame.TOOL:
        pose[:3, 3] = p0 + r0 @ d
        pose[:3, :3] = r0 @ rot
    else:
        pose[:3, 3] = p0 + d
        pose[:3, :3] = rot @ r0
    tol = Tolerance(args.tol_pos, args.tol_rot)
    frame = args.frame
    if args.rpy is None and len(arm.chain(frame)) < 6:
        return PositionGoal(pose[:3, 3], frame=frame, tolerance=tol)
    return PoseGoal(pose, frame=frame, tolerance=tol)


def tcp_speeds(args: argparse.Namespace) -> tuple[float | None, float | None]:
    """``--tcp-speed`` [m/s] and ``--tcp-angular-speed`` [rad/s] (degrees with ``--deg``).

    Raises:
        InputError: Either without ``--linear``, a linear speed above 10 m/s (it can only be
            millimetres per second), or an angular speed beyond a turn per second without
            ``--deg`` (it can only be degrees per second).
    """
    v, w = args.tcp_speed, args.tcp_angular_speed
    if (v is not None or w is not None) and not args.linear:
        flag = "--tcp-speed" if v is not None else "--tcp-angular-speed"
        raise InputError(f"{flag} applies to straight-line moves: add --linear (a joint-space "
                         "move is timed by --speed, a factor of the joint limits)")
    if v is not None and v > _MAX_TCP_SPEED:
        raise InputError(f"--tcp-speed {v:g} m/s is more than {_MAX_TCP_SPEED:g} m/s, so it can "
                         f"only be millimetres per second: did you mean --tcp-speed "
                         f"{v / 1000:g} ({v:g} mm/s)? The value is in metres per second")
    if w is not None:
        if args.deg:
            w = math.radians(w)
        elif w > _TURN_PER_S + 1e-9:
            raise InputError(f"--tcp-angular-speed {w:g} rad/s is more than a full turn per "
                             "second (2 pi = 6.283 rad/s), so it can only be degrees per "
                             "second: did you mean --deg?")
    return v, w
