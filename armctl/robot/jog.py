"""Jogging: one small, checked step per key, in joint space or along the base or tool axes.

A :class:`Jogger` holds what a jog pendant shows: the mode (:class:`JogMode`: joint, base frame
or tool frame), the joint or axis selected, the step size (from :class:`JogSteps`) and the speed
factor. Each call of :meth:`Jogger.jog` is one step: a joint move of the selected joint, or a
straight-line move of the tool along or about an axis of the base or tool frame. Every step is a
plan of the :class:`~armctl.robot.Robot`, so it passes the same checks as every other motion
(effective limits, contacts with the arm's scene, velocity, acceleration and jerk limits); a
refused step moves nothing and comes back as a :class:`JogOutcome` that says why. A step stopped
by :meth:`Jogger.stop` (from the ``on_cycle`` callback of the running step, e.g. a key) decelerates
within the joint limits and holds.

An arm whose tool is moved by fewer than six joints (the SO-101 has five) cannot turn its tool
about every axis while keeping the tool point in place: a rotation outside what its joints can
do at the present pose is refused before anything is planned, naming the axes it can turn about
there. Its translations keep the tool point on the line and let the orientation follow.

Keyframes go to a :class:`~armctl.robot.teach.TeachSession` (the file ``armctl teach`` writes and
``armctl play`` replays, saved atomically after every keyframe).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np

from armctl.collision.errors import CollisionError
from armctl.config.schema import JointType
from armctl.errors import ArmctlError, InputError, JointLimitError, NoSolutionError
from armctl.motion import Keyframe
from armctl.motion.errors import LimitViolation, PathError
from armctl.robot.errors import MotionStopped, StopReason
from armctl.robot.executor import CycleInfo
from armctl.robot.session import MoveReport, Robot
from armctl.spatial import axis_angle_to_matrix
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.ik import Goal
    from armctl.robot.teach import TeachSession

__all__ = ["AXES", "JogMode", "JogOutcome", "JogResult", "JogSteps", "Jogger", "turnable_axes"]

#: The Cartesian jog axes: translations along x, y, z, then rotations about x, y, z.
AXES: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz")

#: A rotation axis whose unit vector is further than this from what the joints can turn about
#: (while the tool point stays) is refused before planning (the sine of about 3 deg).
TURN_RESIDUAL = 0.05

#: The speed factors that :meth:`Jogger.faster` and :meth:`Jogger.slower` step through.
SPEEDS: tuple[float, ...] = (0.05, 0.1, 0.2, 0.3, 0.5, 0.75, 1.0)

#: How close a step's goal must come on an arm with fewer than six joints moving the tool:
#: position [m] and rotation [rad] (its joints can only just make a rotation they allow).
_FEW_JOINTS_TOLERANCE = (1e-3, math.radians(0.5))


class JogMode(Enum):
    """What a jog step moves."""

    JOINT = "joint"
    """One joint by the step."""
    BASE = "base"
    """The tool along or about an axis of the base frame (through the tool point)."""
    TOOL = "tool"
    """The tool along or about one of its own axes."""

    def next(self) -> JogMode:
        """The mode after this one (joint, base, tool, joint, ...)."""
        order = list(JogMode)
        return order[(order.index(self) + 1) % len(order)]


@dataclass(frozen=True)
class JogSteps:
    """The step sizes to choose from.

    Attributes:
        rotary: Steps of rotary joints and of rotations [rad], smallest first.
        linear: Steps of prismatic joints and of translations [m], smallest first.

    Raises:
        InputError: An empty list, a step that is not a positive finite number, lists of
            different lengths, or a rotation of more than 45 deg or a translation of more
            than 0.1 m in one step.
    """

    rotary: tuple[float, ...] = (math.radians(1), math.radians(5), math.radians(10))
    linear: tuple[float, ...] = (0.001, 0.005, 0.020)

    def __post_init__(self) -> None:
        for name, values, top, unit, scale in (
                ("rotary", self.rotary, math.radians(45), "deg", math.degrees(1)),
                ("linear", self.linear, 0.1, "mm", 1000.0)):
            if not values:
                raise InputError(f"give at least one {name} jog step")
            for v in values:
                if not (math.isfinite(v) and v > 0):
                    raise InputError(f"a {name} jog step must be more than 0, got {v * scale:g} "
                                     f"{unit}")
                if v > top + 1e-12:
                    raise InputError(f"a {name} jog step of {v * scale:g} {unit} is more than "
                                     f"{top * scale:g} {unit}: a jog step is a small move")
        if len(self.rotary) != len(self.linear):
            raise InputError(f"give as many rotary jog steps ({len(self.rotary)}) as linear ones "
                             f"({len(self.linear)}): the step keys choose one of each")

    def __len__(self) -> int:
        return len(self.rotary)


class JogResult(Enum):
    """How a jog step (or a gripper move, or going home) ended."""

    MOVED = "moved"
    REFUSED = "refused"
    """Refused before anything moved (a limit, a contact, a line or rotation the arm cannot do)."""
    STOPPED = "stopped"
    """Stopped on request: the arm decelerated and holds."""


@dataclass(frozen=True)
class JogOutcome:
    """What one step did.

    Attributes:
        result: Moved, refused or stopped.
        message: One line for a status display: what moved, or why nothing did.
        detail: The whole explanation (the error's message, with where a limit comes from and
            how to change it); empty when the step moved.
        error: The refusal or the stop, if any.
        report: The move's report when it moved.
    """

    result: JogResult
    message: str
    detail: str = ""
    error: ArmctlError | None = None
    report: MoveReport | None = None


def _format(value: float, prismatic: bool) -> str:
    """A joint value or step as text in deg or mm."""
    return f"{value * 1000:.1f} mm" if prismatic else f"{math.degrees(value):.1f} deg"


def turnable_axes(arm: Arm, q: Array, axes: Array, frame: str | None = None) -> Array:
    """How far each axis is from those a frame can turn about, its origin staying put.

    A frame moved by ``n`` joints can turn, to first order, about the axes ``w`` of the twists
    ``(v = 0, w)`` inside the span of its Jacobian's columns. For ``n >= 6`` (and no
    singularity) that is every axis; for five joints it is a plane of axes, for four a line.

    Args:
        arm: The arm.
        q: Joint values ``(dof,)`` [rad]/[m].
        axes: Unit axes in the base frame ``(k, 3)``.
        frame: The frame (default: the arm's tool).

    Returns:
        ``(k,)``: the distance of each unit axis from the axes the joints can turn about (0:
        it can; 1: it cannot at all).
    """
    jac = arm.jacobian(q, frame)
    cols = jac[:, list(arm.chain(frame))]
    jv, jw = cols[:3], cols[3:]
    _, s, vt = np.linalg.svd(jv)
    rank = int(np.sum(s > 1e-9 * max(float(s[0]) if s.size else 1.0, 1e-12)))
    null = vt[rank:].T  # joint rates that keep the tool point still
    turns = jw @ null  # (3, m): the rotations those rates make
    a = np.asarray(axes, dtype=float)
    if turns.size == 0:
        return np.ones(len(a))
    u, sw, _ = np.linalg.svd(turns, full_matrices=False)
    basis = u[:, sw > 1e-6 * max(float(sw[0]), 1e-12)]
    return np.linalg.norm(a - (a @ basis) @ basis.T, axis=1)


class Jogger:
    """Jog a robot one checked step at a time.

    Args:
        robot: The open robot (holding its pose).
        steps: The step sizes to choose from; the smallest is selected first.
        speed: Speed factor of the joint limits for every step, in 0.01 to 1.
        session: Where recorded keyframes go (``None``: recording is refused).

    Attributes:
        mode: What a step moves.
        joint: Index into :attr:`joints` of the joint selected for joint steps.
        axis: Index into :data:`AXES` of the axis selected for Cartesian steps.
        step_index: Index of the step size in use.
        speed: Speed factor of the joint limits.
        steps_run: Steps (and gripper and home moves) that reached their goal.
        refusals: Steps refused.

    Raises:
        InputError: A speed outside 0.01 to 1.
    """

    def __init__(self, robot: Robot, steps: JogSteps | None = None, speed: float = 0.3,
                 session: TeachSession | None = None):
        from armctl.config.schema import JointRole

        self.robot = robot
        self.steps = steps if steps is not None else JogSteps()
        self.session = session
        arm = robot.arm
        on_bus = set(robot.bus.joint_names)
        #: The joints that joint steps move: those with a servo, grippers excepted.
        self.joints: tuple[str, ...] = tuple(
            n for n, r in zip(arm.joint_names, arm.joint_roles, strict=True)
            if n in on_bus and r is not JointRole.GRIPPER)
        if not self.joints:
            raise InputError(f"arm {arm.name!r} has no joint to jog (every joint with a servo is "
                             "a gripper)")
        self.mode = JogMode.JOINT
        self.joint = 0
        self.axis = 0
        self.step_index = 0
        self.speed = self._checked_speed(speed)
        self.steps_run = 0
        self.refusals = 0
        #: Whether fewer than six joints move the tool (rotations are limited).
        self.few_joints = len(arm.chain()) < 6
        #: The goal of the last step that moved ``(dof,)`` [rad]/[m]: the next step starts from
        #: it while the arm holds there, so that steps add up exactly (a servo settles within
        #: a tick or two of its goal, and stepping from the reading would add that up).
        self._goal: Array | None = None

    # ---- settings -----------------------------------------------------------------------------
    @staticmethod
    def _checked_speed(speed: float) -> float:
        from armctl.motion import check_speed

        check_speed(speed)
        return float(speed)

    def set_mode(self, mode: JogMode) -> None:
        """Jog joints, or the tool in the base or tool frame."""
        self.mode = mode

    @property
    def targets(self) -> tuple[str, ...]:
        """What the mode's steps can move: joint names, or :data:`AXES`."""
        return self.joints if self.mode is JogMode.JOINT else AXES

    @property
    def target(self) -> str:
        """The joint or axis selected in the present mode."""
        return self.targets[self.joint if self.mode is JogMode.JOINT else self.axis]

    def select(self, index: int) -> str:
        """Select joint or axis ``index`` (from 0) of the present mode; its name.

        Raises:
            InputError: No such joint or axis in this mode.
        """
        targets = self.targets
        if not 0 <= index < len(targets):
            what = "joint" if self.mode is JogMode.JOINT else "axis"
            raise InputError(f"no {what} {index + 1}: {', '.join(targets)} are "
                             f"1 to {len(targets)}")
        if self.mode is JogMode.JOINT:
            self.joint = index
        else:
            self.axis = index
        return targets[index]

    def bigger_step(self) -> None:
        """The next larger step size (the largest stays)."""
        self.step_index = min(self.step_index + 1, len(self.steps) - 1)

    def smaller_step(self) -> None:
        """The next smaller step size (the smallest stays)."""
        self.step_index = max(self.step_index - 1, 0)

    def faster(self) -> None:
        """The next larger speed factor of :data:`SPEEDS` (at most 1)."""
        self.speed = next((s for s in SPEEDS if s > self.speed + 1e-9), self.speed)

    def slower(self) -> None:
        """The next smaller speed factor of :data:`SPEEDS` (at least 0.05, or the start's)."""
        self.speed = next((s for s in reversed(SPEEDS) if s < self.speed - 1e-9), self.speed)

    def step_of(self, target: str | None = None) -> tuple[float, bool]:
        """The step size of a joint or axis (default: the selected one).

        Returns:
            The step [rad] or [m], and whether it is a length.
        """
        target = target if target is not None else self.target
        if target in AXES and self.mode is not JogMode.JOINT:
            linear = not target.startswith("r")
        else:
            i = self.robot.arm.joint_index(target)
            linear = self.robot.arm.joint_types[i] is JointType.PRISMATIC
        values = self.steps.linear if linear else self.steps.rotary
        return values[self.step_index], linear

    def step_text(self) -> str:
        """The selected step as text, e.g. ``"5 deg / 5 mm"``."""
        rot, lin = self.steps.rotary[self.step_index], self.steps.linear[self.step_index]
        return f"{math.degrees(rot):g} deg / {lin * 1000:g} mm"

    # ---- steps --------------------------------------------------------------------------------
    def stop(self, why: str = "stop key") -> None:
        """Ask the running step to stop: it decelerates within the limits and holds.

        Call it from the step's ``on_cycle`` callback (or another thread); a step that has
        not started yet is not affected (each step starts with a clear stop request).
        """
        self.robot.stop.request(why)

    def jog(self, direction: int, on_cycle: Callable[[CycleInfo], None] | None = None
            ) -> JogOutcome:
        """One step of the selected joint or axis, ``direction`` +1 or -1.

        Raises:
            InputError: A direction other than +1 or -1.
            MotionStopped: A stop for a fault (not a stop request): the arm holds.
            BusError: The bus failed.
        """
        if direction not in (1, -1):
            raise InputError(f"a jog direction is +1 or -1, got {direction}")
        size, _ = self.step_of()
        if self.mode is JogMode.JOINT:
            return self.jog_joint(self.target, direction * size, on_cycle)
        return self.jog_cartesian(self.target, direction * size, self.mode, on_cycle)

    def jog_joint(self, joint: str, delta: float,
                  on_cycle: Callable[[CycleInfo], None] | None = None) -> JogOutcome:
        """Move one joint by ``delta`` [rad]/[m] from where it is.

        A goal outside the joint's effective limits is refused (nothing moves), naming the
        limit and where it comes from.
        """
        arm = self.robot.arm
        i = arm.joint_index(joint)
        prismatic = arm.joint_types[i] is JointType.PRISMATIC
        sign = "+" if delta >= 0 else "-"
        what = f"{joint} {sign}{_format(abs(delta), prismatic)}"

        def move() -> MoveReport:
            q = self.stepping_from()
            q[i] += delta
            return self.robot.move_joints(q, self.speed, on_cycle=on_cycle)

        return self._run(what, move)

    def stepping_from(self) -> Array:
        """The joints a step is added to ``(dof,)`` [rad]/[m].

        The goal of the last step while every joint is within the robot's start tolerance of
        it (the arm holds there), else the present position (:meth:`Robot.plan_start`).

        Raises:
            JointLimitError: A joint far outside its effective limits (see ``plan_start``).
        """
        present = self.robot.plan_start()
        goal = self._goal
        if goal is not None and bool(np.all(np.abs(present - goal)
                                            <= self.robot.start_tolerance)):
            return goal.copy()
        return present

    def jog_cartesian(self, axis: str, delta: float, frame: JogMode = JogMode.BASE,
                      on_cycle: Callable[[CycleInfo], None] | None = None) -> JogOutcome:
        """Move the tool along a straight line by ``delta`` along or about an axis.

        Args:
            axis: One of :data:`AXES` (``"x"``: along x [m]; ``"rx"``: about x [rad]).
            delta: The step [m] or [rad].
            frame: :attr:`JogMode.BASE` (the base frame's axes, rotations through the tool
                point) or :attr:`JogMode.TOOL` (the tool's own axes).
            on_cycle: Called every control cycle of the step.

        Raises:
            InputError: An unknown axis, or :attr:`JogMode.JOINT` as the frame.
        """
        if axis not in AXES:
            raise InputError(f"unknown jog axis {axis!r}: one of {', '.join(AXES)}")
        if frame is JogMode.JOINT:
            raise InputError("a Cartesian jog step is in the base or the tool frame")
        rotation = axis.startswith("r")
        k = AXES.index(axis) % 3
        sign = "+" if delta >= 0 else "-"
        what = (f"{frame.value} {axis} {sign}"
                f"{_format(abs(delta), prismatic=not rotation)}")

        def move() -> MoveReport:
            goal = self._cartesian_goal(k, delta, rotation, frame, what)
            try:
                return self.robot.move_to_pose(goal, linear=True, speed=self.speed,
                                               on_cycle=on_cycle)
            except PathError as exc:
                if not (rotation and self.few_joints):
                    raise
                raise self._not_turnable(self.stepping_from(), k, delta, frame, what,
                                         f"the turn fails {exc.fraction:.0%} of the way: "
                                         f"{exc.reason}") from None

        return self._run(what, move)

    def _cartesian_goal(self, k: int, delta: float, rotation: bool, frame: JogMode,
                        what: str) -> Goal:
        """The goal of a Cartesian step from the present tool pose.

        Raises:
            InputError: A rotation the arm's joints cannot make at the present pose.
        """
        from armctl.ik import PoseGoal, PositionGoal

        q = self.stepping_from()
        pose = self.robot.arm.fk(q)
        r0, p0 = pose[:3, :3], pose[:3, 3]
        unit = r0[:, k] if frame is JogMode.TOOL else np.eye(3)[k]
        goal = pose.copy()
        if not rotation:
            goal[:3, 3] = p0 + delta * unit
            if self.few_joints:  # the orientation follows: the tool point keeps to the line
                return PositionGoal(goal[:3, 3])
            return PoseGoal(goal)
        if self.few_joints:  # refuse a turn its joints cannot make at all, before planning
            axes = r0.T if frame is JogMode.TOOL else np.eye(3)
            if turnable_axes(self.robot.arm, q, axes)[k] > TURN_RESIDUAL:
                raise self._not_turnable(q, k, delta, frame, what)
        return self._turned(q, unit, delta)

    def _turned(self, q: Array, axis: Array, angle: float) -> Goal:
        """The pose goal of the tool at ``q`` turned by ``angle`` [rad] through the tool point.

        ``axis``: a unit axis in base coordinates.
        """
        from armctl.ik import PoseGoal, Tolerance

        goal = self.robot.arm.fk(q)
        goal[:3, :3] = axis_angle_to_matrix(axis, angle) @ goal[:3, :3]
        tol = Tolerance(*_FEW_JOINTS_TOLERANCE) if self.few_joints else Tolerance()
        return PoseGoal(goal, tolerance=tol)

    def _not_turnable(self, q: Array, k: int, angle: float, frame: JogMode, what: str,
                      why: str = "") -> InputError:
        """The refusal of a turn by ``angle`` about axis ``k`` of ``frame`` at ``q``.

        It names the other axes of the frame that the tool can turn about by the same angle
        from ``q`` (IK of each turned pose, inside the effective limits).
        """
        r0 = self.robot.arm.fk(q)[:3, :3]
        axes = r0.T if frame is JogMode.TOOL else np.eye(3)
        n = len(self.robot.arm.chain())
        can = [AXES[3 + j] for j in range(3) if j != k and
               self.robot.arm.ik(self._turned(q, axes[j], angle), q0=q).success]
        here = (f"here it can turn the tool about {frame.value} {' and '.join(can)}" if can
                else f"here it can turn the tool about no other axis of the {frame.value} "
                "frame")
        because = f" ({why})" if why else ""
        return InputError(
            f"{what}: arm {self.robot.arm.name!r} moves its tool with {n} joints and cannot "
            f"turn it about the {frame.value} frame's {'xyz'[k]} axis while keeping the tool "
            f"point in place{because}; {here} (or jog single joints, e.g. the wrist, in joint "
            "mode)", {"axis": AXES[3 + k], "frame": frame.value, "joints": n,
                      "turnable": can})

    def gripper(self, open_: bool, on_cycle: Callable[[CycleInfo], None] | None = None
                ) -> JogOutcome:
        """Open (upper effective limit) or close (lower) the gripper joints; the rest holds."""
        arm = self.robot.arm
        names = self.robot.gripper_joints
        what = "open the gripper" if open_ else "close the gripper"
        if not names:
            error = InputError(f"arm {arm.name!r} has no gripper joint (role: gripper)")
            self.refusals += 1
            return JogOutcome(JogResult.REFUSED, f"{what}: no gripper", str(error), error)

        def move() -> MoveReport:
            q = self.stepping_from()
            for name in names:
                i = arm.joint_index(name)
                q[i] = float(arm.upper[i] if open_ else arm.lower[i])
            return self.robot.move_joints(q, self.speed, on_cycle=on_cycle)

        return self._run(what, move)

    def home(self, on_cycle: Callable[[CycleInfo], None] | None = None) -> JogOutcome:
        """Move to the arm's 'home' pose (a joint move, checked like every step)."""
        if "home" not in self.robot.arm.spec.poses:
            error = InputError(f"arm {self.robot.arm.name!r} has no 'home' pose; add one under "
                               "'poses:' in its config")
            self.refusals += 1
            return JogOutcome(JogResult.REFUSED, "home: no 'home' pose", str(error), error)
        return self._run("home", lambda: self.robot.home(self.speed, on_cycle=on_cycle))

    def _run(self, what: str, move: Callable[[], MoveReport]) -> JogOutcome:
        """Run one move; a refusal or a requested stop becomes the outcome.

        Raises:
            MotionStopped: A stop for a fault (a servo alarm, a lost servo, a tracking error).
        """
        goal, self._goal = self._goal, None  # a step that does not end at its goal: the next
        try:  # starts from where the arm is
            report = self._from(goal, move)
        except MotionStopped as exc:
            if exc.reason is not StopReason.USER:
                raise
            return JogOutcome(JogResult.STOPPED, f"{what}: stopped, holding", str(exc), exc)
        except (InputError, NoSolutionError) as exc:
            self.refusals += 1
            return JogOutcome(JogResult.REFUSED, f"{what} refused: {self._why(what, exc)}",
                              str(exc), exc)
        self.steps_run += 1
        self._goal = np.array(report.plan.waypoints[-1].q, dtype=float)
        return JogOutcome(JogResult.MOVED, what, report=report)

    def _from(self, goal: Array | None, move: Callable[[], MoveReport]) -> MoveReport:
        """Run ``move`` with the steps starting from ``goal`` (``None``: from the arm)."""
        self._goal = goal
        try:
            return move()
        finally:
            self._goal = None

    def _why(self, what: str, exc: ArmctlError) -> str:
        """The reason of a refusal in a few words (joint and limit, pair in contact, ...)."""
        if isinstance(exc, JointLimitError):
            arm = self.robot.arm
            prismatic = arm.joint_types[arm.joint_index(exc.joint)] is JointType.PRISMATIC
            upper = exc.value > exc.upper
            bound = exc.upper if upper else exc.lower
            source = exc.details.get("limit_source")
            src = f" ({str(source).replace('_', ' ')})" if source else ""
            return (f"{exc.joint} would reach {_format(exc.value, prismatic)}, beyond its "
                    f"{'upper' if upper else 'lower'} limit {_format(bound, prismatic)}{src}")
        if isinstance(exc, CollisionError):
            c = exc.contact
            how = (f"overlap by {-c.distance * 1000:.1f} mm" if c.distance < 0 else
                   f"come within their {c.padding * 1000:g} mm padding" if c.padding > 0 else
                   "touch")
            return f"{c.a} and {c.b} would {how}"
        if isinstance(exc, PathError):
            return f"no straight line ({exc.reason}, {exc.fraction:.0%} of the way)"
        if "turnable" in exc.details:  # a turn that too few joints cannot make
            can = exc.details["turnable"]
            frame = exc.details["frame"]
            return (f"{exc.details['joints']} joints cannot turn the tool about {frame} "
                    f"{str(exc.details['axis'])[1:]} here (they can about: "
                    f"{', '.join(f'{frame} {a}' for a in can) if can else 'no other axis'})")
        if isinstance(exc, LimitViolation):
            return f"{exc.joint} would exceed its {exc.kind} limit"
        text = str(exc)
        if text.startswith(what + ": "):
            text = text[len(what) + 2:]
        return re.split(r"\.\s+(?=[A-Z])", text)[0]  # the first sentence

    # ---- keyframes ----------------------------------------------------------------------------
    def record(self, name: str = "") -> Keyframe:
        """Record the pose the arm holds (and the gripper's value) as a keyframe.

        The values recorded are the goal of the last step while the arm holds there (so the
        file holds the steps sent, not the servos' settling within a tick of them), else the
        present position. The file is saved atomically (see
        :class:`~armctl.robot.teach.TeachSession`).

        Raises:
            InputError: Without a keyframe file.
        """
        if self.session is None:
            raise InputError("no keyframe file to record into")
        return self.session.record(name, with_gripper=bool(self.robot.gripper_joints),
                                   at=self.stepping_from())

    def undo(self) -> Keyframe | None:
        """Remove the last keyframe (and save); ``None`` when there is none.

        Raises:
            InputError: Without a keyframe file.
        """
        if self.session is None:
            raise InputError("no keyframe file to record into")
        return self.session.undo()

    @property
    def keyframes(self) -> int:
        """How many keyframes the file holds."""
        return 0 if self.session is None else len(self.session.program.keyframes)
