"""The Python API: an arm, its bus and the motion core in one context manager.

Example::

    from armctl.robot import Robot

    with Robot.open("so101", speed=0.5) as robot:       # port 'sim' runs the simulated bus
        robot.move_to_pose(xyz=[0.2, 0.0, 0.15])
        robot.home()
    # leaving the block normally applies the exit policy (hold by default: torque stays on);
    # leaving it with an exception (a stop, Ctrl-C, an error) holds the arm where it is
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from armctl.arm import Arm, load_arm
from armctl.clock import Clock, default_clock
from armctl.collision.errors import CollisionError
from armctl.collision.model import CollisionModel
from armctl.config.motion import ExitPolicy, MotionSpec
from armctl.config.scene import SceneSpec
from armctl.config.schema import JointRole, JointType
from armctl.errors import ArmctlError, InputError
from armctl.ik import Goal, IKResult, IKStatus, PositionGoal
from armctl.motion import (
    KeyframeProgram,
    MotionLimits,
    MotionPlan,
    PlaybackOptions,
    check_trajectory,
    plan_joint_move,
    plan_program,
)
from armctl.motion.cartesian import LineOptions, plan_line
from armctl.motion.collisions import trajectory_contact
from armctl.motion.detour import DetourOptions, Planner, plan_detour
from armctl.motion.errors import LimitViolation
from armctl.robot.errors import MotionStopped
from armctl.robot.executor import CycleInfo, Executor, JointBus, StreamResult
from armctl.robot.live_state import Activity
from armctl.robot.motion_control import MotionControl
from armctl.robot.stop import StopRequest
from armctl.robot.unreachable import unreachable
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.robot.live_publisher import LivePublisher
    from armctl.servo.calibration import Calibration
    from armctl.servo.effective_limits import EffectiveLimits

__all__ = ["MoveReport", "Robot"]


logger = logging.getLogger(__name__)

#: Readings this far outside an effective limit are planned from the limit itself: rotary
#: [rad], prismatic [m]; at least the joint's safety margin plus :data:`_NOISE_TICKS`, so that a
#: joint resting at the stop it was calibrated to can be held (see :meth:`Robot.plan_start`).
_OUTSIDE_ROTARY = 0.02
_OUTSIDE_LINEAR = 0.001
#: Encoder noise and settling beyond the safety margin [servo tick].
_NOISE_TICKS = 4
#: Largest distance between a plan's start and the present position for it to be run: rotary
#: [rad], prismatic [m]; at least 1.5 times the outside tolerance.
_START_ROTARY = 0.05
_START_LINEAR = 0.002


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
    and use it as a context manager: leaving the block normally applies the exit policy;
    leaving it with an exception (a stopped motion, Ctrl-C, an error) holds the arm where it is
    and never parks or releases it.

    Args:
        arm: The arm model.
        bus: An open bus whose joints are joints of the arm.
        motion: Motion defaults (rate, speed, tracking limit, exit policy).
        speed: Default speed factor (overrides ``motion.speed``).
        exit_policy: Exit policy (overrides ``motion.exit_policy``).
        effective: The effective joint limits; by default they are built from the config, the
            bus's calibration and the servos' position limit registers (read from the bus).
        clock: Time base of motions and teaching (default
            :func:`~armctl.clock.default_clock`); a simulated bus must share it.
        scene: The scene every plan is checked against (default: the arm's ``scene:``
            section, else a table at the base; see :mod:`armctl.collision`).
        collisions: Check plans for contacts (links, table, obstacles). Switching it off
            leaves only the joint limits between a plan and the arm.

    Attributes:
        arm: The arm with the effective limits as its position limits: every planner, IK
            solve, jog and playback of this robot stays inside them.
        config_arm: The arm as configured (its limits are the config's).
        effective: The effective limits, with the source of every bound.
    """

    def __init__(self, arm: Arm, bus: JointBus, motion: MotionSpec | None = None, *,
                 speed: float | None = None, exit_policy: ExitPolicy | None = None,
                 effective: EffectiveLimits | None = None, clock: Clock | None = None,
                 scene: SceneSpec | None = None, collisions: bool = True):
        arm.require_one_dof("a robot on a servo bus (servos drive 1-DOF joints)")
        self.config_arm = arm
        self.scene = scene
        self.check_collisions = collisions
        self._collisions: CollisionModel | None = None
        self.clock = clock if clock is not None else default_clock()
        self.bus = bus
        self.effective = effective if effective is not None else _effective_limits(arm, bus)
        self.arm = self.effective.apply(arm)
        self.motion = motion or arm.spec.motion or MotionSpec()
        self.speed = float(speed if speed is not None else min(self.motion.speed, 1.0))
        self.exit_policy = exit_policy or self.motion.exit_policy
        self.limits = MotionLimits.from_model(self.arm)
        self.executor = Executor(bus, self.arm, self.limits, self.motion.rate_hz,
                                 self.motion.max_tracking_error,
                                 explain_short=self._short_cause, clock=self.clock)
        self.stop = StopRequest()
        #: Pause, resume, speed override and stop of every motion this robot streams, from any
        #: thread (see :mod:`armctl.robot.motion_control`).
        self.control = MotionControl()
        #: Called after every streamed motion, also one that ended in a stop or a failure, with
        #: its cycles ``(t [s], commands, measurements)`` (bus joint order, [rad]/[m]); setting
        #: it makes every motion record its cycles (e.g. for a motion log file).
        self.on_motion_cycles: Callable[[tuple[list[float], list[Array], list[Array]]],
                                        None] | None = None
        prismatic = np.array([t is JointType.PRISMATIC for t in self.arm.joint_types], dtype=bool)
        margin = np.array([j.margin for j in self.effective.joints])
        noise = 1.0 + _NOISE_TICKS / max(self.effective.margin_ticks, 1)
        #: How far outside its effective limits a joint's reading is taken as the limit itself
        #: ``(dof,)`` [rad]/[m].
        self.outside_tolerance: Array = np.maximum(
            np.where(prismatic, _OUTSIDE_LINEAR, _OUTSIDE_ROTARY), margin * noise)
        #: Largest distance between a plan's start and the present position ``(dof,)``.
        self.start_tolerance: Array = np.maximum(np.where(prismatic, _START_LINEAR, _START_ROTARY),
                                                 1.5 * self.outside_tolerance)
        # Joints without a servo (if any) are taken to stay at zero, clipped into their limits.
        self._q = np.clip(np.zeros(arm.dof), self.arm.lower, self.arm.upper)
        self._closed = False
        self._owns_bus = False
        #: Serves this robot's live state to other processes (``armctl status``/``view`` on the
        #: same port; see :mod:`armctl.robot.live_publisher`): started by :meth:`open` on a
        #: real port (a device or an ``armctl sim`` pty), ``None`` on the built-in simulated bus.
        self.live: LivePublisher | None = None
        self._activity: Activity | None = None  # what streamed plans are, for watchers

    # ---- life cycle -------------------------------------------------------------------------
    @classmethod
    def open(cls, config: str | Path | Arm, *, speed: float | None = None,
             exit_policy: ExitPolicy | None = None, hold: bool = True,
             clock: Clock | None = None, port: str | None = None, sim: bool = False,
             scene: SceneSpec | None = None, collisions: bool = True,
             publish: bool = True) -> Robot:
        """Load an arm, open its bus and hold the present pose with torque on.

        Args:
            config: Arm YAML path, bundled name, or an :class:`Arm`.
            speed: Default speed factor in (0, 1].
            exit_policy: What to do at the end (default from the config: hold).
            hold: Switch torque on, holding the present pose (no jump). Without it nothing is
                written until the first motion, which holds the present pose first: a plan can
                be checked (and refused) before torque comes on.
            clock: Time base of the motions and, for ``port: sim``, of the simulated servos
                (default :func:`~armctl.clock.default_clock`); a
                :class:`~armctl.clock.SimulatedClock` runs them in simulated time.
            port: Drive the servos on this port instead of the config's (a serial device, or
                the pty of a running ``armctl sim``).
            sim: Use the built-in simulated bus, also for an arm without a ``bus:`` section
                (one simulated servo per joint, see :mod:`armctl.robot.bus_choice`).
            scene: The scene plans are checked against (default: the arm's).
            collisions: Check plans for contacts (default on).
            publish: On a real port, serve the robot's live state to watching processes
                (:attr:`live`).

        Raises:
            InputError: Both ``port`` and ``sim``, or ``port`` for an arm without a ``bus:``
                section.
            ConfigError: Bad config or calibration file.
            BusError: The bus cannot be opened or a servo is missing.
            JointLimitError: With ``hold``, a joint further outside its effective limits than
                encoder noise (move it inside by hand with torque off).
        """
        from armctl.robot.bus_choice import arm_on_bus
        from armctl.servo.arm_bus import ArmBus

        arm = config if isinstance(config, Arm) else load_arm(config)
        arm = arm_on_bus(arm, port, sim)
        calibration = _calibration(arm)
        clock = clock if clock is not None else default_clock()
        bus = ArmBus.from_spec(arm.spec, calibration, clock=clock).open()
        robot: Robot | None = None
        try:
            robot = cls(arm, bus, speed=speed, exit_policy=exit_policy, clock=clock,
                        scene=scene, collisions=collisions)
            robot._owns_bus = True
            if publish and not bus.spec.simulated:
                robot._publish_live()
            if hold:
                robot.hold()
        except BaseException:
            bus.close()
            if robot is not None and robot.live is not None:
                robot.live.close()
            raise
        return robot

    def __enter__(self) -> Robot:
        return self

    def __exit__(self, exc_type: type[BaseException] | None, *exc: object) -> None:
        if exc_type is None:
            self.close()
            return
        # A stop, Ctrl-C or an error ended the block: hold, never a surprise drive to park.
        self.close_holding(f"the block ended with {exc_type.__name__}")

    def close_holding(self, why: str) -> None:
        """Close after a stop, an error or a signal: hold where the arm is, never park or release.

        Logs a warning when that skips the exit policy, and one (instead of raising) when
        closing the bus fails, so that the error that ended the block or command is not hidden.

        Args:
            why: What ended it, for the warning, e.g. ``"the motion was stopped"``.
        """
        if self.exit_policy is not ExitPolicy.HOLD and not self._closed:
            logger.warning("%s: holding the arm where it is (exit policy %r not applied)", why,
                           self.exit_policy.value)
        try:
            self.close(ExitPolicy.HOLD)
        except ArmctlError as failure:
            logger.warning("closing the bus failed: %s", failure)

    def close(self, policy: ExitPolicy | None = None) -> None:
        """Apply an exit policy and close the bus (if this robot opened it).

        Args:
            policy: The policy to apply (default: the robot's :attr:`exit_policy`). An explicit
                policy is applied even after a stopped motion.
        """
        if self._closed:
            return
        self._closed = True
        try:
            self.apply_exit_policy(policy or self.exit_policy)
        finally:
            if self._owns_bus:
                self.bus.close()  # type: ignore[attr-defined]
            if self.live is not None:
                self.live.close()
                self.live = None

    def _publish_live(self) -> None:
        """Serve the live state of this robot's port to watchers (:attr:`live`)."""
        from armctl.robot.live_publisher import publish_robot

        spec = self.arm.spec
        names = self.bus.joint_names
        units = ["m" if self.arm.joint_types[self.arm.joint_index(n)] is JointType.PRISMATIC
                 else "rad" for n in names]
        self.live = publish_robot(self, spec.name, str(spec.file or spec.name),
                                  str(self.bus.spec.port), names, units)  # type: ignore[attr-defined]

    def apply_exit_policy(self, policy: ExitPolicy) -> None:
        """Hold (torque stays on), park (move to the 'park' pose, then hold) or release.

        Parking is a motion like any other: a stop signal during it decelerates and holds.
        While the motions are paused (:meth:`pause`) the arm holds instead of parking.
        When the straight joint-space move to ``park`` collides, a way around is planned
        (:func:`~armctl.motion.detour.plan_detour`); when none is found the arm holds.

        Raises:
            MotionStopped: Parking was stopped; the arm holds where it stopped.
            CollisionError, DetourError: No collision-free way to park; the arm holds.
        """
        if policy is ExitPolicy.PARK:
            if "park" not in self.arm.spec.poses:
                logger.warning("arm %r has no 'park' pose; holding instead", self.arm.name)
                return
            if self.control.paused:  # a pause holds the arm until resumed, also at the end
                logger.warning("the motions are paused: holding instead of parking (resume "
                               "before the end to park)")
                return
            plan = self.plan_joints(self.arm.named_pose("park"), min(self.speed, 0.5),
                                    "park (exit policy)", DetourOptions(planner=Planner.BUILTIN))
            self.execute(plan)
        elif policy is ExitPolicy.RELEASE:
            logger.warning("releasing torque: a raised arm will fall")
            self.bus.set_torque(False)
            if self.live is not None:
                self.live.torque = False

    @property
    def simulated(self) -> bool:
        """Whether the bus is the built-in simulated bus."""
        return getattr(self.bus, "simulator", None) is not None

    # ---- state --------------------------------------------------------------------------------
    def joints(self) -> Array:
        """Present joint values of the whole arm ``(dof,)`` [rad]/[m] (one sync read)."""
        q = self._q.copy()
        q[self.executor.idx] = read = self.bus.read_joints()
        if self.live is not None:
            self.live.reading(read)
        return q

    def pose(self, frame: str | None = None) -> Array:
        """FK of the present joints: the tool pose ``(4, 4)`` [m]."""
        return self.arm.fk(self.joints(), frame)

    def hold(self) -> Array:
        """Hold the present pose: goal = present position, then torque on.

        Raises:
            JointLimitError: A joint is further outside its effective limits than encoder
                noise; nothing was written (move it inside by hand with torque off).
        """
        self.plan_start()  # never command a goal outside the effective limits
        self.executor.hold()
        if self.live is not None:
            self.live.torque = True
        return self.joints()

    def _short_cause(self, joint: str, goal: float) -> str | None:
        """Why a joint stopped short of ``goal``, when its servo's registers tell.

        Returns:
            A sentence when the servo's position limit registers (read again now) exclude the
            goal, else ``None``.
        """
        from armctl.servo.arm_bus import ArmBus
        from armctl.servo.effective_limits import format_joint_value, limits_of_bus

        if not isinstance(self.bus, ArmBus):
            return None
        try:
            now = limits_of_bus(self.config_arm.spec, self.bus).joint(joint)
        except ArmctlError:
            return None
        if now.register is None or now.register_ticks is None or \
                now.register[0] <= goal <= now.register[1]:
            return None
        lo, hi = (format_joint_value(v, now.joint_type) for v in now.register)
        return (f"Likely cause: servo {now.servo_id}'s own position limit registers (Min/Max "
                f"Position Limit: {now.register_ticks[0]}..{now.register_ticks[1]} ticks) allow "
                f"only {lo} to {hi}, which excludes the goal, so the servo stops at its limit. "
                "They differ from when the robot was opened (its effective limits were read "
                "then): open it again to plan inside them, or write wider values to the "
                "registers (torque off).")

    # ---- planning -----------------------------------------------------------------------------
    def plan_start(self) -> Array:
        """The present joints as the start of a plan.

        A reading just outside an effective limit (up to :attr:`outside_tolerance`: 0.02 rad or
        1 mm, and at least the joint's safety margin plus encoder noise, so that a joint
        resting at its calibrated stop or at its servo's limit register is accepted) is taken
        as the limit itself.

        Raises:
            JointLimitError: If a joint is further outside its effective limits (naming the
                limit's source); nothing moves.
        """
        q = self.joints()
        lo, hi = self.arm.lower, self.arm.upper
        out = np.maximum(lo - q, q - hi) - self.outside_tolerance
        if float(np.max(out, initial=0.0)) > 0.0:
            i = int(np.argmax(out))
            raise self.effective.error(self.arm.joint_names[i], float(q[i]),
                                       "present position: move the joint inside by hand with "
                                       "torque off")
        return np.clip(q, lo, hi)

    @property
    def collisions(self) -> CollisionModel | None:
        """The collision model plans are checked against (``None``: checking is off)."""
        if not self.check_collisions:
            return None
        if self._collisions is None:
            self._collisions = CollisionModel.of(self.arm, self.scene)
        return self._collisions

    def check_collisions_of(self, plan: MotionPlan) -> None:
        """Refuse a plan that brings a link into contact with another, the table or an obstacle.

        Checked continuously (nothing can pass through a thin obstacle between samples). A
        pair already in contact at the plan's start may separate but not go deeper.

        Raises:
            CollisionError: Names the pair, when and at which joints, and how deep; nothing
                moves.
        """
        model = self.collisions
        if model is None:
            return
        checker = model.escaping(plan.start)
        contact = trajectory_contact(plan.trajectory, self.limits, checker)
        if contact is not None:
            hint = ("Choose another goal or add a keyframe around it, move an obstacle, or edit "
                    "the scene")
            start = model.contact(plan.start) if checker is not model else None
            if start is not None:
                hint = (f"The arm starts in contact ({start.describe()}): a pair in contact may "
                        "only move apart, and every other pair (another capsule of the same "
                        "link too) keeps its padding. " + hint)
            raise CollisionError(plan.description or "the motion", contact,
                                 self.arm.joint_names, hint)

    def _speed(self, speed: float | None) -> float:
        return self.speed if speed is None else float(speed)

    def plan_joints(self, q: npt.ArrayLike, speed: float | None = None,
                    description: str = "joint move", detour: DetourOptions | None = None
                    ) -> MotionPlan:
        """A checked joint move from the present position.

        Args:
            q: Goal joint values [rad]/[m].
            speed: Speed factor (default: the robot's).
            description: Text for the plan.
            detour: When the straight joint-space move collides, plan a way around with these
                options (:func:`~armctl.motion.detour.plan_detour`); ``None``: refuse it.

        Raises:
            JointLimitError: A goal outside the effective limits, naming the limit's source
                (config, calibration or servo register) and how to change it; nothing moves.
            CollisionError: The move collides (and no detour was asked for, or the goal
                itself collides); nothing moves.
            DetourError: No way around was found within the detour's time budget.
        """
        goal = self.effective.check(self.arm.as_q(q, "goal of the move"), "goal of the move")
        return self._joint_plan(self.plan_start(), goal, speed, description, detour)

    def _joint_plan(self, start: Array, goal: Array, speed: float | None, description: str,
                    detour: DetourOptions | None) -> MotionPlan:
        """A checked joint move ``start`` -> ``goal``, around obstacles if asked for."""
        with self._limit_sources():
            plan = plan_joint_move(start, goal, self.limits, self._speed(speed), description)
        try:
            self.check_collisions_of(plan)
        except CollisionError:
            model = self.collisions
            if detour is None or model is None:
                raise
            with self._limit_sources():
                plan = plan_detour(model.escaping(start), start, goal, self.limits,
                                   self._speed(speed), detour)
            plan = replace(plan, description=f"{description}, {plan.description}")
            self.check_collisions_of(plan)
        return plan

    @contextmanager
    def _limit_sources(self) -> Iterator[None]:
        """Re-raise a planned position beyond a limit with the source of that limit."""
        try:
            yield
        except LimitViolation as exc:
            if exc.kind != "position" or exc.joint not in self.effective.names:
                raise
            raise LimitViolation(exc.joint, exc.kind, exc.value, exc.bound, exc.time,
                                 "The path swings outside the joint's effective range: add a "
                                 "keyframe there, stop at keyframes, or use linear "
                                 "interpolation. "
                                 + self.effective.explain(exc.joint, exc.value),
                                 exc.unit) from None

    def solve(self, goal: Goal, solver: str = "auto", q0: npt.ArrayLike | None = None
              ) -> IKResult:
        """IK from the present joints, keeping out of contact (with :attr:`collisions`).

        Answers that bring a link into contact are discarded and the search goes on (see
        :meth:`armctl.arm.Arm.ik`, ``avoid``).

        Raises:
            IKFailedError: A :class:`NoSolutionError` with the closest distance found, when the
                goal cannot be reached; its ``details`` hold the closest joints and errors.
            CollisionError: Every answer found for the goal brings a link into contact (names
                the shallowest contact); nothing moves.
        """
        start = self.joints() if q0 is None else np.asarray(q0, dtype=float)
        res = self.arm.ik(goal, q0=start, solver=solver, avoid=self.collisions)
        if res.status is IKStatus.COLLIDES and res.contact is not None:
            hint = ("The goal puts a link in contact: choose another goal or orientation, or "
                    "edit the scene")
            model = self.collisions
            table = None if model is None else model.scene.table
            pos = getattr(goal, "position", None)
            if table is not None and isinstance(pos, np.ndarray) and pos.shape == (3,) \
                    and float(pos[2]) < table.height:
                hint = (f"The goal's z={float(pos[2]):.3f} m is "
                        f"{(table.height - float(pos[2])) * 1000:.0f} mm below the table top "
                        f"(z={table.height:.3f} m in the base frame). " + hint)
            raise CollisionError("every IK answer found for the goal", res.contact,
                                 self.arm.joint_names, hint)
        if not res.success:
            narrowed = self.effective.narrowed()
            which = ", ".join(f"{n} ({'/'.join(s)})" for n, s in narrowed.items())
            note = (f"IK searched inside the effective limits, narrower than the config for: "
                    f"{which} (see 'armctl status')." if narrowed else "")
            raise unreachable(self.arm, goal, res, res.status.value, note=note)
        return res

    def plan_pose(self, goal: Goal, *, linear: bool = False, speed: float | None = None,
                  solver: str = "auto", tcp_speed: float | None = None,
                  tcp_angular_speed: float | None = None, detour: DetourOptions | None = None
                  ) -> tuple[MotionPlan, IKResult | None]:
        """A checked move of the tool to a goal: joint-space (IK at the goal) or a straight line.

        ``tcp_speed`` [m/s] and ``tcp_angular_speed`` [rad/s] bound the goal frame's speeds on a
        straight line (with ``linear``; see :class:`~armctl.motion.cartesian.LineOptions`).

        Raises:
            InputError: A TCP speed without ``linear``.
            NoSolutionError: Goal unreachable (nothing moves).
            PathError: A straight line that cannot be followed (with where it fails).
        """
        if linear and detour is not None:
            raise InputError("a straight-line move that collides is refused, never replaced by "
                             "a detour: plan a detour with a joint-space move (linear=False)")
        if not linear and (tcp_speed is not None or tcp_angular_speed is not None):
            raise InputError("a TCP speed applies to a straight-line move (linear=True); a "
                             "joint-space move is timed by the speed factor")
        try:
            options = LineOptions(solver=solver, tcp_speed=tcp_speed,
                                  tcp_angular_speed=tcp_angular_speed)
        except ValueError as exc:
            raise InputError(str(exc)) from None
        start = self.plan_start()
        if linear:
            with self._limit_sources():
                plan = plan_line(self.arm, start, goal, self.limits, self._speed(speed),
                                 options)
            self.check_collisions_of(plan)
            return plan, None
        res = self.solve(goal, solver, start)
        # Keep joints the goal does not involve (the gripper) where they are.
        q = np.asarray(res.q, dtype=float).copy()
        moving = set(self.arm.chain(goal.frame))
        for i in range(self.arm.dof):
            if i not in moving:
                q[i] = start[i]
        q = self.effective.check(q, "IK solution of the goal")
        return self._joint_plan(start, q, speed, "move to pose", detour), res

    # ---- moving -------------------------------------------------------------------------------
    def pause(self) -> None:
        """Decelerate the running motion to a stop on its path and hold (any thread).

        See :meth:`MotionControl.pause <armctl.robot.motion_control.MotionControl.pause>`;
        motions started while paused start held until :meth:`resume`.
        """
        self.control.pause()

    def resume(self) -> None:
        """Go on along the path after :meth:`pause` (any thread)."""
        self.control.resume()

    def set_speed(self, speed: float) -> float:
        """Set the speed override of running and later motions (any thread).

        See :meth:`MotionControl.set_speed
        <armctl.robot.motion_control.MotionControl.set_speed>`.

        Args:
            speed: Times as fast as planned [-], 0.01 to 100; capped at what the running
                plan's joint limits allow.

        Returns:
            The override applied to the running motion.

        Raises:
            InputError: For a bad factor (NaN, zero, negative, out of range).
        """
        return self.control.set_speed(speed)

    def execute(self, plan: MotionPlan, on_cycle: Callable[[CycleInfo], None] | None = None,
                record: bool = False) -> StreamResult:
        """Check a plan, then stream it, stopping safely on a stop signal or a fault.

        The plan is checked first (:meth:`check_plan`); a refused plan writes nothing. SIGINT
        (Ctrl-C), SIGTERM and SIGHUP (main thread), or a ``KeyboardInterrupt`` raised by
        ``on_cycle``, decelerate the arm within its limits and hold it; a second one during the
        deceleration holds at once. The exit policy is not applied. The motion follows
        :attr:`control` (:meth:`pause`, :meth:`resume`, :meth:`set_speed`, from any thread) by
        time scaling along the plan's path.

        Raises:
            ServoAlarmError, JointLimitError, LimitViolation, InputError: The plan was refused
                (see :meth:`check_plan`); nothing was written.
            MotionStopped: The motion was stopped; the arm holds its position, and
                ``stopped_at`` (also in ``details``) says where: the joints read back and the
                tool pose.
        """
        self.check_plan(plan)
        self.stop.clear()
        listener = self.on_motion_cycles
        if listener is not None:
            record = True
            self.executor.last_log = ([], [], [])
        live = self.live
        if live is not None:  # watchers see every cycle (stored, never waited for)
            from armctl.robot.live_publisher import cycle_hook

            live.torque = True
            activity = self._activity or Activity.of_verb(live.hello.verb)
            on_cycle = cycle_hook(live, activity, plan.description, on_cycle)
        try:
            return self.executor.run(plan, self.stop, on_cycle, record, self.control)
        except MotionStopped as stopped:
            self._locate(stopped)
            raise
        finally:
            if live is not None:
                live.idle()
            if listener is not None:
                listener(self.executor.last_log)

    def check_plan(self, plan: MotionPlan) -> None:
        """Refuse a plan this robot cannot run as it is (nothing is written to the servos).

        Every sample must lie inside the effective limits (a plan made elsewhere, e.g. by
        :func:`~armctl.motion.plan_joint_move` with the config's limits or by another robot, is
        not clipped into them), within the velocity and acceleration limits, and start at the
        present position (within :attr:`start_tolerance`); no servo may be in the alarm
        lock-out; no link may come into contact (:meth:`check_collisions_of`).

        Raises:
            ServoAlarmError: A servo reported a hardware alarm and was not cleared (names it,
                and how to clear it).
            CollisionError: A contact along the plan (names the pair, time, joints, depth).
            JointLimitError: A sample outside the effective limits, naming the limit's source.
            LimitViolation: A sample beyond a velocity or acceleration limit.
            InputError: A plan for another number of joints, or one that starts elsewhere.
        """
        from armctl.servo.arm_bus import ArmBus
        from armctl.servo.effective_limits import format_joint_value

        if isinstance(self.bus, ArmBus):
            self.bus.refuse_alarmed("the motion")
        if plan.start.shape != (self.arm.dof,):
            raise InputError(f"the plan is for {plan.start.size} joints, arm "
                             f"{self.arm.name!r} has {self.arm.dof}; plan it with this robot")
        try:
            check_trajectory(plan.trajectory, self.limits)
        except LimitViolation as exc:
            if exc.kind != "position" or exc.joint not in self.effective.names:
                raise
            raise self.effective.error(exc.joint, exc.value, f"{plan.description} at "
                                       f"t={exc.time:.3f} s: a plan made with other limits; "
                                       "plan it with this robot") from None
        gap = np.abs(self.joints() - plan.start) - self.start_tolerance
        idx = self.executor.idx
        if float(np.max(gap[idx], initial=0.0)) > 0.0:
            i = int(idx[int(np.argmax(gap[idx]))])
            far = format_joint_value(float(gap[i] + self.start_tolerance[i]),
                                     self.arm.joint_types[i])
            raise InputError(f"the plan starts {far} away from the present position of joint "
                             f"{self.arm.joint_names[i]!r}; plan again from the present "
                             "position")
        self.check_collisions_of(plan)

    def _locate(self, stopped: MotionStopped) -> None:
        """Record on ``stopped`` where the arm stopped (joints read back, else the held goal)."""
        from armctl.errors import BusError
        from armctl.spatial import matrix_to_rpy

        q: Array | None
        try:
            q = self.joints()
        except BusError:
            q = None if stopped.held is None else np.asarray(stopped.held, dtype=np.float64)
        if q is None or q.shape != (self.arm.dof,):
            return
        pose = self.arm.fk(q)
        stopped.locate(self.arm.values_by_name(q), pose[:3, 3], matrix_to_rpy(pose[:3, :3]))

    def move_joints(self, q: npt.ArrayLike, speed: float | None = None, dry_run: bool = False,
                    on_cycle: Callable[[CycleInfo], None] | None = None,
                    detour: DetourOptions | None = None) -> MoveReport:
        """Move all joints to ``q`` [rad]/[m] together (around obstacles with ``detour``)."""
        plan = self.plan_joints(q, speed, detour=detour)
        if dry_run:
            return MoveReport(plan)
        res = self.execute(plan, on_cycle)
        return MoveReport(plan, res, reached=self.arm.fk(res.final))

    def move_to_pose(self, goal: Goal | None = None, *, xyz: npt.ArrayLike | None = None,
                     linear: bool = False, speed: float | None = None, solver: str = "auto",
                     dry_run: bool = False,
                     on_cycle: Callable[[CycleInfo], None] | None = None,
                     on_plan: Callable[[MotionPlan, IKResult | None], bool] | None = None,
                     tcp_speed: float | None = None, tcp_angular_speed: float | None = None,
                     detour: DetourOptions | None = None) -> MoveReport:
        """Move the tool to a goal (or to position ``xyz`` [m]); report the reached pose.

        The reached pose is FK of the joints read back after the servos settled.

        Args:
            goal: The goal (its frame, position and orientation or direction).
            xyz: Instead of ``goal``: a position of the tool [m].
            linear: Move the tool along a straight line (else a joint-space move to the IK
                solution).
            speed: Speed factor of the joint limits (default: the robot's).
            solver: IK solver name.
            dry_run: Plan only; nothing moves.
            on_cycle: Called every control cycle while the plan streams.
            on_plan: Called with the checked plan and the IK result (``None`` for a straight
                line) before anything moves; when it returns ``False`` nothing moves and the
                report is that of a dry run (e.g. to show the plan first, or to skip a plan
                that does not move the arm).
            tcp_speed: With ``linear``: largest speed of the goal's frame [m/s].
            tcp_angular_speed: With ``linear``: largest angular speed of the goal's frame
                [rad/s].
            detour: For a joint-space move that collides: plan a way around with these
                options (``None``: refuse it). A straight line is never replaced by a detour.
        """
        if goal is None:
            if xyz is None:
                raise InputError("give a goal or xyz")
            goal = PositionGoal(np.asarray(xyz, dtype=float))
        plan, ik = self.plan_pose(goal, linear=linear, speed=speed, solver=solver,
                                  tcp_speed=tcp_speed, tcp_angular_speed=tcp_angular_speed,
                                  detour=detour)
        if dry_run or (on_plan is not None and not on_plan(plan, ik)):
            return MoveReport(plan, None, ik)
        res = self.execute(plan, on_cycle)
        reached = self.arm.fk(res.final, goal.frame)
        dp, dr = goal.errors(reached)
        return MoveReport(plan, res, ik, reached, dp, dr)

    def home(self, speed: float | None = None, dry_run: bool = False,
             on_cycle: Callable[[CycleInfo], None] | None = None,
             detour: DetourOptions | None = None) -> MoveReport:
        """Move to the arm's ``home`` pose (around obstacles with ``detour``)."""
        return self._named("home", speed, dry_run, on_cycle, detour)

    def park(self, speed: float | None = None, dry_run: bool = False,
             on_cycle: Callable[[CycleInfo], None] | None = None,
             detour: DetourOptions | None = None) -> MoveReport:
        """Move to the arm's ``park`` pose (around obstacles with ``detour``)."""
        return self._named("park", speed, dry_run, on_cycle, detour)

    def _named(self, pose: str, speed: float | None, dry_run: bool,
               on_cycle: Callable[[CycleInfo], None] | None,
               detour: DetourOptions | None = None) -> MoveReport:
        plan = self.plan_joints(self.arm.named_pose(pose), speed, f"move to the {pose!r} pose",
                                detour)
        if dry_run:
            return MoveReport(plan)
        res = self.execute(plan, on_cycle)
        return MoveReport(plan, res, reached=self.arm.fk(res.final))

    def plan_program(self, program: KeyframeProgram, options: PlaybackOptions | None = None,
                     solver: str = "auto") -> MotionPlan:
        """A checked plan of a keyframe program from the present pose.

        Raises:
            JointLimitError: A joint keyframe (or gripper value) inside the config's limits but
                outside the effective ones, naming the keyframe and the limit's source.
            ConfigError: A keyframe outside the config's limits.
            LimitViolation: A sample of the plan beyond a limit.
        """
        self._check_keyframes(program)

        def ik(pose: Array, seed: Array, orientation: bool) -> Array:
            from armctl.ik import PoseGoal

            frame = program.frame or None
            goal: Goal = (PoseGoal(pose, frame=frame) if orientation else
                          PositionGoal(pose[:3, 3], frame=frame))
            q = np.asarray(self.solve(goal, solver, seed).q, dtype=float).copy()
            still = [i for i in range(self.arm.dof) if i not in set(self.arm.chain(frame))]
            q[still] = seed[still]
            return q

        with self._limit_sources():
            plan = plan_program(program, self.arm, self.limits, self.plan_start(),
                                options or PlaybackOptions(), ik)
        self.check_collisions_of(plan)
        return plan

    def _check_keyframes(self, program: KeyframeProgram) -> None:
        """Refuse joint values that the config allows but the effective limits do not."""
        cfg = self.config_arm
        grip = [i for i, r in enumerate(self.arm.joint_roles) if r is JointRole.GRIPPER]
        for k, kf in enumerate(program.keyframes):
            values: list[tuple[int, float]] = []
            if kf.q is not None:
                values += [(self.arm.joint_index(n), float(v))
                           for n, v in zip(program.joints, kf.q, strict=True)]
            if kf.gripper is not None:
                values += [(i, float(kf.gripper)) for i in grip]
            for i, v in values:
                inside_config = cfg.lower[i] - 1e-9 <= v <= cfg.upper[i] + 1e-9
                if inside_config and not self.arm.lower[i] - 1e-9 <= v <= self.arm.upper[i] + 1e-9:
                    where = f", {kf.where.where()}" if kf.where.file or kf.where.keys else ""
                    raise self.effective.error(self.arm.joint_names[i], v,
                                               f"keyframe {k} ({kf.label}){where}")

    def play(self, program: KeyframeProgram, options: PlaybackOptions | None = None,
             dry_run: bool = False, solver: str = "auto",
             on_cycle: Callable[[CycleInfo], None] | None = None) -> MoveReport:
        """Play a keyframe program (see :class:`PlaybackOptions`)."""
        plan = self.plan_program(program, options, solver)
        if dry_run:
            return MoveReport(plan)
        self._activity = Activity.PLAY
        try:
            res = self.execute(plan, on_cycle)
        finally:
            self._activity = None
        return MoveReport(plan, res, reached=self.arm.fk(res.final))

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
    from armctl.servo.calibration import load_calibration

    return load_calibration(arm.spec)


def _effective_limits(arm: Arm, bus: JointBus) -> EffectiveLimits:
    """The effective limits of an arm on a bus.

    On an :class:`~armctl.servo.arm_bus.ArmBus`: the config, its calibration and the servos'
    position limit registers; on another bus: the config's limits.
    """
    from armctl.servo.arm_bus import ArmBus
    from armctl.servo.effective_limits import effective_limits, limits_of_bus

    if isinstance(bus, ArmBus):
        return limits_of_bus(arm.spec, bus)
    return effective_limits(arm.spec)
