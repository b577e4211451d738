"""The ``ik`` command: joint values that bring a frame to a goal."""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from armctl.cli._common import (
    add_config,
    add_json,
    check_rpy,
    emit,
    finite,
    fmt,
    load_arm_arg,
    nonnegative_int,
    parse_angles,
    positive,
    positive_int,
    table,
)
from armctl.cli._parser import add_later
from armctl.cli._scene import add_scene_option, scene_arg
from armctl.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy as np

    from armctl.arm import Arm
    from armctl.collision.contact import Contact
    from armctl.collision.model import CollisionModel
    from armctl.ik import Goal, IKOptions, IKResult

ORDER = 20

_DESCRIPTION = """\
Inverse kinematics: find joint values that bring a frame (the tool by default) to a goal.
Without --rpy/--quat/--direction only the position is constrained (3 DOF); --direction AXIS DX
DY DZ points the tool's x, y or z axis along a direction (5 DOF, the goal for 5-joint arms);
--rpy or --quat give the full pose (6 DOF); --look-at X Y Z (without --xyz) points the tool's z
axis (or --axis) at a point and leaves the position free (2 DOF, e.g. a wrist camera).
"""

_EPILOG = """\
exit codes: 0 solved (every goal met within tolerance, inside the joint limits, free of contact
with the arm itself, the table and the scene's obstacles); 2 bad input; 3 no solution: the goal
was not reached (unreachable, or no start converged within the budgets), or every answer found
collides (the contact is named). --no-collisions turns the collision check off.
With exit code 3 the closest configuration found, its pose and the remaining error are printed
(on stderr; with --json as "error.details" on stdout). Angles are radians unless --deg.
"""


@dataclass(frozen=True)
class IKRequest:
    """Everything the command line asks of the solver.

    Attributes:
        goals: The goals.
        q0: Start ``(dof,)`` or ``None`` (the middle of the ranges).
        solver: Registered solver name.
        options: Budgets, seed and collision checker (``options.avoid``).
        constraints: Extra constraints (solver ``nlp``).
    """

    goals: tuple[Goal, ...]
    q0: np.ndarray | None
    solver: str
    options: IKOptions
    constraints: tuple[Any, ...] = ()


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``ik`` command."""
    p = sub.add_parser("ik", help="inverse kinematics: joint values that reach a pose",
                       description=_DESCRIPTION, epilog=_EPILOG,
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.set_defaults(func=cmd_ik)
    add_later(p, _ik_arguments)  # the goal types' flags need armctl.ik (NumPy): only for `ik`


def _ik_arguments(p: argparse.ArgumentParser) -> None:
    add_config(p)
    add_goal_arguments(p)
    p.add_argument("--force-pose", action="store_true",
                   help="solve a full pose (--rpy/--quat) even when fewer than 6 joints move "
                        "the frame (such a pose is reachable only on a 5-DOF subset)")
    add_solver_arguments(p)
    add_constraint_arguments(p)
    add_collision_arguments(p)
    p.add_argument("--tip", help="URDF only: keep the chain to this link")
    p.add_argument("--all", action="store_true",
                   help="with --solver analytic: list every distinct solution (nearest to --from "
                        "first), each with its residual, whether it is inside the joint "
                        "limits and whether it is free of contact; a solution is shown by its "
                        "variant inside the limits nearest to --from")
    p.add_argument("--variants", action="store_true",
                   help="with --all: also list the 2 pi variants of each solution (joint values "
                        "a full turn apart that fit in the limits)")
    add_json(p)


def add_goal_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments that describe the goal."""
    p.add_argument("--xyz", nargs=3, type=finite, metavar=("X", "Y", "Z"),
                   help="target position in the base frame [m]")
    rot = p.add_mutually_exclusive_group()
    rot.add_argument("--rpy", nargs=3, type=finite, metavar=("R", "P", "Y"),
                     help="target roll, pitch, yaw (URDF convention; radians, degrees with --deg)")
    rot.add_argument("--quat", nargs=4, type=finite, metavar=("W", "X", "Y", "Z"),
                     help="target orientation as a quaternion (normalised)")
    from armctl.ik.goals import goal_classes

    for cls in goal_classes():  # the goal types' own flags
        for arg in cls.cli_arguments:
            many = len(arg.metavar) > 1
            (rot if arg.exclusive else p).add_argument(
                arg.flag, dest=arg.dest, nargs=len(arg.metavar) if many else None,
                metavar=arg.metavar if many else arg.metavar[0],
                type=finite if arg.numbers else str, choices=arg.choices or None, help=arg.help)
    p.add_argument("--frame", help="the frame that must reach the goal (default: the tool)")
    p.add_argument("--tol-pos", type=positive, default=1e-5, metavar="M",
                   help="position tolerance [m] (default 1e-5)")
    p.add_argument("--tol-rot", type=positive, default=1e-4, metavar="RAD",
                   help="rotation tolerance [rad] (default 1e-4)")


def add_solver_arguments(p: argparse.ArgumentParser) -> None:
    """Arguments that choose and tune the solver."""
    from armctl.ik.registry import DEFAULT, solver_infos

    p.add_argument("--solver", default=DEFAULT, metavar="NAME",
                   help="; ".join(f"{i.name}: {i.summary}" for i in solver_infos())
                   + f" (default {DEFAULT}; docs/ik-methods.md)")
    p.add_argument("--from", dest="q0", nargs="+", metavar="Q",
                   help="start configuration (default: the middle of the joint ranges)")
    p.add_argument("--deg", action="store_true", help="angles (--from, --rpy, output) in degrees")
    p.add_argument("--max-iterations", type=positive_int, default=100, help="iterations per start")
    p.add_argument("--restarts", type=nonnegative_int, default=50,
                   help="random restarts (default 50)")
    p.add_argument("--time-limit", type=positive, default=0.5, metavar="S",
                   help="time budget [s] (default 0.5)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the restarts")


def add_constraint_arguments(p: argparse.ArgumentParser) -> None:
    """Constraints and goals files for the ``nlp`` solver (chosen automatically with them)."""
    p.add_argument("--plane", nargs=6, type=finite, action="append",
                   metavar=("PX", "PY", "PZ", "NX", "NY", "NZ"),
                   help="hard constraint: the goal frame stays on the plane through PX PY PZ "
                        "with normal NX NY NZ [m] (repeatable)")
    p.add_argument("--halfspace", nargs=6, type=finite, action="append",
                   metavar=("PX", "PY", "PZ", "NX", "NY", "NZ"),
                   help="hard constraint: the goal frame stays on the side of the plane PX PY "
                        "PZ that the normal NX NY NZ points to (repeatable)")
    p.add_argument("--keep-out", nargs="+", type=finite, action="append", metavar="V",
                   help="no link enters the sphere CX CY CZ R, or the box XMIN YMIN ZMIN XMAX "
                        "YMAX ZMAX [m] (repeatable)")
    p.add_argument("--goals", dest="goals_file", metavar="FILE",
                   help="YAML goals file with goals and constraints (see docs/nlp.md)")


def add_collision_arguments(p: argparse.ArgumentParser) -> None:
    """``--scene`` and ``--no-collisions``: what answers are checked against."""
    add_scene_option(p)
    p.add_argument("--no-collisions", action="store_true",
                   help="do not check answers for contact (with the arm itself, the table or "
                        "the obstacles)")


def build_checker(args: argparse.Namespace, arm: Arm) -> CollisionModel | None:
    """The collision checker the arguments ask for (``None`` with --no-collisions).

    Raises:
        InputError: For --scene together with --no-collisions.
        ConfigError: For a scene file that cannot be read (file, line, key and fix).
    """
    if getattr(args, "no_collisions", False):
        if getattr(args, "scene", None):
            raise InputError("--scene gives obstacles to check against, --no-collisions turns "
                             "the check off: give one of them")
        return None
    from armctl.collision.model import CollisionModel

    return CollisionModel.of(arm, scene_arg(args, arm))


def contact_text(contact: Contact | None) -> str:
    """``"free"``, or ``"collides: a-b 3.2 mm deep"`` (the pair, how deep inside its padding)."""
    if contact is None:
        return "free"
    return f"collides: {contact.a}-{contact.b} {contact.depth * 1000:.1f} mm deep"


def contact_data(contact: Contact | None) -> dict[str, Any] | None:
    """A contact as JSON-safe data (``None`` for none)."""
    if contact is None:
        return None
    return {"pair": [contact.a, contact.b], "kind": contact.kind.value,
            "distance": contact.distance, "depth": contact.depth, "padding": contact.padding}


def build_constraints(args: argparse.Namespace) -> tuple[Any, ...]:
    """The constraints given by --plane, --halfspace and --keep-out."""
    from armctl.ik.nlp import InHalfSpace, KeepOutBox, KeepOutSphere, OnPlane

    frame = getattr(args, "frame", None)
    out: list[Any] = []
    for v in getattr(args, "plane", None) or []:
        out.append(OnPlane(v[:3], v[3:], frame=frame))
    for v in getattr(args, "halfspace", None) or []:
        out.append(InHalfSpace(v[:3], v[3:], frame=frame))
    for v in getattr(args, "keep_out", None) or []:
        if len(v) == 4:
            out.append(KeepOutSphere(v[:3], v[3]))
        elif len(v) == 6:
            out.append(KeepOutBox(v[:3], v[3:]))
        else:
            raise InputError(f"--keep-out takes 4 numbers (sphere CX CY CZ R) or 6 (box XMIN "
                             f"YMIN ZMIN XMAX YMAX ZMAX), got {len(v)}")
    return tuple(out)


def build_goals(args: argparse.Namespace, arm: Arm) -> tuple[Goal, ...]:
    """The goal described by the goal arguments (the goal type whose flags were given)."""
    import numpy as np

    from armctl.ik import CliGoalInput, Tolerance, goal_classes
    from armctl.spatial import quat_to_matrix, rpy_to_matrix

    frame = args.frame
    if frame is not None:
        arm.frame_index(frame)
    tol = Tolerance(args.tol_pos, args.tol_rot)
    rot = None
    check_rpy(args.rpy, args.deg)
    if args.rpy is not None:
        rpy = np.radians(args.rpy) if args.deg else np.array(args.rpy)
        rot = rpy_to_matrix(rpy)
    elif args.quat is not None:
        quat = np.array(args.quat, dtype=float)
        if not np.linalg.norm(quat) > 1e-9:
            raise InputError("--quat: the quaternion must not be zero")
        rot = quat_to_matrix(quat / np.linalg.norm(quat))
    classes = goal_classes()
    own = {a.flag: getattr(args, a.dest, None) for cls in classes for a in cls.cli_arguments}
    given = CliGoalInput(None if args.xyz is None else np.array(args.xyz), rot, frame, tol, own)
    goals = [g for g in (cls.from_cli(given) for cls in classes) if g is not None]
    if len(goals) != 1:  # none (a flag missing), or flags of several types at once
        usage = [a.usage for cls in classes for a in cls.cli_arguments if a.usage]
        raise InputError("give a goal: --xyz X Y Z (a position), with --rpy or --quat (a pose); "
                         "--rpy/--quat alone (an orientation); " + "; or ".join(usage))
    return (goals[0],)


def _goal_flags(args: argparse.Namespace) -> bool:
    """Whether the command line describes a goal (besides a goals file)."""
    from armctl.ik import goal_classes

    own = [a.dest for c in goal_classes() for a in c.cli_arguments]
    return any(getattr(args, k, None) is not None for k in ("xyz", "rpy", "quat", *own))


def build_request(args: argparse.Namespace, arm: Arm) -> IKRequest:
    """The solver request: goals, start, solver, budgets and collision checker."""
    from armctl.ik import IKOptions
    from armctl.ik.registry import solver_for

    constraints = build_constraints(args)
    if getattr(args, "goals_file", None):
        from armctl.ik.nlp.goals_file import load_goals

        doc = load_goals(args.goals_file)
        goals = (*doc.goals, *build_goals(args, arm)) if _goal_flags(args) else doc.goals
        constraints = (*doc.constraints, *constraints)
        for g in goals:
            arm.frame_index(g.frame)
    else:
        goals = build_goals(args, arm)
    solver = solver_for(args.solver, goals, constraints)  # auto with constraints: nlp
    q0 = None
    if args.q0 is not None:
        q0 = arm.check_limits(parse_angles(args.q0, args.deg, arm, "--from"), "--from")
    options = IKOptions(max_iterations=args.max_iterations, time_limit=args.time_limit,
                        restarts=args.restarts, seed=args.seed, avoid=build_checker(args, arm))
    return IKRequest(goals, q0, solver, options, constraints)


def cmd_ik(args: argparse.Namespace) -> int:
    """Solve and print the joint values, the reached pose and the residual error."""
    from armctl.errors import JointLimitError
    from armctl.ik.errors import IKFailedError
    from armctl.ik.result import IKStatus
    from armctl.servo.calibration import load_calibration
    from armctl.servo.effective_limits import effective_limits

    arm = load_arm_arg(args)
    limits = effective_limits(arm.spec, load_calibration(arm.spec))
    arm = limits.apply(arm)  # answers inside the calibrated range, as the motion commands
    try:
        req = build_request(args, arm)
    except JointLimitError as exc:  # --from: name the limit's source (config or calibration)
        if exc.joint in arm.multi_dof_joints:  # a swing, twist or universal angle: as raised
            raise
        raise limits.error(exc.joint, exc.value, "--from") from None
    asked_pose = args.xyz is not None and (args.rpy is not None or args.quat is not None)
    if asked_pose and not args.force_pose:
        check_pose_dof(arm, req.goals[-1:])  # the command line's goal comes last
    if args.variants and not args.all:
        raise InputError("--variants lists the 2 pi variants of the solutions of --all: give "
                         "--all too")
    checker = req.options.avoid
    if args.all:
        return _cmd_all(args, arm, req, checker)
    _warm_up(arm, req)
    res = arm.ik(list(req.goals), req.q0, req.solver, options=req.options,
                 constraints=req.constraints)
    data, text = _report(arm, req, res, args.deg)
    data["collisions_checked"] = checker is not None
    if checker is not None:
        data["contact"] = contact_data(res.contact)
    if not res.success:
        hints = [h for h in (reach_hint(arm, g) for g in req.goals) if h]
        if res.status is IKStatus.COLLIDES:
            hints.append("every answer found brings a link into contact; --no-collisions "
                         "solves without the check")
        message = "; ".join([f"no solution: {res.message}", *hints])
        closest = ("closest configuration found "
                   f"({res.iterations} iterations, {res.restarts} restarts, "
                   f"{res.time * 1e3:.2f} ms):\n" + text.split("\n", 1)[1].lstrip("\n"))
        data["closest"] = closest
        if hints:
            data["hints"] = hints
        if args.json:  # the JSON message is one line; the closest pose is in error.details
            raise IKFailedError(res, message, data)
        raise IKFailedError(res, f"{message}\n{closest}", data)
    emit(args, data, text)
    return 0


#: Footnote of the joints a goal does not involve (their value is the start's).
_NOT_INVOLVED = ("not involved: joints that do not move the goal frame (e.g. a gripper) keep "
                 "their start value (--from; default the middle of their range)")


def not_involved(arm: Arm, goals: Sequence[Goal]) -> list[str]:
    """The joints that move none of the goals' frames (a gripper's, for a tool goal)."""
    moving: set[int] = set()
    for goal in goals:
        moving.update(arm.chain(goal.frame))
    return [n for i, n in enumerate(arm.joint_names) if i not in moving]


def check_pose_dof(arm: Arm, goals: tuple[Goal, ...]) -> None:
    """Refuse a full pose goal for a frame that fewer than 6 degrees of freedom move.

    A ball joint counts 3, a universal joint 2 (the tangent entries, ``model.v_index``).

    Raises:
        InputError: Naming the arm, the joint count and the goals that can be reached instead.
    """
    for goal in goals:
        if goal.dof < 6:
            continue
        chain = arm.chain(goal.frame)
        n = sum(arm.v_index(j).stop - arm.v_index(j).start for j in chain)  # ball joint: 3
        if n < 6:
            frame = "its tool" if goal.frame in (None, arm.tool) else f"frame {goal.frame!r}"
            moves = (f"{n} joints" if n == len(chain) else
                     f"{len(chain)} joints of {n} degrees of freedom")
            raise InputError(
                f"arm {arm.name!r} moves {frame} with {moves}: a full 6-DOF pose is "
                "generally unreachable; give --direction AXIS DX DY DZ (5-DOF) or only --xyz "
                "(or --force-pose to try anyway)")


def reach_hint(arm: Arm, goal: Goal) -> str | None:
    """A sentence when a goal's position lies beyond the arm's reach, else ``None``."""
    import numpy as np

    target = goal.target_position
    chain = arm.chain(goal.frame)
    if target is None or not chain:
        return None
    # the first joint's parent is the base: its placement's translation is its origin there
    base = arm.tree.joint_origin(chain[0])[:3, 3]
    dist = float(np.linalg.norm(np.asarray(target, dtype=float) - base))
    reach = arm.reach(goal.frame, from_first_joint=True)
    if dist <= reach:
        return None
    hint = (f"goal is {dist:.3g} m from the base joint; the arm reaches at most about "
            f"{reach:.2f} m")
    mm = np.asarray(target, dtype=float) / 1000.0
    if float(np.linalg.norm(mm - base)) <= reach:  # the values fit as millimetres
        hint += (f"; positions are in metres: did you mean {' '.join(f'{v:g}' for v in mm)} "
                 f"({' '.join(f'{v * 1000:g}' for v in mm)} mm)?")
    return hint


def _warm_up(arm: Arm, req: IKRequest) -> None:
    """Run the solver once with a one-iteration budget before the timed solve.

    The first call of a compiled solver loads its kernels (hundreds of ms); the time printed
    must be the solve's own.
    """
    from dataclasses import replace

    from armctl.ik.registry import solver_info

    if not solver_info(req.solver).capabilities.compiled or req.constraints:
        return  # e.g. the NLP builds its problem per goal: nothing reusable to load beforehand
    options = replace(req.options, max_iterations=1, restarts=0, time_limit=1.0)
    arm.ik(list(req.goals), req.q0, req.solver, options=options)


def _report(arm: Arm, req: IKRequest, res: IKResult, deg: bool) -> tuple[dict[str, Any], str]:
    from armctl.config.schema import JointType
    from armctl.spatial import matrix_to_quat, matrix_to_rpy

    rows = []
    idle = [] if req.constraints else not_involved(arm, req.goals)
    for i, name in enumerate(arm.joint_names):
        sl = arm.q_index(i)
        v = float(res.q[sl.start])
        if arm.joint_types[i] is JointType.BALL:  # its quaternion, never in degrees
            rows.append([name, " ".join(fmt(x, 6) for x in res.q[sl]), "quaternion w x y z"])
        elif arm.joint_types[i] is JointType.UNIVERSAL:
            rows.append([name, " ".join(fmt(math.degrees(x) if deg else x, 4 if deg else 6)
                                        for x in res.q[sl]), "deg" if deg else "rad"])
        elif arm.joint_types[i] is JointType.PRISMATIC:
            rows.append([name, fmt(v, 6), "m"])
        else:
            rows.append([name, fmt(math.degrees(v) if deg else v, 4 if deg else 6),
                         "deg" if deg else "rad"])
        if idle:
            rows[-1].append("(not involved)" if name in idle else "")
    lines = [f"{res.message}; {res.iterations} iterations, {res.restarts} restarts, "
             f"{res.time * 1e3:.2f} ms", "",
             table(["joint", "value", "unit", *(["note"] if idle else [])], rows, [1]), ""]
    if idle:
        lines[-1:-1] = [_NOT_INVOLVED]
    frames = []
    for goal, err in zip(req.goals, res.goal_errors, strict=True):
        pose = arm.fk(res.q, goal.frame)
        rpy = matrix_to_rpy(pose[:3, :3])
        shown = [math.degrees(a) for a in rpy] if deg else list(rpy)
        xyz = "  ".join(fmt(x, 6) for x in pose[:3, 3])
        lines.append(f"frame {err.frame!r}: position [m] {xyz}"
                     f"; rpy [{'deg' if deg else 'rad'}] {'  '.join(fmt(a, 4) for a in shown)}")
        lines.append(f"  residual: position {err.position:.3g} m, rotation {err.rotation:.3g} rad"
                     f" ({'met' if err.reached else 'NOT met'})")
        frames.append({"frame": err.frame, "position": pose[:3, 3], "rpy": rpy,
                       "quaternion": matrix_to_quat(pose[:3, :3]), "matrix": pose,
                       "position_error": err.position, "rotation_error": err.rotation,
                       "reached": err.reached})
    data = {"success": res.success, "status": res.status.value, "solver": res.solver,
            "q": res.q, "joints": arm.joint_values(res.q), "not_involved": idle,
            "iterations": res.iterations,
            "restarts": res.restarts, "time": res.time, "position_error": res.position_error,
            "rotation_error": res.rotation_error, "within_limits": res.within_limits,
            "frames": frames}
    if res.constraint_errors:
        lines.append("constraints:")
        for c in res.constraint_errors:
            lines.append(f"  {c.name}: violation {c.violation:.3g} "
                         f"({'holds' if c.satisfied else 'VIOLATED'})")
        data["constraints"] = [{"name": c.name, "violation": c.violation, "hard": c.hard,
                                "tolerance": c.tolerance, "satisfied": c.satisfied}
                               for c in res.constraint_errors]
    return data, "\n".join(lines)


def _cmd_all(args: argparse.Namespace, arm: Arm, req: IKRequest,
             checker: CollisionModel | None) -> int:
    """``--all``: every closed-form solution, nearest to the start first.

    With a collision checker each solution is marked free or colliding (the pair and depth).
    """
    from armctl.config.schema import JointType
    from armctl.errors import NoSolutionError
    from armctl.ik.analytic import acceptance, ik_all
    from armctl.ik.analytic.solve_all import CONTINUUM
    from armctl.ik.registry import solver_info, solver_infos

    if not solver_info(req.solver).capabilities.all_solutions:
        able = [i.name for i in solver_infos() if i.capabilities.all_solutions]
        raise InputError("--all lists the closed-form solutions; use it with --solver "
                         f"{' or '.join(able)}")
    if len(req.goals) != 1 or req.constraints:
        raise InputError("--all takes exactly one goal and no constraints")
    goal = req.goals[0]
    every = ik_all(arm, goal, q_ref=req.q0, tol=acceptance(goal),  # as the single answer
                   variants=True)
    if checker is not None:
        every = every.checked(checker)
    prismatic = [t is JointType.PRISMATIC for t in arm.joint_types]
    distinct = every.distinct([not p for p in prismatic])  # near-duplicates merged
    sols = every if args.variants else distinct
    units = ["m" if p else "deg" if args.deg else "rad" for p in prismatic]
    scale = [1.0 if p else 180.0 / math.pi if args.deg else 1.0 for p in prismatic]
    digits = [6 if p else 4 for p in prismatic]
    contacts = sols.contacts if sols.contacts is not None else (None,) * len(sols)
    rows = [[str(i + 1), "yes" if ok else "no",
             *(fmt(v * k, d) for v, k, d in zip(q, scale, digits, strict=True)), f"{ep:.1e}",
             f"{er:.1e}", *([contact_text(c)] if checker is not None else [])]
            for i, (q, ok, ep, er, c) in enumerate(zip(sols.q, sols.within_limits,
                                                        sols.position_error,
                                                        sols.rotation_error, contacts,
                                                        strict=True))]
    idle = not_involved(arm, req.goals)
    variants = ("" if len(every) == len(distinct) else
                f", {len(every)} rows with their 2 pi variants" if args.variants else
                f"; --variants lists all {len(every)} rows (with the 2 pi variants and the "
                "near-duplicate representatives)" if every.singular else
                f"; --variants lists their {len(every)} rows with the 2 pi variants")
    free = ("" if distinct.contacts is None else
            f", {int((distinct.within_limits & distinct.collision_free).sum())} of them free "
            "of contact")
    head = (f"{len(distinct)} distinct solutions ({int(distinct.within_limits.sum())} inside "
            f"the limits){free}{variants}; family: {sols.family}"
            + (f"; held at --from: {', '.join(sols.free)}" if sols.free else "")
            + ("; SINGULAR goal: a continuum of solutions, representatives at least "
               f"{CONTINUUM[0]:g} rad apart shown" if sols.singular else ""))
    data = {"family": sols.family, "singular": sols.singular, "free": list(sols.free),
            "not_involved": idle,
            "count": len(sols), "distinct": len(distinct), "with_variants": len(every),
            "variants_listed": bool(args.variants), "collisions_checked": checker is not None,
            "solutions": [
                {"q": q, "joints": arm.values_by_name(q), "within_limits": bool(ok),
                 "position_error": float(ep), "rotation_error": float(er),
                 **({"collision_free": c is None, "contact": contact_data(c)}
                    if checker is not None else {})}
                for q, ok, ep, er, c in zip(sols.q, sols.within_limits, sols.position_error,
                                            sols.rotation_error, contacts, strict=True)]}
    if not len(sols):
        raise NoSolutionError(f"no solution: the goal is out of reach ({sols.family})")
    text = head + "\n\n" + table(["#", "in limits", *(f"{n} [{u}]" for n, u in
                                                       zip(arm.joint_names, units, strict=True)),
                                   "pos err [m]", "rot err [rad]",
                                   *(["collisions"] if checker is not None else [])], rows,
                                  right=list(range(2, arm.dof + 4)))
    if idle:
        text += f"\n{_NOT_INVOLVED}: {', '.join(idle)}"
    emit(args, data, text)
    return 0
