"""The gripper command: open, close, or move the gripper joint(s) to a value.

A gripper joint is one with ``role: gripper`` in the arm config. Its lower limit is the closed
jaw and its upper limit the open jaw (the convention of the bundled configs, see docs/cli.md);
``open`` and ``close`` go to those ends of the *effective* limits (config, calibration and
servo registers), every other joint holds where it is.
"""

from __future__ import annotations

import argparse
import math
from typing import TYPE_CHECKING, Any

from armctl.cli._checks import check_servo_arm as _check_servo_arm
from armctl.cli._common import add_config, add_json, load_arm_arg
from armctl.cli.move import add_move_options
from armctl.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from armctl.arm import Arm
    from armctl.motion import MotionPlan
    from armctl.robot import Robot

ORDER = 43

#: The words GOAL may be instead of a value.
OPEN, CLOSE = "open", "close"


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the gripper command."""
    p = sub.add_parser(
        "gripper", help="open or close the gripper, or move it to a value",
        description="Move only the gripper joint(s) (role: gripper in the config): 'open' to "
                    "the upper end of its effective limits, 'close' to the lower end, or VALUE "
                    "in the joint's unit ([rad] for a rotary jaw, [m] for a prismatic finger; "
                    "--deg or --mm to give it in degrees or millimetres). The other joints hold "
                    "where they are.")
    add_config(p)
    p.add_argument("goal", metavar="open|close|VALUE",
                   help="'open', 'close', or a joint value [rad] or [m]")
    units = p.add_mutually_exclusive_group()
    units.add_argument("--deg", action="store_true", help="VALUE in degrees (rotary gripper)")
    units.add_argument("--mm", action="store_true",
                       help="VALUE in millimetres (prismatic gripper)")
    add_move_options(p)  # --speed, --dry-run, --exit-policy, --port | --sim, --log
    add_json(p)
    p.set_defaults(func=cmd_gripper)


def gripper_indices(arm: Arm) -> list[int]:
    """Joint-vector indices of the arm's gripper joints (``role: gripper``).

    Raises:
        InputError: For an arm without a gripper joint.
    """
    from armctl.config.schema import JointRole

    idx = [i for i, r in enumerate(arm.joint_roles) if r is JointRole.GRIPPER]
    if not idx:
        where = f" ({arm.spec.file})" if arm.spec.file is not None else ""
        raise InputError(f"arm {arm.name!r}{where} has no gripper: no joint has 'role: gripper' "
                         f"(its joints: {', '.join(arm.joint_names)}); mark the jaw joint with "
                         "'role: gripper' in the config (docs/config.md)")
    return idx


def goal_value(arm: Arm, idx: list[int], goal: str, deg: bool, mm: bool) -> float | None:
    """The gripper value VALUE means in SI ([rad] or [m]); ``None`` for 'open' and 'close'.

    Checked against the config's limits here (the effective limits are checked once the bus is
    open).

    Raises:
        InputError: Not a number, a unit flag that does not fit the joint, a value outside the
            config's limits (with the unit hint when it can only be another unit).
    """
    from armctl.config.schema import JointType

    word = goal.strip().lower()
    if word in (OPEN, CLOSE):
        if deg or mm:
            raise InputError(f"--{'deg' if deg else 'mm'} applies to a VALUE, not to "
                             f"{word!r}: drop it")
        return None
    try:
        raw = float(goal)
    except ValueError:
        raise InputError(f"gripper goal {goal!r} is neither 'open', 'close' nor a number "
                         "(a joint value in [rad] or [m])") from None
    if not math.isfinite(raw):
        raise InputError(f"gripper goal {goal!r} is not a finite number")
    types = {arm.joint_types[i] is JointType.PRISMATIC for i in idx}
    if len(types) > 1 and (deg or mm):
        raise InputError("the gripper joints are rotary and prismatic: give VALUE in SI "
                         "([rad] and [m]) without --deg or --mm")
    prismatic = types == {True}
    names = ", ".join(repr(arm.joint_names[i]) for i in idx)
    if deg and prismatic:
        raise InputError(f"--deg: the gripper joint {names} is prismatic: give VALUE in metres, "
                         "or in millimetres with --mm")
    if mm and not prismatic:
        raise InputError(f"--mm: the gripper joint {names} is rotary: give VALUE in radians, or "
                         "in degrees with --deg")
    value = math.radians(raw) if deg else raw / 1000.0 if mm else raw
    for i in idx:
        lo, hi = float(arm.lower[i]), float(arm.upper[i])
        if lo - 1e-9 <= value <= hi + 1e-9:
            continue
        name = arm.joint_names[i]
        if arm.joint_types[i] is JointType.PRISMATIC:
            unit, scale = ("mm", 1000.0) if mm else ("m", 1.0)
            hint = ("; did you mean --mm?" if not mm and lo <= raw / 1000.0 <= hi else "")
        else:
            unit, scale = ("deg", math.degrees(1.0)) if deg else ("rad", 1.0)
            hint = ("; did you mean --deg?" if not deg and lo <= math.radians(raw) <= hi
                    else "")
        raise InputError(f"gripper joint {name!r}: {raw:g} {unit} is outside its limits "
                         f"[{lo * scale:.6g}, {hi * scale:.6g}] {unit} (closed to open); "
                         f"nothing was sent{hint}")
    return value


def gripper_target(robot: Robot, idx: list[int], goal: str, value: float | None
                   ) -> np.ndarray:
    """The joint goal: the present joints, the gripper joints at the goal.

    ``open`` and ``close`` are the upper and lower ends of each gripper joint's effective limits.
    """
    q = robot.plan_start()
    for i in idx:
        if value is not None:
            q[i] = value
        elif goal.strip().lower() == OPEN:
            q[i] = float(robot.arm.upper[i])
        else:
            q[i] = float(robot.arm.lower[i])
    return q


def cmd_gripper(args: argparse.Namespace) -> int:
    """``armctl gripper``."""
    from armctl.cli import _checks
    from armctl.cli.move import joint_command

    arm = load_arm_arg(args)
    _check_servo_arm(arm)
    idx = gripper_indices(arm)
    value = goal_value(arm, idx, args.goal, args.deg, args.mm)
    _checks.check_speed_arg(args, arm)
    word = args.goal.strip().lower() if value is None else None
    what = f"{word} the gripper" if word else "move the gripper"

    def extra(robot: Robot, plan: MotionPlan) -> dict[str, Any]:
        return {"gripper": {robot.arm.joint_names[i]: {
            "goal": word or "value", "target": float(plan.goal[i]),
            "lower": float(robot.arm.lower[i]), "upper": float(robot.arm.upper[i])}
            for i in idx}}

    return joint_command(args, arm, lambda robot: gripper_target(robot, idx, args.goal, value),
                         what, f"the gripper is already there ({what}); nothing to do",
                         extra=extra)
