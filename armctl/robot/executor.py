"""The streaming loop: a checked plan sent to the servos at a fixed rate, and stopped safely.

Every cycle has a deadline ``t0 + k / rate``; the loop sleeps until it, samples the trajectory at
the planned time, sends one sync write of goal positions, reads the state back in one sync read,
and measures the tracking error (measured position against the command of the previous cycle)
and the loop jitter (cycle start minus deadline). A late cycle does not make the loop rush: the
next deadline is the first one still ahead, and the missed ones are counted as overruns.

The loop stops safely on a stop request (SIGINT/Ctrl-C, SIGTERM, SIGHUP, routed to a
:class:`StopRequest` while it runs; a ``KeyboardInterrupt`` or error raised by the ``on_cycle``
callback), a servo alarm, a servo that stops answering, or a tracking error above the limit: it
plans a jerk-limited stop from the commanded state, streams it, and holds the final position with
torque on. A second stop request during that deceleration holds at once: the goal becomes the
present reading.

With a :class:`~armctl.robot.motion_control.MotionControl`, the planned time of a cycle is no
longer ``k / rate``: it advances at the rate the control asks for (pause, resume, speed
override), changed smoothly within the joint limits by time scaling along the plan
(:mod:`armctl.robot.time_scaling`); the path stays the plan's.
"""

from __future__ import annotations

import logging
import math
import signal
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import numpy.typing as npt

from armctl.clock import Clock, default_clock
from armctl.config.schema import JointRole, JointType
from armctl.errors import ArmctlError, BusError
from armctl.kinematics.model import KinematicModel
from armctl.motion import MotionLimits, MotionPlan, Trajectory, stop_trajectory
from armctl.robot.errors import MotionStopped, StopReason
from armctl.robot.motion_control import MotionControl
from armctl.robot.stop import StopRequest, signals_stop
from armctl.robot.time_scaling import PlanTable, RateFollower
from armctl.servo.errors import PortIOError, ServoAlarmError
from armctl.typing import Array

__all__ = ["BusState", "CycleInfo", "Executor", "JointBus", "StreamResult", "StreamStats"]


logger = logging.getLogger(__name__)

#: A motion logs a warning for a servo that needed more retries than this fraction of its
#: cycles (and at least :data:`RETRY_WARNING_MIN`): an intermittent fault hidden by retries.
RETRY_WARNING = 0.05
RETRY_WARNING_MIN = 3

#: A joint is at rest when, at every reading over the settle dwell, its present velocity is
#: below this many arrival tolerances per second (0.03 rad/s, 3 mm/s at the default
#: tolerances: one count of a Dynamixel's 0.229 rpm velocity unit passes, two do not) ...
REST_SPEED = 3.0
#: ... the mean of those velocities is below this many tolerances per second (0.01 rad/s: a
#: servo still creeping at one velocity count is not at rest, one flickering between 0 and
#: +-1 count is) ...
REST_DRIFT = 1.0
#: ... and its readings span at most this fraction of its arrival tolerance (2.5 mrad: one
#: tick of a 4096-tick servo passes, two do not). A bus that reports no velocity is judged by
#: its readings alone.
REST_BAND = 0.25


class BusState(Protocol):
    """What the loop reads from a bus state (:class:`armctl.servo.arm_bus.JointState`)."""

    @property
    def position(self) -> Array:
        """Present positions [rad]/[m]."""
        ...

    @property
    def velocity(self) -> Array:
        """Present velocities [rad/s]/[m/s]."""
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

    def write_joints(self, q: npt.ArrayLike, *, skip_alarmed: bool = False) -> None:
        """Goal positions, one sync write (``skip_alarmed``: leave alarmed servos out)."""
        ...

    def set_torque(self, on: bool, joints: Sequence[str] | None = None) -> None:
        """Torque on or off."""
        ...


@dataclass(frozen=True)
class CycleInfo:
    """What one cycle did, for progress displays.

    Attributes:
        t: Planned time of the cycle [s]: where along the plan the command is (it stands
            still while the motion is paused).
        duration: Planned duration of the whole motion [s].
        command: Goal positions sent, bus joint order.
        measured: Positions read back.
        tracking_error: Largest |measured - previous command| [rad]/[m].
        stopping: Whether a stop is under way.
        elapsed: Time since the first cycle on the executor's clock [s].
        rate: How fast the plan's time advances now [-] (1: as planned, 0: held).
        paused: Whether a pause is asked for (:class:`~armctl.robot.motion_control.MotionControl`).
        speed: The speed override the motion heads for [-] (capped to what the plan allows).
    """

    t: float
    duration: float
    command: Array
    measured: Array
    tracking_error: float
    stopping: bool
    elapsed: float = 0.0
    rate: float = 1.0
    paused: bool = False
    speed: float = 1.0


@dataclass(frozen=True)
class StreamStats:
    """Figures of one streamed motion.

    Attributes:
        rate_hz: Target loop rate [Hz].
        cycles: Cycles run.
        elapsed: Time on the executor's clock from the first to the last cycle start [s].
        jitter_mean: Mean lateness of cycle starts [s].
        jitter_p99: 99th percentile lateness [s].
        jitter_max: Largest lateness [s].
        overruns: Deadlines missed entirely.
        io_time_mean: Mean time of one write + read [s].
        max_tracking_error: Largest tracking error per bus joint [rad]/[m].
        settle_time: Time after the end of the plan (or of a stop) until the servos had settled:
            every joint within its arrival tolerance and at rest for the settle dwell [s].
        retries: Failed bus attempts (missing, corrupt or late replies, each retried) per
            servo id during the motion; only servos with any.
        held_time: Time the motion spent paused at rest [s].
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
    retries: Mapping[int, int] = field(default_factory=dict)
    held_time: float = 0.0

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
        log_t: Planned time of each cycle (only with ``record=True``) [s].
        log_cmd: Commands ``(N, n_bus)`` (only with ``record=True``).
        log_meas: Measurements ``(N, n_bus)`` (only with ``record=True``).
        log_elapsed: Time of each cycle since the first on the executor's clock (only with
            ``record=True``) [s]; it runs on while a paused motion's planned time stands still.
    """

    stats: StreamStats
    final: Array
    log_t: Array = field(default_factory=lambda: np.zeros(0))
    log_cmd: Array = field(default_factory=lambda: np.zeros((0, 0)))
    log_meas: Array = field(default_factory=lambda: np.zeros((0, 0)))
    log_elapsed: Array = field(default_factory=lambda: np.zeros(0))


class _Abort(ArmctlError):
    """Why the streaming loop must stop; caught inside the executor and raised as MotionStopped."""

    def __init__(self, reason: StopReason, message: str, joint: str | None = None,
                 servo_id: int | None = None):
        super().__init__(message, {"reason": reason.value, "joint": joint,
                                   "servo_id": servo_id})
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
        settle_tolerance: Arrival tolerance of rotary joints [rad]: at the end of a motion
            every arm joint must come this close to the goal and come to rest there, else the
            motion fails.
        settle_timeout: Longest wait for that after the last sample of the plan [s].
        lost_after: A servo counts as lost after this many cycles in a row without a reply
            (each read already retries; one slow cycle is not a lost servo).
        settle_tolerance_linear: Arrival tolerance of prismatic joints [m].
        explain_short: Called with a joint's name and goal [rad]/[m] when it did not arrive;
            returns a likely cause to add to the error (or ``None``), e.g. from the servo's
            registers.
        clock: Time base of the loop (default :func:`~armctl.clock.default_clock`); give it the
            simulated bus's :class:`~armctl.clock.SimulatedClock` to stream in simulated time.
        settle_dwell: How long every joint must stay within its tolerance and at rest before
            the motion counts as arrived [s].

    A joint is at rest when, over the whole dwell, its present velocity stays below
    :data:`REST_SPEED` tolerances per second and averages below :data:`REST_DRIFT`, and its
    readings span at most :data:`REST_BAND` of a tolerance.
    Gripper joints are not held to the arrival tolerance: a gripper closing on an object
    stops short of its goal by design.
    """

    def __init__(self, bus: JointBus, model: KinematicModel, limits: MotionLimits,
                 rate_hz: float = 50.0, max_tracking_error: float = 0.2,
                 settle_tolerance: float = 0.01, settle_timeout: float = 1.0,
                 lost_after: int = 3, settle_tolerance_linear: float = 0.001,
                 explain_short: Callable[[str, float], str | None] | None = None,
                 clock: Clock | None = None, settle_dwell: float = 0.05):
        self.bus = bus
        self.clock = clock if clock is not None else default_clock()
        self.model = model
        self.limits = limits
        self.rate_hz = float(rate_hz)
        self.max_tracking_error = float(max_tracking_error)
        self.settle_tolerance = settle_tolerance
        self.settle_timeout = settle_timeout
        self.settle_dwell = float(settle_dwell)
        self.lost_after = lost_after
        self.explain_short = explain_short
        self.idx = np.array([model.joint_index(n) for n in bus.joint_names], dtype=int)
        self.last_command: Array | None = None
        #: The cycles of the latest stream ``(t, commands, measurements)``, kept with
        #: ``record=True`` even when it ended in a stop or a failure.
        self.last_log: tuple[list[float], list[Array], list[Array]] = ([], [], [])
        prismatic = np.array([model.joint_types[i] is JointType.PRISMATIC for i in self.idx],
                             dtype=bool)
        #: Arrival tolerance per bus joint [rad]/[m].
        self.arrival_tolerance: Array = np.where(prismatic, settle_tolerance_linear,
                                                 settle_tolerance)
        #: Bus joints that must arrive (every joint but the grippers).
        self.must_arrive = np.array([model.joint_roles[i] is not JointRole.GRIPPER
                                     for i in self.idx], dtype=bool)

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

    def _write(self, q_full: Array, skip_alarmed: bool = False) -> Array:
        cmd = np.clip(q_full[self.idx], self.limits.lower[self.idx], self.limits.upper[self.idx])
        try:
            if skip_alarmed:  # a stop: goals for every servo but those that reported an alarm
                self.bus.write_joints(cmd, skip_alarmed=True)
            else:
                self.bus.write_joints(cmd)
        except BusError as exc:
            raise self._bus_abort(exc) from exc
        self.last_command = cmd
        return cmd

    def _bus_abort(self, exc: BusError) -> _Abort:
        """The stop for a bus error: the port failed, a servo is alarmed, or it is lost."""
        if isinstance(exc, PortIOError):
            return _Abort(StopReason.BUS_IO, str(exc).split("\n")[0])
        sid = getattr(exc, "servo_id", None)
        joint = self._joint_of(sid)
        who = f"servo {sid}" + (f" (joint {joint!r})" if joint else "") if sid is not None \
            else "the bus"
        if isinstance(exc, ServoAlarmError):
            return _Abort(StopReason.SERVO_ERROR, f"{who}: {exc}", joint, sid)
        return _Abort(StopReason.LOST_SERVO, f"{who} stopped answering: {exc}", joint, sid)

    def _retry_counts(self) -> dict[int, int]:
        counts = getattr(self.bus, "retry_counts", None)
        return dict(counts()) if callable(counts) else {}

    def _retries_since(self, before: Mapping[int, int], cycles: int) -> dict[int, int]:
        """Failed bus attempts per servo since ``before``; warns past :data:`RETRY_WARNING`."""
        now = self._retry_counts()
        out = {sid: n - before.get(sid, 0) for sid, n in sorted(now.items())
               if n > before.get(sid, 0)}
        for sid, n in out.items():
            if n >= max(RETRY_WARNING_MIN, RETRY_WARNING * cycles):
                joint = self._joint_of(sid)
                spec = getattr(self.bus, "spec", None)
                hint = ("this is the built-in simulated bus, so no hardware is involved: a fault "
                        "injected into the simulator, or a machine too busy to answer in time"
                        if getattr(spec, "simulated", False) else
                        "check its cable, connectors and power supply")
                logger.warning("servo %d%s needed %d retries in %d cycles: its replies are "
                               "missing, corrupt or late; %s", sid,
                               f" (joint {joint!r})" if joint else "", n, cycles, hint)
        return out

    def _read(self) -> Array:
        return self._read_state()[0]

    def _read_state(self) -> tuple[Array, Array | None]:
        """Present positions and velocities (``None`` when the bus reports none)."""
        try:
            state = self.bus.read_state()
        except BusError as exc:
            raise self._bus_abort(exc) from exc
        for name, alarms in zip(self.bus.joint_names, state.errors, strict=False):
            if alarms:
                sid = self._servo_id(name)
                what = ", ".join(getattr(a, "value", str(a)) for a in alarms)
                raise _Abort(StopReason.SERVO_ERROR,
                             f"servo {sid} (joint {name!r}) reports {what}", name, sid)
        pos = np.asarray(state.position, dtype=np.float64)
        vel = getattr(state, "velocity", None)
        if vel is not None:
            vel = np.asarray(vel, dtype=np.float64)
            if vel.shape != pos.shape:
                vel = None
        return pos, vel

    # ---- the loop --------------------------------------------------------------------------
    def run(self, plan: MotionPlan, stop: StopRequest | None = None,
            on_cycle: Callable[[CycleInfo], None] | None = None,
            record: bool = False, control: MotionControl | None = None) -> StreamResult:
        """Stream a plan; return when the servos have settled at its end.

        While it runs (in the main thread), SIGINT, SIGTERM and SIGHUP are routed to ``stop``
        (:func:`~armctl.robot.stop.signals_stop`): the first decelerates and holds, a second
        holds at once.

        With a ``control``, the plan is followed by time scaling along its path
        (:mod:`armctl.robot.time_scaling`): a pause decelerates to a stop on the path and holds
        there (still reading the servos and watching for faults), a resume or a speed change
        changes pace, each within the joints' velocity, acceleration and jerk limits; a stop
        starts from the commanded state as scaled. A pause too close to the plan's end lets
        the plan finish.

        Args:
            plan: A checked plan starting at the present position.
            stop: Stop requests to watch.
            on_cycle: Called after every cycle (keep it fast). A ``KeyboardInterrupt`` it
                raises is a stop request; another exception stops the arm the same way and is
                raised again once the arm holds.
            record: Keep every command and measurement in the result.
            control: Pause, resume, speed override and stop from other threads (``None``: the
                plan runs as timed).

        Returns:
            Timing and tracking figures and the final measured position.

        Raises:
            MotionStopped: After a controlled stop, for a stop request (signal or
                ``KeyboardInterrupt``), a servo alarm, a lost servo or a tracking error; the
                arm holds where the stop ended. A stop request in the last cycle or while the
                servos settle at the goal also ends in ``MotionStopped`` (the arm holds at the
                goal): a motion asked to stop never reports success.
        """
        stop = stop or StopRequest()
        if self.last_command is None:  # nothing commanded yet: torque on, holding, first
            self.hold()
        if control is not None:
            control.begin(stop)
        try:
            with signals_stop(stop):
                result = self._stream(plan, stop, on_cycle, record, control)
        finally:
            if control is not None:
                control.end()
        if stop.requested:  # between the settled end and the handlers' restoring
            raise self._stopped_at_goal(plan, stop)
        return result

    def _follower(self, traj: Trajectory, control: MotionControl | None,
                  dt: float) -> RateFollower:
        """The plan's time as the control wants it (at rate 1 without a control)."""
        if control is None:
            return RateFollower(None, 1.0, dt)
        table = PlanTable.of(traj, self.limits)
        control.set_cap(table.cap)
        return RateFollower(table, control.wanted(), min(dt, 0.01))

    def _stream(self, plan: MotionPlan, stop: StopRequest,
                on_cycle: Callable[[CycleInfo], None] | None, record: bool,
                control: MotionControl | None = None) -> StreamResult:
        """The loop of :meth:`run` (signals already routed to ``stop``)."""
        traj: Trajectory = plan.trajectory
        dt = 1.0 / self.rate_hz
        retries0 = self._retry_counts()
        jitter: list[float] = []
        io: list[float] = []
        log_t: list[float] = []
        log_c: list[Array] = []
        log_m: list[Array] = []
        log_e: list[float] = []
        self.last_log = (log_t, log_c, log_m)
        worst = np.zeros(self.idx.size)
        prev_cmd: Array | None = None
        overruns = 0
        follower = self._follower(traj, control, dt)
        s = rate = rate_d = 0.0  # the plan's time [s], its rate [-] and rate's rate [1/s]
        held_cycles = 0  # cycles paused at rest
        # a stop under way: its trajectory, and the loop time and plan time it began at
        stopping: tuple[Trajectory, float, float] | None = None
        abort: _Abort | None = None
        blind = False  # after a lost servo: keep writing, stop reading
        missed_reads = 0
        failure: BaseException | None = None  # raised by on_cycle
        frozen = False  # a second stop request: held at once
        clock = self.clock
        t0 = last_start = clock.now()
        k = 0
        while True:
            deadline = t0 + k * dt
            clock.sleep_until(deadline)
            start = clock.now()
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
            if stop.escalated:
                if abort is None:
                    abort = _Abort(StopReason.USER, f"stopped by {stop.reason}")
                logger.warning("second stop request: holding at once at the present position")
                self._freeze(blind)
                frozen = True
                break
            if stopping is None:
                s, rate, rate_d, _ = follower.follow(t, control.wanted() if control else 1.0)
                if control is not None:
                    control.report(rate)
            if stopping is None and (stop.requested or abort is not None):
                if abort is None:
                    abort = _Abort(StopReason.USER, f"stopped by {stop.reason}")
                    logger.warning("%s: decelerating within the joint limits, then holding "
                                   "(a second one holds at once)", stop.reason)
                s = min(s, traj.duration)
                q, qd, qdd = traj.sample(s)  # the commanded state, as time-scaled
                stopping = (stop_trajectory(q, qd * rate, qdd * rate**2 + qd * rate_d,
                                            self.limits), t, s)
            if stopping is not None:
                s_traj, s_t0, s_at = stopping
                q_full = s_traj.sample(t - s_t0)[0]
                finished = t - s_t0 >= s_traj.duration
                s = s_at + (t - s_t0)
            else:
                q_full = traj.sample(s)[0]
                finished = s >= traj.duration
                held_cycles += rate == 0.0
            try:
                cmd = self._write(q_full, skip_alarmed=stopping is not None)
                meas = self._read() if not blind else cmd
                missed_reads = 0
            except _Abort as exc:
                if exc.reason is StopReason.BUS_IO:  # nothing more can be sent or read
                    abort, blind = exc, True
                    break
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
            io.append(clock.now() - start)
            err = np.abs(meas - (prev_cmd if prev_cmd is not None else cmd))
            worst = np.maximum(worst, err)
            prev_cmd = cmd
            if record:
                log_t.append(s)
                log_c.append(cmd)
                log_m.append(meas)
                log_e.append(t)
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
                try:
                    now = control.state() if control is not None else None
                    on_cycle(CycleInfo(s, traj.duration, cmd, meas,
                                       float(np.max(err, initial=0.0)), stopping is not None,
                                       t, rate if stopping is None else 0.0,
                                       now.paused if now is not None else False,
                                       now.applied if now is not None else 1.0))
                except BaseException as exc:  # Ctrl-C, or an error in the caller's callback
                    if isinstance(exc, KeyboardInterrupt):
                        if not stop.requested:  # once per motion: never a second request
                            stop.request("Ctrl-C (KeyboardInterrupt)", signal.SIGINT)
                        failure = failure or exc
                    else:
                        on_cycle = None  # it failed: stop without calling it again
                        if abort is None:
                            abort = _Abort(StopReason.USER, f"the on_cycle callback raised "
                                           f"{type(exc).__name__}: {exc}")
                            failure = exc
                        else:
                            logger.warning("the on_cycle callback raised %s: %s",
                                           type(exc).__name__, exc)
            k += 1
            if finished and abort is None:
                break
            if finished and stopping is not None:
                break
        elapsed = last_start - t0
        t_stop = stopping[2] if stopping is not None else min(s, traj.duration)
        settle = 0.0
        final_cmd = self.last_command if self.last_command is not None else np.zeros(0)
        meas_final = final_cmd
        if frozen and not blind:
            settle, meas_final = self._await_rest(final_cmd)
        elif not blind and abort is None:  # arrival: at the plan's own end, not a clipped one
            settle, meas_final = self._settle(traj.end[self.idx], plan, traj.duration,
                                              stop=stop)
        elif not blind:
            settle, meas_final = self._settle(final_cmd, plan, t_stop, require=False)
            if abort is not None and abort.reason is StopReason.TRACKING:
                final_cmd = self._give_way(final_cmd, meas_final, plan)
        if abort is None and stop.requested:  # in the last cycle, or while settling
            raise self._stopped_at_goal(plan, stop) from failure
        jit = np.array(jitter) if jitter else np.zeros(1)
        stats = StreamStats(
            rate_hz=self.rate_hz, cycles=len(jitter), elapsed=elapsed,
            jitter_mean=float(jit.mean()), jitter_p99=float(np.percentile(jit, 99)),
            jitter_max=float(jit.max()), overruns=overruns,
            io_time_mean=float(np.mean(io)) if io else math.nan, max_tracking_error=worst,
            settle_time=settle, retries=self._retries_since(retries0, len(jitter)),
            held_time=held_cycles * dt)
        final = plan.trajectory.end.copy()
        final[self.idx] = meas_final
        if abort is not None:
            held = self._full(plan, final_cmd)
            suffix = ("; the arm decelerated and holds its position" if not blind else
                      "; the other servos decelerated and hold their position")
            if abort.reason is StopReason.BUS_IO:
                suffix = "; nothing more could be sent: each servo holds the last goal it got"
            if frozen:
                suffix = ("; a second stop request held it at once at its present position"
                          if not blind else "; a second stop request held the other servos "
                          "at once")
            if failure is not None and not isinstance(failure, KeyboardInterrupt):
                logger.warning("%s%s", abort.message, suffix)
                raise failure
            raise MotionStopped(abort.reason, abort.message + suffix, abort.joint,
                                abort.servo_id, held, t_stop,
                                stop.signum if abort.reason is StopReason.USER else None
                                ) from failure
        return StreamResult(stats, final, np.array(log_t), np.array(log_c), np.array(log_m),
                            np.array(log_e))

    def _settle(self, goal: Array, plan: MotionPlan, at: float, require: bool = True,
                stop: StopRequest | None = None) -> tuple[float, Array]:
        """Keep holding ``goal`` until the servos have settled there (or time out).

        Settled means that every joint (other than a gripper) is within its arrival tolerance
        of ``goal`` and at rest (see :class:`Executor`) at every reading over
        ``settle_dwell``. A position loop closes in on its goal gradually, so a joint that has
        just come within its tolerance may still be moving: the position it comes to rest at is
        the one the motion reports.

        Args:
            goal: The position to hold (bus joint order): the plan's end, or where a stop ended.
            plan: The plan that was streamed (for the joints without a servo, and the report).
            at: When along the plan the motion ended [s] (its duration, or where a stop began).
            require: Fail if a joint (other than a gripper) has not settled by the timeout.
            stop: Stop requests to watch: a request ends the wait at once (the goal stays
                commanded; the caller reports the stop).

        Returns:
            The time it took [s] and the last measured position (never the goal itself).

        Raises:
            MotionStopped: For a servo alarm, a servo lost for ``lost_after`` reads, a bus
                error while holding the goal, or (with ``require``) a joint that has not
                settled by ``settle_timeout`` (reason ``NOT_REACHED``), naming the joint, its
                servo, how far short it is (and how fast it still moves) and a likely cause.
        """
        clock = self.clock
        t0 = clock.now()
        dt = 1.0 / self.rate_hz
        meas = np.full_like(goal, np.nan)
        vel: Array | None = None
        # the readings since every joint came within its tolerance at a low speed (trimmed to
        # the last dwell) and when that was
        window: list[tuple[float, Array, Array | None]] = []
        since = t0
        restless = np.zeros(goal.shape, dtype=bool)  # the joints that ended the last window
        misses = 0
        while True:
            try:
                meas, vel = self._read_state()
                misses = 0
            except _Abort as exc:
                misses += 1
                if exc.reason is not StopReason.LOST_SERVO or misses >= self.lost_after:
                    raise self._settle_failed(exc, goal, plan, at, require) from None
                window.clear()  # a reading missed: the rest must be seen again
                clock.sleep_until(clock.now() + dt)
                continue
            now = clock.now()
            if stop is not None and stop.requested:
                return now - t0, meas
            if goal.size == 0:
                return now - t0, meas
            short = (np.abs(meas - goal) > self.arrival_tolerance) & self.must_arrive
            fast = np.zeros(goal.shape, dtype=bool) if vel is None else (
                (np.abs(vel) > REST_SPEED * self.arrival_tolerance) & self.must_arrive)
            if short.any() or fast.any():
                window.clear()
                restless = fast
            else:
                if not window:
                    since = now
                window.append((now, meas, vel))
                span = max(self.settle_dwell, dt)  # at least two readings
                window = [r for r in window if r[0] >= now - span - 1e-9]
                if now - since >= self.settle_dwell - 1e-9:
                    restless = self._drifting(window)
                    if not restless.any():
                        return now - t0, meas
            if now - t0 > self.settle_timeout:
                if require:
                    raise self._not_reached(goal, meas, vel, short, restless & ~short,
                                            now - t0, self._full(plan, goal), at)
                return now - t0, meas
            clock.sleep_until(now + dt)
            try:  # nothing to a servo that reported an alarm: the next read names it
                self._write(self._full(plan, goal), skip_alarmed=True)
            except _Abort as exc:
                raise self._settle_failed(exc, goal, plan, at, require) from None

    def _drifting(self, window: Sequence[tuple[float, Array, Array | None]]
                  ) -> npt.NDArray[np.bool_]:
        """The joints (gripper excepted) not at rest over ``window``: (time, reading, velocity).

        Every reading of the window is within tolerance and below :data:`REST_SPEED` already;
        a joint still drifts when its readings span more than :data:`REST_BAND` of a
        tolerance or its velocities average more than :data:`REST_DRIFT` tolerances per second.
        """
        pos = np.array([r[1] for r in window])
        drift = np.ptp(pos, axis=0) > REST_BAND * self.arrival_tolerance
        vels = [r[2] for r in window]
        if all(v is not None for v in vels):
            drift |= np.abs(np.mean(np.array(vels), axis=0)) > REST_DRIFT * self.arrival_tolerance
        return drift & self.must_arrive

    def _full(self, plan: MotionPlan, bus_values: Array) -> Array:
        """The arm vector ``(dof,)``: ``bus_values`` on the servo joints, else the plan's end."""
        full = plan.trajectory.end.copy()
        full[self.idx] = bus_values
        return full

    def _settle_failed(self, exc: _Abort, goal: Array, plan: MotionPlan, at: float,
                       arrived: bool) -> MotionStopped:
        """The error for a bus fault while the servos settle (``arrived``: at the plan's end)."""
        suffix = ("; nothing more could be sent: each servo holds the last goal it got"
                  if exc.reason is StopReason.BUS_IO else
                  "; the arm was at the end of its motion" if arrived else
                  "; the arm was stopping")
        return MotionStopped(exc.reason, exc.message + suffix, exc.joint, exc.servo_id,
                             self._full(plan, goal), at)

    def _stopped_at_goal(self, plan: MotionPlan, stop: StopRequest) -> MotionStopped:
        """The error for a stop request that came as the motion reached its goal."""
        held = self.last_command if self.last_command is not None else plan.trajectory.end[
            self.idx]
        return MotionStopped(StopReason.USER, f"stopped by {stop.reason} as the motion reached "
                             "its goal; the arm holds there", None, None, self._full(plan, held),
                             plan.duration, stop.signum)

    def _not_reached(self, goal: Array, meas: Array, vel: Array | None,
                     short: npt.NDArray[np.bool_], restless: npt.NDArray[np.bool_],
                     waited: float, held: Array, at: float) -> MotionStopped:
        """The error for joints that did not settle at the goal at the end of a motion.

        Args:
            goal: The goal (bus joint order).
            meas: The last reading.
            vel: The last velocity reading (``None`` when the bus reports none).
            short: Joints outside their arrival tolerance.
            restless: Joints within it but not at rest.
            waited: Time since the end of the motion [s].
            held: The goal held, arm vector.
            at: When along the plan the motion ended [s].
        """
        load: Array | None = None
        try:
            load = np.asarray(getattr(self.bus.read_state(), "load", None), dtype=float)
        except (BusError, TypeError, ValueError):
            load = None
        dist = np.abs(meas - goal)
        speed = np.abs(vel) if vel is not None else None
        if short.any():
            j = int(np.argmax(np.where(short, dist, -1.0)))
        else:  # all within tolerance: the one moving most (relative to its tolerance)
            score = (speed if speed is not None else dist) / self.arrival_tolerance
            j = int(np.argmax(np.where(restless, score, -1.0) if restless.any() else dist))
        name = self.bus.joint_names[j]
        sid = self._servo_id(name)
        i = int(self.idx[j])
        servo = f" (servo {sid})" if sid is not None else ""
        where = (f"it is at {self._shown(i, meas[j])}, the goal is {self._shown(i, goal[j])} "
                 f"(tolerance {self._shown(i, float(self.arrival_tolerance[j]))})")
        moves = (f"moving at {self._shown(i, float(speed[j]))}/s"
                 if speed is not None and speed[j] > 0 else "creeping, its readings changing")
        after = f"{waited:.1f} s after the end of the motion; the move did not arrive"
        if short[j]:
            text = (f"joint {name!r}{servo} stopped {self._shown(i, dist[j])} short of its "
                    f"goal: {where}, {after}")
        else:
            text = (f"joint {name!r}{servo} did not come to rest at its goal: {where}, still "
                    f"{moves} (it is {self._shown(i, dist[j])} off), {after}")
        others = [f"{self.bus.joint_names[k]} {self._shown(int(self.idx[k]), dist[k])}"
                  for k in np.flatnonzero(short) if k != j]
        if others:
            text += f" (also short: {', '.join(others)})"
        unrest = [str(self.bus.joint_names[k]) for k in np.flatnonzero(restless) if k != j]
        if unrest:
            text += f" (also not at rest: {', '.join(unrest)})"
        cause = (self.explain_short(name, float(goal[j]))
                 if self.explain_short and short[j] else None)
        if cause is None and short[j]:
            reading = (f" (present load: {100 * load[j]:.0f} % of the servo's stall torque)"
                       if load is not None and load.shape == goal.shape else "")
            cause = ("Likely cause: something blocks the joint or it carries more than the "
                     f"servo can hold{reading}, or the servo's own Min/Max Position Limit "
                     "register stops it. Check for an obstacle and the load, and compare the "
                     "registers with 'armctl status'.")
        elif cause is None:
            cause = ("Likely cause: the servo hunts around its goal (its position gains are "
                     "too high for what the joint carries) or something keeps pushing the "
                     "joint. Check the load, and the servo's position gain registers (a lower "
                     "P gain or a higher D gain damps it).")
        if short.any():
            bus_held = self._give_way(goal, meas, None)
            held = held.copy()
            held[self.idx] = bus_held
            hold_text = ("Torque stays on: the joints short of their goal hold where they "
                         "stopped (no longer pushing), the others hold the goal.")
        else:
            hold_text = "Torque stays on with the goal commanded."
        return MotionStopped(StopReason.NOT_REACHED, f"{text}. {cause} {hold_text}", name, sid,
                             held, at)

    def _give_way(self, goal: Array, meas: Array, plan: MotionPlan | None) -> Array:
        """Stop pushing: joints held away from ``goal`` take their measured position as goal.

        A joint that something blocks would otherwise press on the obstacle at full current
        and heat its servo until the overheating alarm. Grippers keep their goal (they close on
        objects by design); the new goals stay inside the limits.

        Args:
            goal: The goal held now (bus joint order).
            meas: The last reading (bus joint order).
            plan: The plan (for the joints without a servo); ``None``: the arm's present
                command is used for those.

        Returns:
            The goal held from now on (bus joint order).
        """
        away = (np.abs(meas - goal) > self.arrival_tolerance) & self.must_arrive & np.isfinite(meas)
        if not away.any():
            return goal
        new = np.where(away, np.clip(meas, self.limits.lower[self.idx],
                                     self.limits.upper[self.idx]), goal)
        if plan is not None:
            full = self._full(plan, new)
        else:
            full = np.zeros(self.model.dof)
            full[self.idx] = new
        try:
            self._write(full, skip_alarmed=True)
        except _Abort as exc:
            logger.warning("could not relieve the blocked joints: %s", exc.message)
            return goal
        logger.warning("holding %s where %s stopped instead of pushing on",
                       ", ".join(str(self.bus.joint_names[k]) for k in np.flatnonzero(away)),
                       "it" if int(away.sum()) == 1 else "they")
        return new

    def _shown(self, i: int, value: float) -> str:
        """A joint value or distance for a message: degrees (rotary) or millimetres."""
        if self.model.joint_types[i] is JointType.PRISMATIC:
            return f"{value * 1000:.2f} mm"
        return f"{math.degrees(value):.2f} deg"

    def _freeze(self, blind: bool) -> None:
        """Hold at once: goal = present reading (torque stays on; never outside the limits).

        Where the servos cannot be read (``blind``, or the read fails), the last command is held.
        """
        q = self.last_command
        if not blind:
            try:
                q = np.asarray(self.bus.read_joints(), dtype=float)
            except BusError as exc:
                logger.warning("could not read the servos to hold them (%s); holding the last "
                               "command", exc)
        if q is None:
            return
        full = np.zeros(self.model.dof)
        full[self.idx] = q
        try:
            self._write(full, skip_alarmed=True)  # nothing to a servo that reported an alarm
        except _Abort as exc:
            logger.warning("could not hold the servos at once: %s", exc.message)

    def _await_rest(self, goal: Array) -> tuple[float, Array]:
        """After a freeze: wait (at most ``settle_timeout``) until the servos are at rest.

        A servo held while moving brakes past its goal and comes back to it, so the position
        alone does not tell rest: the readings must also stop changing.

        Returns:
            The time it took [s] and the last reading (the goal when the servos cannot be read).
        """
        clock = self.clock
        t0 = clock.now()
        dt = 1.0 / self.rate_hz
        last = goal
        while clock.now() - t0 < self.settle_timeout:
            clock.sleep_until(clock.now() + dt)
            try:
                meas = np.asarray(self.bus.read_joints(), dtype=float)
            except BusError:
                break
            still = float(np.max(np.abs(meas - last), initial=0.0)) < 0.2 * self.settle_tolerance
            last = meas
            if still and float(np.max(np.abs(meas - goal), initial=0.0)) <= self.settle_tolerance:
                break
        return clock.now() - t0, last

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
