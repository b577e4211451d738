"""The Python API: an arm, its bus and the motion core in one context manager.

Example::

    from armctl.robot import Robot

    with Robot.open("so101", speed=0.5) as robot:       # port 'sim' runs the simulated bus
        robot.move_to_pose(xyz=[0.2, 0.0, 0.15])
        robot.home()
    # leaving the block applies the exit policy (hold by default: torque stays on)
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from armctl.arm import Arm, load_arm
from armctl.config.motion import ExitPolicy, MotionSpec
from armctl.config.schema import JointRole
from armctl.errors import ArmctlError, InputError, JointLimitError
from armctl.ik import Goal, IKResult, PositionGoal
from armctl.ik.errors import IKFailedError
from armctl.motion import (
    KeyframeProgram,
    MotionLimits,
    MotionPlan,
    PlaybackOptions,
    plan_joint_move,
    plan_program,
)
from armctl.motion.cartesian import LineOptions, plan_line
from armctl.robot.errors import MotionStopped
from armctl.robot.executor import CycleInfo, Executor, JointBus, StreamResult
from armctl.robot.stop import StopRequest, ignore_sigint, sigint_stops

if TYPE_CHECKING:
    from armctl.robot.teach import TeachSession
    from armctl.servo.calibration import Calibration

__all__ = ["MoveReport", "Robot"]

Array = npt.NDArray[np.float64]

#: Largest distance [rad]/[m] between a plan's start and the present position for it to be run.
_START_TOLERANCE = 0.05
#: Readings this far [rad]/[m] outside a limit are planned from the limit itself.
_OUTSIDE_TOLERANCE = 0.02


@dataclass(frozen=True)
class MoveReport:
    """What a move did.

    Attributes:
        plan: The plan that was streamed (or would be, for a dry run).
        result: Streaming figures and the final measured joints (``None`` for a dry run).
        ik: The IK result for pose moves.
        reached: FK of the measured final joints ``(4, 4)`` (``None`` for a dry run).
        position_error: Distance of ``reached`` from the goal [m] (NaN when not a pose move).
        rotation_error: Rotation or direction error of ``reached`` [rad].
    """

    plan: MotionPlan
    result: StreamResult | None = None
    ik: IKResult | None = None
    reached: Array | None = None
    position_error: float = float("nan")
    rotation_error: float = float("nan")


class Robot:
    """An arm with its servo bus: plans, streams, stops safely and applies an exit policy.

    Build one with :meth:`open` (which opens the bus and holds the present pose with torque on)
    and use it as a context manager so that the exit policy is applied on the way out.

    Args:
        arm: The arm model.
        bus: An open bus whose joints are joints of the arm.
        motion: Motion defaults (rate, speed, tracking limit, exit policy).
        speed: Default speed factor (overrides ``motion.speed``).
        exit_policy: Exit policy (overrides ``motion.exit_policy``).
    """

    def __init__(self, arm: Arm, bus: JointBus, motion: MotionSpec | None = None, *,
                 speed: float | None = None, exit_policy: ExitPolicy | None = None):
        self.arm = arm
        self.bus = bus
        self.motion = motion or arm.spec.motion or MotionSpec()
        self.speed = float(speed if speed is not None else min(self.motion.speed, 1.0))
        self.exit_policy = exit_policy or self.motion.exit_policy
        self.limits = MotionLimits.from_model(arm)
        self.executor = Executor(bus, arm, self.limits, self.motion.rate_hz,
                                 self.motion.max_tracking_error)
        self.stop = StopRequest()
        # Joints without a servo (if any) are taken to stay at zero, clipped into their limits.
        self._q = np.clip(np.zeros(arm.dof), arm.lower, arm.upper)
        self._closed = False
        self._owns_bus = False

    # ---- life cycle -------------------------------------------------------------------------
    @classmethod
    def open(cls, config: str | Path | Arm, *, speed: float | None = None,
             exit_policy: ExitPolicy | None = None, hold: bool = True) -> Robot:
        """Load an arm, open its bus and hold the present pose with torque on.

        Args:
            config: Arm YAML path, bundled name, or an :class:`Arm`.
            speed: Default speed factor in (0, 1].
            exit_policy: What to do at the end (default from the config: hold).
            hold: Switch torque on, holding the present pose (no jump).

        Raises:
            ConfigError: Bad config or calibration file.
            BusError: The bus cannot be opened or a servo is missing.
        """
        from armctl.servo.arm_bus import ArmBus

        arm = config if isinstance(config, Arm) else load_arm(config)
        calibration = _calibration(arm)
        bus = ArmBus.from_spec(arm.spec, calibration).open()
        try:
            robot = cls(arm, bus, speed=speed, exit_policy=exit_policy)
            robot._owns_bus = True
            if hold:
                robot.hold()
        except BaseException:
            bus.close()
            raise
        return robot

    def __enter__(self) -> Robot:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *exc: object) -> None:
        try:
            self.close()
        except ArmctlError as failure:
            if exc_type is None:
                raise
            # Do not hide the error that ended the block; report the failed exit policy too.
            print(f"armctl: exit policy {self.exit_policy.value!r} failed: {failure}",
                  file=sys.stderr)

    def close(self, policy: ExitPolicy | None = None) -> None:
        """Apply the exit policy and close the bus (if this robot opened it)."""
        if self._closed:
            return
        self._closed = True
        try:
            self.apply_exit_policy(policy or self.exit_policy)
        finally:
            if self._owns_bus:
                self.bus.close()  # type: ignore[attr-defined]

    def apply_exit_policy(self, policy: ExitPolicy) -> None:
        """Hold (torque stays on), park (move to the 'park' pose, then hold) or release."""
        if policy is ExitPolicy.PARK:
            if "park" not in self.arm.spec.poses:
                print(f"armctl: arm {self.arm.name!r} has no 'park' pose; holding instead",
                      file=sys.stderr)
                return
            self.stop.clear()
            with ignore_sigint("parking"):
                plan = self.plan_joints(self.arm.named_pose("park"), min(self.speed, 0.5),
                                        "park (exit policy)")
                self.executor.run(plan, StopRequest())
        elif policy is ExitPolicy.RELEASE:
            print("armctl: releasing torque: a raised arm will fall", file=sys.stderr)
            self.bus.set_torque(False)

    @property
    def simulated(self) -> bool:
        """Whether the bus is the built-in simulated bus."""
        return getattr(self.bus, "simulator", None) is not None

    # ---- state --------------------------------------------------------------------------------
    def joints(self) -> Array:
        """Present joint values of the whole arm ``(dof,)`` [rad]/[m] (one sync read)."""
        q = self._q.copy()
        q[self.executor.idx] = self.bus.read_joints()
        return q

    def pose(self, frame: str | None = None) -> Array:
        """FK of the present joints: the tool pose ``(4, 4)`` [m]."""
        return self.arm.fk(self.joints(), frame)

    def hold(self) -> Array:
        """Hold the present pose: goal = present position, then torque on."""
        self.executor.hold()
        return self.joints()

    # ---- planning -----------------------------------------------------------------------------
    def plan_start(self) -> Array:
        """The present joints as the start of a plan.

        A reading just outside a limit (up to :data:`_OUTSIDE_TOLERANCE`, encoder noise or a
        joint pushed against its stop) is taken as the limit itself.

        Raises:
            JointLimitError: If a joint is further outside its limits; nothing moves.
        """
        q = self.joints()
        lo, hi = self.arm.lower, self.arm.upper
        out = np.maximum(lo - q, q - hi)
        if float(np.max(out, initial=0.0)) > _OUTSIDE_TOLERANCE:
            i = int(np.argmax(out))
            raise JointLimitError(self.arm.joint_names[i], float(q[i]), float(lo[i]),
                                  float(hi[i]), "present position: move the joint inside by hand "
                                  "with torque off, or check the calibration")
        return np.clip(q, lo, hi)

    def _speed(self, speed: float | None) -> float:
        return self.speed if speed is None else float(speed)

    def plan_joints(self, q: npt.ArrayLike, speed: float | None = None,
                    description: str = "joint move") -> MotionPlan:
        """A checked joint move from the present position."""
        goal = self.arm.check_limits(q, "goal of the move")
        return plan_joint_move(self.plan_start(), goal, self.limits, self._speed(speed),
                               description)

    def solve(self, goal: Goal, solver: str = "auto", q0: npt.ArrayLike | None = None
              ) -> IKResult:
        """IK from the present joints.

        Raises:
            IKFailedError: A :class:`NoSolutionError` with the closest distance found, when the
                goal cannot be reached; its ``details`` hold the closest joints and errors.
        """
        start = self.joints() if q0 is None else np.asarray(q0, dtype=float)
        res = self.arm.ik(goal, q0=start, solver=solver)
        if not res.success:
            advice = "Check the goal is inside the arm's reach"
            if not isinstance(goal, PositionGoal):
                advice += ", or give fewer orientation constraints"
            advice += "."
            details = {"status": res.status.value, "solver": res.solver,
                       "closest_q": np.asarray(res.q, dtype=float),
                       "closest_joints": self.arm.values_by_name(res.q),
                       "position_error": res.position_error,
                       "rotation_error": res.rotation_error,
                       "closest_xyz": self.arm.fk(res.q, goal.frame)[:3, 3]}
            raise IKFailedError(
                res, f"the goal cannot be reached ({res.status.value}): closest found is "
                f"{res.position_error * 1000:.1f} mm and {np.degrees(res.rotation_error):.1f} "
                f"deg away (solver {res.solver}); nothing was moved. {advice}", details)
        return res

    def plan_pose(self, goal: Goal, *, linear: bool = False, speed: float | None = None,
                  solver: str = "auto") -> tuple[MotionPlan, IKResult | None]:
        """A checked move of the tool to a goal: joint-space (IK at the goal) or a straight line.

        Raises:
            NoSolutionError: Goal unreachable (nothing moves).
            PathError: A straight line that cannot be followed (with where it fails).
        """
        start = self.plan_start()
        if linear:
            plan = plan_line(self.arm, start, goal, self.limits, self._speed(speed),
                             LineOptions(solver=solver))
            return plan, None
        res = self.solve(goal, solver, start)
        # Keep joints the goal does not involve (the gripper) where they are.
        q = np.asarray(res.q, dtype=float).copy()
        moving = set(self.arm.chain(goal.frame))
        for i in range(self.arm.dof):
            if i not in moving:
                q[i] = start[i]
        return plan_joint_move(start, q, self.limits, self._speed(speed), "move to pose"), res

    # ---- moving -------------------------------------------------------------------------------
    def execute(self, plan: MotionPlan, on_cycle: Callable[[CycleInfo], None] | None = None,
                record: bool = False) -> StreamResult:
        """Stream a plan, stopping safely on Ctrl-C or a fault.

        A second Ctrl-C during the stop applies the exit policy once the arm is at rest.

        Raises:
            MotionStopped: The motion was stopped; the arm holds its position (or the exit
                policy was applied after a second Ctrl-C).
        """
        q_now = self.joints()
        gap = np.abs(q_now[self.executor.idx] - plan.start[self.executor.idx])
        if float(np.max(gap, initial=0.0)) > _START_TOLERANCE:
            j = self.bus.joint_names[int(np.argmax(gap))]
            raise InputError(f"the plan starts {float(np.max(gap)):.3f} away from the present "
                             f"position of joint {j!r}; plan again from the present position")
        self.stop.clear()
        try:
            with sigint_stops(self.stop):
                return self.executor.run(plan, self.stop, on_cycle, record)
        except MotionStopped:
            if self.stop.escalated:
                self.apply_exit_policy(self.exit_policy)
                self._closed = self._closed or self.exit_policy is not ExitPolicy.HOLD
            raise

    def move_joints(self, q: npt.ArrayLike, speed: float | None = None, dry_run: bool = False,
                    on_cycle: Callable[[CycleInfo], None] | None = None) -> MoveReport:
        """Move all joints to ``q`` [rad]/[m] together."""
        plan = self.plan_joints(q, speed)
        if dry_run:
            return MoveReport(plan)
        res = self.execute(plan, on_cycle)
        return MoveReport(plan, res, reached=self.arm.fk(res.final))

    def move_to_pose(self, goal: Goal | None = None, *, xyz: npt.ArrayLike | None = None,
                     linear: bool = False, speed: float | None = None, solver: str = "auto",
                     dry_run: bool = False,
                     on_cycle: Callable[[CycleInfo], None] | None = None) -> MoveReport:
        """Move the tool to a goal (or to position ``xyz`` [m]); report the reached pose.

        The reached pose is FK of the joints read back after the servos settled.
        """
        if goal is None:
            if xyz is None:
                raise InputError("give a goal or xyz")
            goal = PositionGoal(np.asarray(xyz, dtype=float))
        plan, ik = self.plan_pose(goal, linear=linear, speed=speed, solver=solver)
        if dry_run:
            return MoveReport(plan, None, ik)
        res = self.execute(plan, on_cycle)
        reached = self.arm.fk(res.final, goal.frame)
        dp, dr = goal.errors(reached)
        return MoveReport(plan, res, ik, reached, dp, dr)

    def home(self, speed: float | None = None, dry_run: bool = False,
             on_cycle: Callable[[CycleInfo], None] | None = None) -> MoveReport:
        """Move to the arm's ``home`` pose."""
        return self._named("home", speed, dry_run, on_cycle)

    def park(self, speed: float | None = None, dry_run: bool = False,
             on_cycle: Callable[[CycleInfo], None] | None = None) -> MoveReport:
        """Move to the arm's ``park`` pose."""
        return self._named("park", speed, dry_run, on_cycle)

    def _named(self, pose: str, speed: float | None, dry_run: bool,
               on_cycle: Callable[[CycleInfo], None] | None) -> MoveReport:
        plan = self.plan_joints(self.arm.named_pose(pose), speed, f"move to the {pose!r} pose")
        if dry_run:
            return MoveReport(plan)
        res = self.execute(plan, on_cycle)
        return MoveReport(plan, res, reached=self.arm.fk(res.final))

    def plan_program(self, program: KeyframeProgram, options: PlaybackOptions | None = None,
                     solver: str = "auto") -> MotionPlan:
        """A checked plan of a keyframe program from the present pose."""

        def ik(pose: Array, seed: Array, orientation: bool) -> Array:
            from armctl.ik import PoseGoal

            frame = program.frame or None
            goal: Goal = (PoseGoal(pose, frame=frame) if orientation else
                          PositionGoal(pose[:3, 3], frame=frame))
            q = np.asarray(self.solve(goal, solver, seed).q, dtype=float).copy()
            still = [i for i in range(self.arm.dof) if i not in set(self.arm.chain(frame))]
            q[still] = seed[still]
            return q

        return plan_program(program, self.arm, self.limits, self.plan_start(),
                            options or PlaybackOptions(), ik)

    def play(self, program: KeyframeProgram, options: PlaybackOptions | None = None,
             dry_run: bool = False, solver: str = "auto",
             on_cycle: Callable[[CycleInfo], None] | None = None) -> MoveReport:
        """Play a keyframe program (see :class:`PlaybackOptions`)."""
        plan = self.plan_program(program, options, solver)
        if dry_run:
            return MoveReport(plan)
        res = self.execute(plan, on_cycle)
        return MoveReport(plan, res, reached=self.arm.fk(res.final))

    def teach(self, path: str | Path, release: Sequence[str] | None = None) -> TeachSession:
        """A started teach session writing ``path`` (the released joints go limp).

        See :class:`armctl.robot.teach.TeachSession`; call ``finish()`` to stiffen again.
        """
        from armctl.robot.teach import TeachSession

        session = TeachSession(self, path, release)
        session.start()
        return session

    @property
    def gripper_joints(self) -> tuple[str, ...]:
        """Names of the gripper joints."""
        return tuple(n for n, r in zip(self.arm.joint_names, self.arm.joint_roles, strict=True)
                     if r is JointRole.GRIPPER)

    def calibration_hash(self) -> str | None:
        """Hash of the calibration in use, if any."""
        cal = getattr(self.bus, "calibration", None)
        return None if cal is None else str(cal.hash)


def _calibration(arm: Arm) -> Calibration | None:
    """The arm's calibration when its file exists (else the config's offsets are used)."""
    from armctl.servo.calibration import Calibration, calibration_path

    if arm.spec.bus is None or arm.spec.file is None:
        return None
    try:
        path = calibration_path(arm.spec)
    except InputError:
        return None
    return Calibration.load(path) if path.exists() else None
