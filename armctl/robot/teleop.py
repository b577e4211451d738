"""Teleoperation: a leader arm moved by hand, a follower arm that copies it.

Every cycle (at :attr:`TeleopOptions.rate_hz`, 100 Hz by default) one sync read of the leader's
joints (torque off, so a person can move it) and one sync write of the follower's goals. Joints
pair by name; both arms' calibrations apply through their own joint mappings, so the values
passed across are calibrated SI joint values [rad]/[m]. An optional per-joint scale and offset
(:class:`JointScale`) maps a leader joint onto its follower joint.

Nothing is sent raw. Each cycle the leader's target is

* clamped into the follower's effective limits (config, calibration, servo registers): the
  clamp is counted per joint and logged once per joint;
* rate-limited: the command moves toward the target no faster than the follower's velocity
  limit and changes its speed no faster than the acceleration limit, braking in time to stop
  at the target; a jump of the leader larger than the velocity limit allows in one cycle is
  counted per joint;
* kept out of contact (when the follower checks collisions, as it does by default): a command
  is sent only if the step to it and the stop from it (a deceleration at the acceleration
  limit, each joint's travel at most ``v^2 / 2a``) are certified free by the follower's
  collision model. Otherwise the follower brakes toward the stop point of its last safe command
  and waits there until the leader asks for a pose it can reach safely; the cycles are counted
  and the pair is logged once.

:meth:`Teleop.start` first moves the follower to the leader's pose through the motion planner
(jerk-limited, at a modest speed), then :meth:`Teleop.run` follows. A stop request (SIGINT /
Ctrl-C, SIGTERM, SIGHUP, or :meth:`StopRequest.request`) ends following with a controlled
stop: a jerk-limited deceleration from the commanded state, streamed by the robot's executor,
after which the follower holds with torque on (a second request holds at once).

Recording (:class:`TeleopRecorder`): keyframes on demand (:meth:`TeleopRecorder.mark`) or a
continuous trajectory sampled at a fixed period, written to a keyframe file of the follower
that ``armctl play`` replays. The file is written atomically; an existing file is refused
unless overwriting is asked for.
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from armctl.collision.contact import Contact
from armctl.collision.model import CollisionModel
from armctl.errors import (
    ArmctlError,
    BusError,
    ConfigError,
    InputError,
    KeyPath,
    UnknownNameError,
)
from armctl.motion import Keyframe, KeyframeProgram, MotionPlan, save_keyframes, stop_trajectory
from armctl.robot.errors import MotionStopped
from armctl.robot.live_state import Activity
from armctl.robot.session import Robot
from armctl.robot.stop import StopRequest, signals_stop
from armctl.robot.teach import ExistingFile, check_output, taught_joints
from armctl.typing import Array

#: Per-joint flags.
Mask = npt.NDArray[np.bool_]

__all__ = ["JointScale", "Teleop", "TeleopCycle", "TeleopOptions", "TeleopRecorder",
           "TeleopStats", "load_joint_scales", "paired_joints", "parse_joint_scale"]

logger = logging.getLogger(__name__)

#: A target this far beyond a limit counts as clamped [rad]/[m] (rounding of the mappings).
_CLAMP_TOL = 1e-9
#: Shortest and longest sampling period of a continuous recording [s].
MIN_RECORD_PERIOD = 0.01
MAX_RECORD_PERIOD = 1.0


@dataclass(frozen=True)
class JointScale:
    """How a leader joint maps to its follower joint: ``follower = scale * leader + offset``.

    Attributes:
        scale: Factor [-] (negative mirrors the joint).
        offset: Offset [rad] (rotary) or [m] (prismatic).
    """

    scale: float = 1.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.scale) and math.isfinite(self.offset)):
            raise InputError(f"a joint scale and offset must be finite numbers, got scale "
                             f"{self.scale} and offset {self.offset}")


def parse_joint_scale(text: str) -> tuple[str, JointScale]:
    """Parse ``JOINT=SCALE`` or ``JOINT=SCALE:OFFSET`` (offset in [rad]/[m]).

    Raises:
        InputError: For another shape or a value that is not a finite number.
    """
    name, sep, rest = text.partition("=")
    parts = rest.split(":")
    if not sep or not name.strip() or len(parts) > 2 or not parts[0].strip():
        raise InputError(f"{text!r} is not JOINT=SCALE or JOINT=SCALE:OFFSET "
                         "(e.g. gripper=1.5 or wrist_roll=-1:0.1)")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise InputError(f"{text!r}: scale and offset must be numbers "
                         "(e.g. gripper=1.5 or wrist_roll=-1:0.1)") from None
    return name.strip(), JointScale(values[0], values[1] if len(values) > 1 else 0.0)


def load_joint_scales(path: str | Path) -> dict[str, JointScale]:
    """Read a joint scale file: ``{joint: {scale: S, offset: O}}`` (either key optional).

    Offsets are in [rad] for rotary joints and [m] for prismatic ones.

    Raises:
        ConfigError: Unreadable file, or a bad entry (naming the file and key).
    """
    import yaml

    p = Path(path)
    try:
        doc = yaml.safe_load(p.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigError(f"cannot read the joint scale file: {exc.strerror}", KeyPath(p),
                          "give an existing YAML file") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"not valid YAML: {exc}", KeyPath(p), "fix the YAML syntax") from None
    if doc is None:
        return {}
    if not isinstance(doc, dict):
        raise ConfigError("expected a mapping of joint names to {scale, offset}", KeyPath(p),
                          "write e.g. 'gripper: {scale: 1.5, offset: 0.0}'")
    out: dict[str, JointScale] = {}
    for name, entry in doc.items():
        where = KeyPath(p, (str(name),))
        if not isinstance(entry, dict) or not set(entry) <= {"scale", "offset"}:
            raise ConfigError("expected a mapping with the keys 'scale' and/or 'offset'", where,
                              f"write e.g. '{name}: {{scale: 1.0, offset: 0.0}}'")
        try:
            out[str(name)] = JointScale(float(entry.get("scale", 1.0)),
                                        float(entry.get("offset", 0.0)))
        except (TypeError, ValueError, InputError):
            raise ConfigError("scale and offset must be finite numbers", where,
                              "offsets are in rad (rotary) or m (prismatic)") from None
    return out


@dataclass(frozen=True)
class TeleopOptions:
    """How a teleoperation runs.

    Attributes:
        rate_hz: Loop rate [Hz] (one leader read and one follower write per cycle).
        start_speed: Speed factor of the first move to the leader's pose (0, 1].
        speed: Factor of the follower's velocity limits applied while following (0, 1];
            the acceleration limits scale with its square.
        scales: Per-joint scale and offset, by follower joint name.
        duration: Follow for this long [s] and then stop (``None``: until a stop request).
    """

    rate_hz: float = 100.0
    start_speed: float = 0.3
    speed: float = 1.0
    scales: Mapping[str, JointScale] = field(default_factory=dict)
    duration: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.rate_hz) and 1.0 <= self.rate_hz <= 1000.0):
            raise InputError(f"teleoperation rate {self.rate_hz} Hz is outside 1 to 1000 Hz")
        for what, v in (("start speed", self.start_speed), ("speed", self.speed)):
            if not (math.isfinite(v) and 0.0 < v <= 1.0):
                raise InputError(f"teleoperation {what} {v} must be in (0, 1]")
        if self.duration is not None and not (math.isfinite(self.duration)
                                               and self.duration > 0):
            raise InputError(f"teleoperation duration {self.duration} s must be more than 0 s")


@dataclass(frozen=True)
class TeleopCycle:
    """One cycle, for a callback.

    Attributes:
        t: Time since following began [s].
        leader: Leader joints read this cycle (leader bus order) [rad]/[m].
        target: Follower targets after scaling, before limits (follower bus order).
        command: Follower goals written this cycle (follower bus order).
        clamped: Per follower bus joint, whether the target was clamped this cycle.
        rate_limited: Per follower bus joint, whether the command was rate-limited.
        blocked: The pair that kept the follower from following this cycle (e.g.
            ``'gripper_link' and 'table'``), else ``""``.
    """

    t: float
    leader: Array
    target: Array
    command: Array
    clamped: Mask
    rate_limited: Mask
    blocked: str = ""


@dataclass(frozen=True)
class TeleopStats:
    """What a teleoperation did.

    Attributes:
        rate_hz: Set loop rate [Hz].
        cycles: Cycles run.
        elapsed: Time from the first cycle to the last [s].
        dropped: Cycles whose deadline passed before they could start (skipped, not bunched).
        latency_median: Median time from the start of a leader read to the end of the
            follower write of the same cycle [s].
        latency_p99: Its 99th percentile [s].
        clamped: Cycles per follower joint whose target was outside the effective limits.
        rate_limited: Cycles per follower joint in which the target moved by more than the
            velocity limit allows in one cycle.
        recorded: Keyframes recorded.
        stopped_by: What ended it ("" when the duration ran out).
        blocked: Cycles in which a contact ahead kept the follower from following, by pair.
    """

    rate_hz: float
    cycles: int
    elapsed: float
    dropped: int
    latency_median: float
    latency_p99: float
    clamped: dict[str, int]
    rate_limited: dict[str, int]
    recorded: int = 0
    stopped_by: str = ""
    blocked: dict[str, int] = field(default_factory=dict)

    @property
    def achieved_rate(self) -> float:
        """Cycles per second actually run [Hz]."""
        return (self.cycles - 1) / self.elapsed if self.elapsed > 0 and self.cycles > 1 else 0.0


class TeleopRecorder:
    """Record the follower's commanded pose while teleoperating, into a keyframe file.

    Keyframes are the follower's joints (every joint but the grippers; a keyframe on demand
    also carries the gripper's value). The file is written atomically after every keyframe on
    demand, and at the end of a continuous recording.

    Args:
        follower: The follower robot (the arm the file is for).
        path: The keyframe file (``.yaml``).
        period: Sample a continuous trajectory every ``period`` seconds (0.01 to 1 s);
            ``None`` records only keyframes asked for with :meth:`mark`.
        existing: What to do with an existing file (default: refuse).

    Raises:
        InputError: An existing file without overwriting, a bad path or period.
    """

    def __init__(self, follower: Robot, path: str | Path, period: float | None = None,
                 existing: ExistingFile = ExistingFile.REFUSE):
        if existing is ExistingFile.APPEND:
            raise InputError("teleoperation records into a new file (or overwrites one)")
        self.check_period(period)
        self.path = check_output(path, existing, can_append=False)
        self.follower = follower
        self.period = period
        arm = follower.arm
        self.joints = taught_joints(arm)
        self._cols = np.array([arm.joint_index(n) for n in self.joints], dtype=int)
        grip = follower.gripper_joints
        self._grip = arm.joint_index(grip[0]) if grip else None
        #: A sampled gripper value is recorded when it moved by more than this [rad]/[m] (2 % of
        #: its range) since the last one recorded: a gripper event of the program.
        self._grip_step = (0.02 * float(arm.upper[self._grip] - arm.lower[self._grip])
                           if self._grip is not None else math.inf)
        self._last_grip: float | None = None
        self.program = KeyframeProgram(arm.name, self.joints, (), follower.calibration_hash(),
                                       description="recorded by teleoperation")
        self._pending: list[str] = []
        self._lock = threading.Lock()
        self._next: float | None = None
        self.written = False

    @staticmethod
    def check_period(period: float | None) -> None:
        """Refuse a sampling period [s] outside 0.01 to 1 s (``None``: keyframes only).

        Raises:
            InputError: Saying the valid range.
        """
        if period is not None and not (math.isfinite(period)
                                       and MIN_RECORD_PERIOD <= period <= MAX_RECORD_PERIOD):
            raise InputError(f"recording period {period * 1000:g} ms is outside "
                             f"{MIN_RECORD_PERIOD * 1000:g} to {MAX_RECORD_PERIOD * 1000:g} ms")

    def mark(self, name: str = "") -> None:
        """Ask for a keyframe at the next cycle (thread-safe; e.g. from a key press)."""
        with self._lock:
            self._pending.append(name)

    def sample(self, t: float, q: Array) -> None:
        """Called every cycle with the time [s] and the follower's commanded joints (arm order).

        Records the keyframes asked for since the last cycle, and a continuous sample when its
        time has come.
        """
        self.flush_marks(q)
        if self.period is not None and (self._next is None or t >= self._next - 1e-9):
            self._next = t + self.period if self._next is None else self._next + self.period
            grip: float | None = None
            if self._grip is not None:
                value = float(q[self._grip])
                if self._last_grip is None or abs(value - self._last_grip) > self._grip_step:
                    grip = self._last_grip = value
            self.program = self.program.append(
                Keyframe(q=tuple(float(v) for v in q[self._cols]), time=round(t, 4),
                         gripper=grip))

    def flush_marks(self, q: Array) -> None:
        """Record the keyframes asked for and not yet recorded, at joints ``q`` (arm order)."""
        with self._lock:
            names, self._pending = self._pending, []
        for name in names:
            grip = float(q[self._grip]) if self._grip is not None else None
            self.program = self.program.append(
                Keyframe(q=tuple(float(v) for v in q[self._cols]), name=name, gripper=grip))
            self.save()

    def save(self) -> None:
        """Write the file atomically (nothing when no keyframe was recorded)."""
        if self.program.keyframes:
            save_keyframes(self.program, self.path, self.follower.arm)
            self.written = True


def paired_joints(leader: str, leader_joints: Sequence[str], follower: str,
                  follower_joints: Sequence[str],
                  scales: Mapping[str, JointScale] | None = None) -> tuple[str, ...]:
    """The joints a leader and a follower share (in the follower's order).

    Args:
        leader: The leader arm's name, for messages.
        leader_joints: The leader's joints with a servo.
        follower: The follower arm's name.
        follower_joints: The follower's joints with a servo.
        scales: Per-joint scales, whose joints must be shared.

    Raises:
        InputError: No joint in common (saying how joints pair), or a scale for a joint the
            arms do not share (:class:`~armctl.errors.UnknownNameError`, with the valid names).
    """
    common = tuple(n for n in follower_joints if n in leader_joints)
    if not common:
        raise InputError(
            f"leader {leader!r} and follower {follower!r} share no joint: the leader's servos "
            f"drive {', '.join(leader_joints)}, the follower's {', '.join(follower_joints)}. "
            "Joints pair by name: use a leader of the same joint layout (e.g. so101_leader -> "
            "so101, koch_leader -> koch_follower), or rename the joints in one config")
    for name in scales or {}:
        if name not in common:
            raise UnknownNameError("joint shared by leader and follower", name, common,
                                   "the joint scales")
    return common


class Teleop:
    """A follower robot that copies a leader robot, joint by joint.

    Args:
        leader: The leader robot (its torque goes off at :meth:`start`).
        follower: The follower robot (open, holding).
        options: Rate, speeds, per-joint scales, duration.
        recorder: Records keyframes or a trajectory while following, if given.

    Raises:
        InputError: The arms share no joint with a servo, or a scale names a joint that is
            not shared.
    """

    def __init__(self, leader: Robot, follower: Robot, options: TeleopOptions | None = None,
                 recorder: TeleopRecorder | None = None):
        self.leader = leader
        self.follower = follower
        self.options = options or TeleopOptions()
        self.recorder = recorder
        self.clock = follower.clock
        lead_names = list(leader.bus.joint_names)
        fol_names = list(follower.bus.joint_names)
        common = list(paired_joints(leader.arm.name, lead_names, follower.arm.name, fol_names,
                                    self.options.scales))
        #: Follower bus index of each paired joint, and the leader bus index it copies.
        self.follower_index = np.array([fol_names.index(n) for n in common], dtype=int)
        self.leader_index = np.array([lead_names.index(n) for n in common], dtype=int)
        self.joints = tuple(common)
        #: Follower bus joints without a leader joint: they hold where they are.
        self.unpaired = tuple(n for n in fol_names if n not in common)
        self._scale = np.array([self.options.scales.get(n, JointScale()).scale for n in common])
        self._offset = np.array([self.options.scales.get(n, JointScale()).offset
                                 for n in common])
        idx = follower.executor.idx
        lim = follower.limits
        s = self.options.speed
        self.lower: Array = lim.lower[idx]
        self.upper: Array = lim.upper[idx]
        self.velocity: Array = lim.velocity[idx] * s
        self.acceleration: Array = lim.acceleration[idx] * s * s
        self._fol_names = tuple(fol_names)
        self._held: Array | None = None  # follower bus values of the unpaired joints
        self._cmd: Array | None = None
        self._vel = np.zeros(len(fol_names))
        self._acc = np.zeros(len(fol_names))
        self.clamped: dict[str, int] = {}
        self.rate_limited: dict[str, int] = {}
        self.blocked: dict[str, int] = {}
        self.stop = StopRequest()
        self._guard: CollisionModel | None = None
        self._safe_stop: Array | None = None  # where the last safe command comes to rest
        self._full: Array = np.zeros(follower.arm.dof)  # the follower's joints (arm order)

    # ---- mapping ------------------------------------------------------------------------------
    def target(self, leader_q: Array) -> Array:
        """Follower targets (follower bus order) for leader joints (leader bus order).

        Unpaired follower joints keep the value they had when following began.
        """
        if self._held is None:  # held where they are (inside the limits)
            self._held = np.clip(np.asarray(self.follower.bus.read_joints(), dtype=float),
                                 self.lower, self.upper)
        out = self._held.copy()
        out[self.follower_index] = self._scale * np.asarray(leader_q)[self.leader_index] \
            + self._offset
        return out

    def read_leader(self) -> Array:
        """The leader's joints, one sync read (leader bus order) [rad]/[m]."""
        return np.asarray(self.leader.bus.read_joints(), dtype=float)

    # ---- per cycle ----------------------------------------------------------------------------
    def limit(self, target: Array, dt: float) -> tuple[Array, Mask, Mask]:
        """The next command toward ``target``, within the limits (and the clamp/rate flags).

        The target is clamped into the effective limits; the command then moves toward it at
        most at the velocity limit, changes its velocity at most by the acceleration limit per
        second, and brakes so as to come to rest at the target (the stopping speed of a
        constant deceleration in discrete steps of ``dt``).

        Args:
            target: Follower targets (follower bus order) [rad]/[m].
            dt: Cycle time [s].

        Returns:
            The command, whether each joint was clamped, and whether it was rate-limited.
        """
        if self._cmd is None:
            raise InputError("call start() before following")
        goal = np.clip(target, self.lower, self.upper)
        clamped = (target < self.lower - _CLAMP_TOL) | (target > self.upper + _CLAMP_TOL)
        err = goal - self._cmd
        dist = np.abs(err)
        a_dt = self.acceleration * dt
        # Largest speed from which a deceleration of a per cycle stops within dist.
        brake = a_dt * (np.sqrt(0.25 + 2.0 * dist / (a_dt * dt)) - 0.5)
        want = np.sign(err) * np.minimum.reduce([self.velocity, dist / dt, brake])
        vel = np.clip(want, self._vel - a_dt, self._vel + a_dt)
        # Land on the goal when one step there is within the limits.
        land = err / dt
        can_land = (np.abs(land - self._vel) <= a_dt) & (np.abs(land) <= self.velocity)
        vel = np.clip(np.where(can_land, land, vel), -self.velocity, self.velocity)
        cmd = np.clip(self._cmd + vel * dt, self.lower, self.upper)
        rate_limited = dist > self.velocity * dt + _CLAMP_TOL
        new_vel = (cmd - self._cmd) / dt
        self._acc = (new_vel - self._vel) / dt
        self._vel = new_vel
        self._cmd = cmd
        return cmd, clamped, rate_limited

    def _count(self, clamped: Mask, rate_limited: Mask, target: Array) -> None:
        for j in np.flatnonzero(clamped):
            name = self._fol_names[j]
            if name not in self.clamped:
                lo, hi = self.lower[j], self.upper[j]
                logger.warning("joint %r: the leader asks for %.4f, outside the follower's "
                               "effective limits [%.4f, %.4f]; clamped (counted, logged once "
                               "per joint)", name, float(target[j]), float(lo), float(hi))
            self.clamped[name] = self.clamped.get(name, 0) + 1
        for j in np.flatnonzero(rate_limited):
            name = self._fol_names[j]
            if name not in self.rate_limited:
                logger.info("joint %r: the leader moves faster than the follower's velocity "
                            "limit allows; rate-limited (counted, logged once per joint)", name)
            self.rate_limited[name] = self.rate_limited.get(name, 0) + 1

    # ---- keeping out of contact ---------------------------------------------------------------
    def _stop_point(self, cmd: Array, vel: Array) -> Array:
        """Where each joint comes to rest decelerating at its acceleration limit (bus order)."""
        a = np.maximum(self.acceleration, 1e-12)
        return np.clip(cmd + vel * np.abs(vel) / (2.0 * a), self.lower, self.upper)

    def _ahead(self, prev: Array, cmd: Array, vel: Array) -> Contact | None:
        """A contact on the step ``prev`` -> ``cmd`` or on the stop from ``cmd``, else None."""
        guard = self._guard
        if guard is None:
            return None
        stop = self._stop_point(cmd, vel)
        full = np.tile(self._full, (3, 1))
        idx = self.follower.executor.idx
        full[0, idx], full[1, idx], full[2, idx] = prev, cmd, stop
        travel = np.abs(np.diff(full, axis=0))
        return guard.first_contact_on_samples(np.array([0.0, 1.0, 2.0]), full, travel)

    def _guarded(self, prev: tuple[Array, Array, Array], target: Array, dt: float
                 ) -> tuple[Array, Mask, Mask, str]:
        """:meth:`limit`, unless the command's step or stop would touch: then brake instead."""
        cmd, clamped, rate_limited = self.limit(target, dt)
        if self._guard is None:
            return cmd, clamped, rate_limited, ""
        contact = self._ahead(prev[0], cmd, self._vel)
        if contact is None:
            self._safe_stop = self._stop_point(cmd, self._vel)
            return cmd, clamped, rate_limited, ""
        # keep to the last safe command's stop: every state on the way stops inside it
        self._cmd, self._vel, self._acc = prev
        assert self._safe_stop is not None
        cmd, _, _ = self.limit(self._safe_stop, dt)
        pair = contact.pair
        if pair not in self.blocked:
            logger.warning("teleoperation: the leader's pose would bring %s within %.1f mm "
                           "(padding %.1f mm); the follower waits (counted, logged once per "
                           "pair)", pair, max(contact.distance, 0.0) * 1000,
                           contact.padding * 1000)
        self.blocked[pair] = self.blocked.get(pair, 0) + 1
        return cmd, clamped, rate_limited, pair

    # ---- running ------------------------------------------------------------------------------
    def start(self) -> MotionPlan | None:
        """Leader torque off; move the follower to the leader's pose (planned, jerk-limited).

        Returns:
            The plan of the move (``None`` when the follower was there already).

        Raises:
            JointLimitError: The follower's present position is outside its effective limits.
            MotionStopped: The move was stopped; the follower holds.
        """
        self.leader.bus.set_torque(False)
        fol = self.follower
        self._held = None
        target = self.target(self.read_leader())
        goal_bus = np.clip(target, self.lower, self.upper)
        clamped = (target < self.lower - _CLAMP_TOL) | (target > self.upper + _CLAMP_TOL)
        self._count(clamped, np.zeros_like(clamped), target)
        goal = fol.plan_start()
        goal[fol.executor.idx] = goal_bus
        plan = fol.plan_joints(goal, self.options.start_speed,
                               f"move to the leader {self.leader.arm.name!r}'s pose")
        moved: MotionPlan | None = None
        if plan.duration > 1e-6:
            fol.execute(plan)
            moved = plan
        elif fol.executor.last_command is None:
            fol.hold()
        last = fol.executor.last_command
        self._cmd = np.asarray(last if last is not None else goal_bus, dtype=float).copy()
        self._vel = np.zeros_like(self._cmd)
        self._acc = np.zeros_like(self._cmd)
        self._safe_stop = self._cmd.copy()
        self._full = fol.plan_start()
        self._full[fol.executor.idx] = self._cmd
        model = fol.collisions
        self._guard = None if model is None else model.escaping(self._full)
        return moved

    def run(self, on_cycle: Callable[[TeleopCycle], None] | None = None) -> TeleopStats:
        """Follow the leader until a stop request (or :attr:`TeleopOptions.duration`).

        While it runs (main thread), SIGINT, SIGTERM and SIGHUP are routed to :attr:`stop`. A
        stop ends with a controlled stop: the follower decelerates from its commanded state
        within its limits and holds (torque on). A ``KeyboardInterrupt`` raised by
        ``on_cycle`` is a stop request too.

        Returns:
            The figures of the run.

        Raises:
            InputError: :meth:`start` was not called.
            BusError: The leader's bus failed (the follower stopped under control and holds),
                or the follower's (it holds where it could).
        """
        if self._cmd is None:
            raise InputError("call start() before run(): the follower must first move to the "
                             "leader's pose")
        dt = 1.0 / self.options.rate_hz
        clock = self.clock
        lat: list[float] = []
        dropped = 0
        k = 0
        duration = self.options.duration
        fol = self.follower
        full = fol.plan_start()
        idx = fol.executor.idx
        failure: BaseException | None = None
        t0 = last = clock.now()
        stop = self.stop
        watched = fol.live, self.leader.live  # publishers of the two ports' live state
        try:
            with signals_stop(stop):
                while not stop.requested:
                    deadline = t0 + k * dt
                    if duration is not None and k * dt > duration + 1e-9:
                        break
                    clock.sleep_until(deadline)
                    begin = clock.now()
                    late = begin - deadline
                    if late > dt:
                        missed = int(late // dt)
                        dropped += missed
                        k += missed
                    last = begin
                    try:
                        leader_q = self.read_leader()
                    except BusError as exc:  # the follower is fine: stop it under control
                        failure = exc
                        stop.request(f"the leader's bus failed ({exc})")
                        break
                    target = self.target(leader_q)
                    prev = (self._cmd.copy(), self._vel.copy(), self._acc.copy())
                    cmd, clamped, rate_limited, blocked = self._guarded(prev, target, dt)
                    fol.bus.write_joints(cmd)
                    fol.executor.last_command = cmd
                    lat.append(clock.now() - begin)
                    self._count(clamped, rate_limited, target)
                    full[idx] = cmd
                    if watched[0] is not None:
                        watched[0].cycle(Activity.TELEOP, "following the leader", k * dt, None,
                                         cmd, None)
                    if watched[1] is not None:
                        watched[1].cycle(Activity.TELEOP, "leading (moved by hand)", k * dt,
                                         None, None, leader_q)
                    if self.recorder is not None:
                        self.recorder.sample(k * dt, full)
                    if on_cycle is not None:
                        try:
                            on_cycle(TeleopCycle(k * dt, leader_q, target, cmd, clamped,
                                                 rate_limited, blocked))
                        except KeyboardInterrupt:
                            stop.request("Ctrl-C (KeyboardInterrupt)")
                    k += 1
        except BaseException as exc:  # the follower's bus failed, or an error in on_cycle
            failure = exc
        reason = stop.reason
        for publisher in watched:
            if publisher is not None:
                publisher.idle()
        try:
            self._controlled_stop(full, None if stop.requested else failure)
        finally:
            if self.recorder is not None:
                self.recorder.flush_marks(full)  # asked for in the last cycle
                self.recorder.save()
        if failure is not None:
            raise failure
        arr = np.array(lat) if lat else np.full(1, math.nan)
        return TeleopStats(self.options.rate_hz, len(lat), last - t0, dropped,
                           float(np.median(arr)), float(np.percentile(arr, 99)),
                           dict(self.clamped), dict(self.rate_limited),
                           len(self.recorder.program.keyframes) if self.recorder else 0,
                           reason, dict(self.blocked))

    def _controlled_stop(self, full: Array, failure: BaseException | None) -> None:
        """Decelerate from the commanded state within the limits, then hold.

        Streams the stop through the follower's executor (a second stop request holds at once);
        after a bus failure, holds the present reading instead.
        """
        fol = self.follower
        idx = fol.executor.idx
        if self.stop.escalated or isinstance(failure, BusError):
            try:
                fol.executor.hold()
            except ArmctlError as exc:
                logger.warning("could not hold the follower: %s", exc)
            return
        q, qd, qdd = full.copy(), np.zeros(fol.arm.dof), np.zeros(fol.arm.dof)
        q[idx] = self._cmd if self._cmd is not None else q[idx]
        qd[idx], qdd[idx] = self._vel, self._acc
        # Following changes speed at the acceleration limit (its jerk is not limited), and it
        # brakes in time to stop at the leader's pose: a stop at the same deceleration never
        # goes past that pose, where a jerk-limited stop from full speed would.
        limits = replace(fol.limits, jerk=np.full(fol.arm.dof, np.inf))
        traj = stop_trajectory(q, qd, qdd, limits)
        plan = MotionPlan(traj, limits, description="controlled stop of teleoperation")
        try:
            fol.executor.run(plan, StopRequest())
        except MotionStopped as exc:
            logger.warning("the controlled stop was cut short: %s", exc)
        except ArmctlError as exc:
            logger.warning("the controlled stop ended with: %s; the follower holds", exc)
        self._cmd = None

    def summary(self) -> dict[str, Any]:
        """The pairing, for reports: paired joints, unpaired follower joints, scales."""
        return {"leader": self.leader.arm.name, "follower": self.follower.arm.name,
                "joints": list(self.joints), "unpaired": list(self.unpaired),
                "scales": {n: {"scale": s.scale, "offset": s.offset}
                           for n, s in self.options.scales.items()}}
