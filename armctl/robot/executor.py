"""The streaming loop: a checked plan sent to the servos at a fixed rate, and stopped safely.

Every cycle has a deadline ``t0 + k / rate``; the loop sleeps until it, samples the trajectory at
the planned time, sends one sync write of goal positions, reads the state back in one sync read,
and measures the tracking error (measured position against the command of the previous cycle)
and the loop jitter (cycle start minus deadline). A late cycle does not make the loop rush: the
next deadline is the first one still ahead, and the missed ones are counted as overruns.

The loop stops safely on a stop request (Ctrl-C), a servo alarm, a servo that stops answering,
or a tracking error above the limit: it plans a jerk-limited stop from the commanded state,
streams it, and holds the final position with torque on.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import numpy.typing as npt

from armctl.errors import ArmctlError, BusError
from armctl.kinematics.model import KinematicModel
from armctl.motion import MotionLimits, MotionPlan, Trajectory, stop_trajectory
from armctl.robot.errors import MotionStopped, StopReason
from armctl.robot.stop import StopRequest

__all__ = ["BusState", "CycleInfo", "Executor", "JointBus", "StreamResult", "StreamStats"]

Array = npt.NDArray[np.float64]


class BusState(Protocol):
    """What the loop reads from a bus state (:class:`armctl.servo.arm_bus.JointState`)."""

    @property
    def position(self) -> Array:
        """Present positions [rad]/[m]."""
        ...

    @property
    def errors(self) -> tuple[tuple[object, ...], ...]:
        """Per joint, the alarms the servo reports."""
        ...


class JointBus(Protocol):
    """What the loop needs from a bus (:class:`armctl.servo.arm_bus.ArmBus` provides it)."""

    joint_names: tuple[str, ...]

    def read_joints(self) -> Array:
        """Present positions."""
        ...

    def read_state(self) -> BusState:
        """Positions, velocities, loads, temperatures, voltages and alarms."""
        ...

    def write_joints(self, q: npt.ArrayLike) -> None:
        """Goal positions, one sync write."""
        ...

    def set_torque(self, on: bool, joints: Sequence[str] | None = None) -> None:
        """Torque on or off."""
        ...


@dataclass(frozen=True)
class CycleInfo:
    """What one cycle did, for progress displays.

    Attributes:
        t: Planned time of the cycle [s].
        duration: Planned duration of the whole motion [s].
        command: Goal positions sent, bus joint order.
        measured: Positions read back.
        tracking_error: Largest |measured - previous command| [rad]/[m].
        stopping: Whether a stop is under way.
    """

    t: float
    duration: float
    command: Array
    measured: Array
    tracking_error: float
    stopping: bool


@dataclass(frozen=True)
class StreamStats:
    """Figures of one streamed motion.

    Attributes:
        rate_hz: Target loop rate [Hz].
        cycles: Cycles run.
        elapsed: Wall time from the first to the last cycle start [s].
        jitter_mean: Mean lateness of cycle starts [s].
        jitter_p99: 99th percentile lateness [s].
        jitter_max: Largest lateness [s].
        overruns: Deadlines missed entirely.
        io_time_mean: Mean time of one write + read [s].
        max_tracking_error: Largest tracking error per bus joint [rad]/[m].
        settle_time: Time after the end of the plan until the servos were within tolerance [s].
    """

    rate_hz: float
    cycles: int
    elapsed: float
    jitter_mean: float
    jitter_p99: float
    jitter_max: float
    overruns: int
    io_time_mean: float
    max_tracking_error: Array
    settle_time: float

    @property
    def achieved_rate(self) -> float:
        """Cycles per second actually run [Hz]."""
        return (self.cycles - 1) / self.elapsed if self.elapsed > 0 else 0.0


@dataclass(frozen=True)
class StreamResult:
    """The outcome of streaming a plan.

    Attributes:
        stats: Timing and tracking figures.
        final: Measured joint values at the end, full arm vector ``(dof,)`` [rad]/[m].
        log_t: Planned time of each cycle (only with ``record=True``).
        log_cmd: Commands ``(N, n_bus)`` (only with ``record=True``).
        log_meas: Measurements ``(N, n_bus)`` (only with ``record=True``).
    """

    stats: StreamStats
    final: Array
    log_t: Array = field(default_factory=lambda: np.zeros(0))
    log_cmd: Array = field(default_factory=lambda: np.zeros((0, 0)))
    log_meas: Array = field(default_factory=lambda: np.zeros((0, 0)))


class _Abort(Exception):
    def __init__(self, reason: StopReason, message: str, joint: str | None = None,
                 servo_id: int | None = None):
        super().__init__(message)
        self.reason = reason
        self.message = message
        self.joint = joint
        self.servo_id = servo_id


class Executor:
    """Streams checked plans to a bus.

    Args:
        bus: The open bus.
        model: The arm (its joint order is the plans' order).
        limits: Hard limits, used for controlled stops.
        rate_hz: Loop rate [Hz].
        max_tracking_error: Stop when |measured - commanded| exceeds this [rad]/[m].
        settle_tolerance: At the end, wait until every joint is this close to the goal.
        settle_timeout: Longest wait for that [s].
        lost_after: A servo counts as lost after this many cycles in a row without a reply
            (each read already retries; one slow cycle is not a lost servo).
    """

    def __init__(self, bus: JointBus, model: KinematicModel, limits: MotionLimits,
                 rate_hz: float = 50.0, max_tracking_error: float = 0.2,
                 settle_tolerance: float = 0.01, settle_timeout: float = 1.0,
                 lost_after: int = 3):
        self.bus = bus
        self.model = model
        self.limits = limits
        self.rate_hz = float(rate_hz)
        self.max_tracking_error = float(max_tracking_error)
        self.settle_tolerance = settle_tolerance
        self.settle_timeout = settle_timeout
        self.lost_after = lost_after
        self.idx = np.array([model.joint_index(n) for n in bus.joint_names], dtype=int)
        self.last_command: Array | None = None

    # ---- helpers ---------------------------------------------------------------------------
    def _servo_id(self, joint: str) -> int | None:
        mapping = getattr(self.bus, "mapping", None)
        try:
            return int(mapping.joint(joint).servo_id) if mapping is not None else None
        except (ArmctlError, AttributeError):
            return None

    def _joint_of(self, servo_id: int | None) -> str | None:
        mapping = getattr(self.bus, "mapping", None)
        if mapping is None or servo_id is None:
            return None
        for j in getattr(mapping, "joints", ()):
            if j.servo_id == servo_id:
                return str(j.name)
        return None

    def _write(self, q_full: Array) -> Array:
        cmd = np.clip(q_full[self.idx], self.limits.lower[self.idx], self.limits.upper[self.idx])
        self.bus.write_joints(cmd)
        self.last_command = cmd
        return cmd

    def _read(self) -> Array:
        try:
            state = self.bus.read_state()
        except BusError as exc:
            sid = getattr(exc, "servo_id", None)
            joint = self._joint_of(sid)
            who = f"servo {sid}" + (f" (joint {joint!r})" if joint else "") if sid is not None \
                else "the bus"
            raise _Abort(StopReason.LOST_SERVO, f"{who} stopped answering: {exc}", joint,
                         sid) from exc
        for name, alarms in zip(self.bus.joint_names, state.errors, strict=False):
            if alarms:
                sid = self._servo_id(name)
                what = ", ".join(getattr(a, "value", str(a)) for a in alarms)
                raise _Abort(StopReason.SERVO_ERROR,
                             f"servo {sid} (joint {name!r}) reports {what}", name, sid)
        return np.asarray(state.position, dtype=np.float64)

    # ---- the loop --------------------------------------------------------------------------
    def run(self, plan: MotionPlan, stop: StopRequest | None = None,
            on_cycle: Callable[[CycleInfo], None] | None = None,
            record: bool = False) -> StreamResult:
        """Stream a plan; return when the servos have settled at its end.

        Args:
            plan: A checked plan starting at the present position.
            stop: Stop requests (Ctrl-C) to watch.
            on_cycle: Called after every cycle (keep it fast).
            record: Keep every command and measurement in the result.

        Returns:
            Timing and tracking figures and the final measured position.

        Raises:
            MotionStopped: After a controlled stop, for a stop request, a servo alarm, a lost
                servo or a tracking error; the arm holds where the stop ended.
        """
        stop = stop or StopRequest()
        traj: Trajectory = plan.trajectory
        dt = 1.0 / self.rate_hz
        jitter: list[float] = []
        io: list[float] = []
        log_t: list[float] = []
        log_c: list[Array] = []
        log_m: list[Array] = []
        worst = np.zeros(self.idx.size)
        prev_cmd: Array | None = None
        overruns = 0
        stopping: tuple[Trajectory, float] | None = None
        abort: _Abort | None = None
        blind = False  # after a lost servo: keep writing, stop reading
        missed_reads = 0
        t0 = last_start = time.perf_counter()
        k = 0
        while True:
            deadline = t0 + k * dt
            now = time.perf_counter()
            if now < deadline:
                time.sleep(deadline - now)
            start = time.perf_counter()
            last_start = start
            late = start - deadline
            if late > dt:
                missed = int(late // dt)
                overruns += missed
                k += missed
                deadline = t0 + k * dt
                late = start - deadline
            jitter.append(max(late, 0.0))
            t = k * dt
            if stopping is None and (stop.requested or abort is not None):
                if abort is None:
                    abort = _Abort(StopReason.USER, "stopped by the user (Ctrl-C)")
                q, qd, qdd = traj.sample(min(t, traj.duration))
                stopping = (stop_trajectory(q, qd, qdd, self.limits), min(t, traj.duration))
            if stopping is not None:
                s_traj, s_t0 = stopping
                q_full = s_traj.sample(t - s_t0)[0]
                finished = t - s_t0 >= s_traj.duration
            else:
                q_full = traj.sample(t)[0]
                finished = t >= traj.duration
            try:
                cmd = self._write(q_full)
                meas = self._read() if not blind else cmd
                missed_reads = 0
            except _Abort as exc:
                lost = exc.reason is StopReason.LOST_SERVO
                missed_reads += 1
                if stopping is not None:  # already stopping: keep going, blind if need be
                    blind = blind or not lost or missed_reads >= self.lost_after
                    meas = cmd
                elif lost and missed_reads < self.lost_after:
                    meas = cmd  # one late reply: carry on and read again next cycle
                else:
                    abort, blind = exc, lost
                    k += 1
                    continue
            io.append(time.perf_counter() - start)
            err = np.abs(meas - (prev_cmd if prev_cmd is not None else cmd))
            worst = np.maximum(worst, err)
            prev_cmd = cmd
            if record:
                log_t.append(t)
                log_c.append(cmd)
                log_m.append(meas)
            if stopping is None and not blind and float(np.max(err, initial=0.0)) > \
                    self.max_tracking_error:
                j = int(np.argmax(err))
                name = self.bus.joint_names[j]
                abort = _Abort(StopReason.TRACKING,
                               f"joint {name!r} (servo {self._servo_id(name)}) is "
                               f"{err[j]:.3f} from its command, more than the allowed "
                               f"{self.max_tracking_error:.3f}; blocked or overloaded?",
                               name, self._servo_id(name))
            if on_cycle is not None:
                on_cycle(CycleInfo(t, traj.duration, cmd, meas, float(np.max(err, initial=0.0)),
                                   stopping is not None))
            k += 1
            if finished and abort is None:
                break
            if finished and stopping is not None:
                break
        elapsed = last_start - t0
        settle = 0.0
        final_cmd = self.last_command if self.last_command is not None else np.zeros(0)
        meas_final = final_cmd
        if not blind:
            settle, meas_final = self._settle(final_cmd)
        jit = np.array(jitter) if jitter else np.zeros(1)
        stats = StreamStats(
            rate_hz=self.rate_hz, cycles=len(jitter), elapsed=elapsed,
            jitter_mean=float(jit.mean()), jitter_p99=float(np.percentile(jit, 99)),
            jitter_max=float(jit.max()), overruns=overruns,
            io_time_mean=float(np.mean(io)) if io else math.nan, max_tracking_error=worst,
            settle_time=settle)
        final = plan.trajectory.end.copy()
        final[self.idx] = meas_final
        if abort is not None:
            held = plan.trajectory.end.copy()
            held[self.idx] = final_cmd
            t_stop = stopping[1] if stopping is not None else 0.0
            suffix = ("; the arm decelerated and holds its position" if not blind else
                      "; the other servos decelerated and hold their position")
            raise MotionStopped(abort.reason, abort.message + suffix, abort.joint,
                                abort.servo_id, held, t_stop)
        return StreamResult(stats, final, np.array(log_t), np.array(log_c), np.array(log_m))

    def _settle(self, goal: Array) -> tuple[float, Array]:
        """Keep holding ``goal`` until the servos are within tolerance (or time out).

        Returns:
            The time it took [s] and the last measured position (never the goal itself).

        Raises:
            MotionStopped: For a servo alarm, or a servo lost for ``lost_after`` reads.
        """
        t0 = time.perf_counter()
        dt = 1.0 / self.rate_hz
        meas = np.full_like(goal, np.nan)
        misses = 0
        while True:
            try:
                meas = self._read()
                misses = 0
            except _Abort as exc:
                misses += 1
                if exc.reason is not StopReason.LOST_SERVO or misses >= self.lost_after:
                    raise MotionStopped(exc.reason, exc.message + "; the arm was at the end of "
                                        "its motion", exc.joint, exc.servo_id, goal) from None
                time.sleep(dt)
                continue
            if goal.size == 0 or float(np.max(np.abs(meas - goal))) <= self.settle_tolerance:
                return time.perf_counter() - t0, meas
            if time.perf_counter() - t0 > self.settle_timeout:
                return time.perf_counter() - t0, meas
            time.sleep(dt)
            self.bus.write_joints(goal)

    def hold(self) -> Array:
        """Hold the present position: goal = present, then torque on (never a jump).

        Returns:
            The held position (bus joint order).
        """
        q = np.asarray(self.bus.read_joints(), dtype=float)
        q = np.clip(q, self.limits.lower[self.idx], self.limits.upper[self.idx])
        self.bus.write_joints(q)
        self.bus.set_torque(True)
        self.last_command = q
        return q
