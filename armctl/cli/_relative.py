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
            and ``--rpy`` only), neither ``--xyz`` nor ``--rpy``, ``--frame`` naming the
            offset's axes instead of a frame of the arm, ``--rpy`` values that can only be
            degrees without ``--deg``, or an offset longer than twice the arm's reach
            (millimetres meant).
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
    from armctl.cli._common import check_rpy

    check_rpy(args.rpy, args.deg)
    axes = OffsetFrame(args.relative)
    _check_offset_length(args, arm)
    return axes


def _check_offset_length(args: argparse.Namespace, arm: Arm) -> None:
    """Refuse an ``--xyz`` offset longer than any move of the frame (twice its reach).

    Raises:
        InputError: Saying the arm's reach, with the offset in metres when the values, read as
            millimetres, fit.
    """
    import numpy as np

    if args.xyz is None:
        return
    d = np.asarray(args.xyz, dtype=float)
    length = float(np.linalg.norm(d))
    most = 2.0 * arm.reach(args.frame, from_first_joint=True)
    if length <= most:
        return
    given = " ".join(f"{v:g}" for v in d)
    fix = (f"the offset is in metres: did you mean --xyz {' '.join(f'{v / 1000:g}' for v in d)} "
           f"({given} mm)?" if length / 1000 <= most else "give the offset in metres")
    raise InputError(f"--relative --xyz {given}: an offset of {length:g} m is longer than any "
                     f"move of arm {arm.name!r} ({most:.2f} m, twice its reach of "
                     f"{most / 2:.2f} m); {fix}")


def _check_turn(arm: Arm, q: Array, present: Array, rot: Array, args: argparse.Namespace,
                axes: OffsetFrame) -> None:
    """Refuse a rotation offset that the frame's joints cannot make in place at ``q``.

    With fewer than 6 joints a frame cannot turn about every axis while its origin stays put:
    at a given pose the axes it can turn about form a plane (5 joints), a line (4) or nothing
    (:func:`armctl.robot.jog.turnable_axes`, from the Jacobian). A rotation about an axis
    outside them is refused here, before anything is planned; so is a turn about an axis inside
    them that IK from ``q`` cannot make in place by the whole angle (to first order is not
    enough for a large turn). The message names the axes of the offset's frame about which IK
    makes a turn of the same angle from the present pose.

    Args:
        arm: The arm.
        q: The present joint values [rad]/[m].
        present: The frame's present pose ``(4, 4)``.
        rot: The rotation offset ``(3, 3)`` (in the offset frame's axes).
        args: The command's arguments (``--frame``).
        axes: The axes the offset is given in.

    Raises:
        InputError: An axis the joints cannot turn about at all here, saying how many joints
            move the frame, about which axes it can turn by that angle and what to do instead.
        NoSolutionError: An axis they turn about only for smaller angles, likewise.
    """
    import numpy as np

    from armctl.robot.jog import TURN_RESIDUAL, turnable_axes

    chain = arm.chain(args.frame)
    if len(chain) >= 6:
        return
    about = np.array([rot[2, 1] - rot[1, 2], rot[0, 2] - rot[2, 0], rot[1, 0] - rot[0, 1]])
    angle = math.atan2(float(np.linalg.norm(about)) / 2.0, (float(np.trace(rot)) - 1.0) / 2.0)
    if angle <= 1e-9:
        return
    if float(np.linalg.norm(about)) < 1e-9:  # a half turn: the axis from the symmetric part
        w, v = np.linalg.eigh(rot + np.eye(3))
        about = v[:, int(np.argmax(w))]
    from armctl.errors import NoSolutionError
    from armctl.ik import PoseGoal, Tolerance
    from armctl.spatial import axis_angle_to_matrix

    r0 = present[:3, :3]
    frame_axes = r0.T if axes is OffsetFrame.TOOL else np.eye(3)  # rows, base coordinates
    unit = about / float(np.linalg.norm(about))
    axis = r0 @ unit if axes is OffsetFrame.TOOL else unit
    off = turnable_axes(arm, q, np.vstack([axis, frame_axes]), args.frame)
    tol = Tolerance(args.tol_pos, args.tol_rot)

    def turns(about_base: Array) -> bool:
        """Whether IK from ``q`` turns the frame by ``angle`` about the axis, in place."""
        goal = np.array(present, dtype=float)
        goal[:3, :3] = axis_angle_to_matrix(about_base, angle) @ r0
        return arm.ik(PoseGoal(goal, frame=args.frame, tolerance=tol), q0=q,
                      solver=args.solver).success

    first_order = off[0] <= TURN_RESIDUAL
    if first_order and turns(axis):
        return
    tool = args.frame in (None, arm.tool)
    who, point = ("its tool", "the tool point") if tool else (
        f"frame {args.frame!r}", "the frame's origin")
    deg = math.degrees(angle)
    can = [f"{axes.value} {'xyz'[i]}" for i in range(3)
           if off[1 + i] <= TURN_RESIDUAL and turns(frame_axes[i])]
    here = (f"from the present pose it can turn {deg:.3g} deg about " + " and ".join(can)
            if can else f"from the present pose it can turn {deg:.3g} deg about no axis of the "
            f"{axes.value} frame")
    shown = np.round(unit, 3).tolist()
    instead = ("move single joints ('armctl jog', 'armctl move-joints'), give an absolute goal "
               "with --xyz and --direction AXIS DX DY DZ, or add --force-pose to try anyway")
    details = {"joints": len(chain), "axis": shown, "turnable": can}
    if not first_order:
        raise InputError(
            f"--relative {axes.value} --rpy: arm {arm.name!r} moves {who} with {len(chain)} "
            f"joints, too few to turn it about any axis while holding {point} in place; the "
            f"rotation asked for is about {shown} in the {axes.value} frame, which its joints "
            f"cannot turn about at the present pose at all, and {here}. Turn about one of "
            f"those, {instead}", details)
    raise NoSolutionError(
        f"--relative {axes.value} --rpy: arm {arm.name!r} moves {who} with {len(chain)} joints: "
        f"at the present pose they turn it about {shown} in the {axes.value} frame only for "
        f"small angles, and a turn of {deg:.3g} deg cannot hold {point} within "
        f"{args.tol_pos * 1000:g} mm (--tol-pos); nothing was moved. Turn in smaller steps, "
        + (f"{here}, " if can else "") + f"or {instead}", details)


def relative_goal(arm: Arm, q: Array, args: argparse.Namespace, axes: OffsetFrame) -> Goal:
    """The absolute goal of a relative move from the frame's pose at the present joints ``q``.

    A pure translation keeps the present orientation when six or more joints move the frame
    (a pose goal), else it is a position goal (a 5-DOF arm cannot keep every orientation while
    it translates). With ``--rpy`` the goal is a pose.

    Raises:
        InputError: ``--rpy`` values that can only be degrees without ``--deg``; (without
            ``--force-pose``) a rotation about an axis that fewer than 6 joints cannot turn
            about in place at ``q``.
        NoSolutionError: (without ``--force-pose``) a rotation that fewer than 6 joints make
            in place only for smaller angles.
    """
    import numpy as np

    from armctl.cli._common import check_rpy
    from armctl.ik import PoseGoal, PositionGoal, Tolerance
    from armctl.spatial import rpy_to_matrix

    check_rpy(args.rpy, args.deg)  # checked before the bus opens too (check_relative_args)
    d = np.zeros(3) if args.xyz is None else np.asarray(args.xyz, dtype=float)
    rot = np.eye(3)
    if args.rpy is not None:
        rot = rpy_to_matrix(np.radians(args.rpy) if args.deg else np.asarray(args.rpy, float))
    pose = arm.fk(q, args.frame)
    if args.rpy is not None and not getattr(args, "force_pose", False):
        _check_turn(arm, q, pose, rot, args, axes)
    r0, p0 = pose[:3, :3].copy(), pose[:3, 3].copy()
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
