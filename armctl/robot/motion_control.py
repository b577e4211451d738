"""Pause, resume, speed override and stop of running motions, from any thread.

A :class:`MotionControl` belongs to one :class:`~armctl.robot.Robot` (``robot.control``) and
steers every motion it streams. The streaming loop reads it once per cycle and follows it by
time scaling along the plan (:mod:`armctl.robot.time_scaling`): the arm keeps to the planned
path, slows to a stop on :meth:`~MotionControl.pause`, speeds up again on
:meth:`~MotionControl.resume`, and changes pace on :meth:`~MotionControl.set_speed`, each time
with continuous velocity and acceleration and bounded jerk, within the joints' velocity,
acceleration and jerk limits. Example::

    import threading
    from armctl.robot import Robot

    with Robot.open("so101", sim=True) as robot:
        threading.Timer(1.0, robot.pause).start()    # from another thread: decelerate, hold
        threading.Timer(3.0, robot.resume).start()   # ... and go on along the same path
        robot.move_joints([1.0, -0.5, 0.5, 0.2, 0.0, 0.0])

The state persists between motions: a motion that starts while the control is paused starts
held (at rest, where it is) until :meth:`~MotionControl.resume`; a speed override applies to
every following motion until it is changed.

Every method takes a lock for a few assignments only; they may be called from any thread
(never from a signal handler: use the stop signals for that).
"""

from __future__ import annotations

import logging
import math
import threading
from dataclasses import dataclass

from armctl.errors import InputError
from armctl.robot.stop import StopRequest
from armctl.robot.time_scaling import MAX_RATE

__all__ = ["MAX_SPEED", "MIN_SPEED", "ControlState", "MotionControl"]

logger = logging.getLogger(__name__)

#: The slowest speed override [-] (a motion 100 times as long as planned; pause to stop).
MIN_SPEED = 0.01
#: The largest speed override accepted [-]; a plan allows at most what its limits allow
#: (:attr:`ControlState.cap`), so the override applied is often less.
MAX_SPEED = MAX_RATE


@dataclass(frozen=True)
class ControlState:
    """A snapshot of a :class:`MotionControl`.

    Attributes:
        paused: Whether a pause is asked for (the arm holds, or is slowing to a stop).
        speed: The speed override asked for [-] (1: as planned).
        moving: Whether a motion is streaming.
        rate: How fast the running motion advances along its plan now [-] (0: held;
            ``None`` when no motion runs or it has not streamed a cycle yet).
        cap: The largest override the running plan allows within the joint limits [-]
            (``None`` when no motion runs or it is not known yet).
        applied: The override the running motion heads for: ``speed``, or ``cap`` when
            ``speed`` is above it [-] (``speed`` when no motion runs).
        capped: Whether the override asked for is above the running plan's cap.
        held: Paused and at rest (the running motion holds its position).
    """

    paused: bool
    speed: float
    moving: bool
    rate: float | None
    cap: float | None
    applied: float
    capped: bool
    held: bool


def check_speed_override(speed: float) -> float:
    """A speed override, checked: a finite number from :data:`MIN_SPEED` to :data:`MAX_SPEED`.

    Raises:
        InputError: For a value that is not a number, NaN or infinite, zero or negative, or
            outside that range; the message says what to use instead.
    """
    valid = (f"use a factor from {MIN_SPEED:g} to {MAX_SPEED:g} (1 = as planned, 0.5 = half "
             "as fast)")
    if isinstance(speed, bool):
        raise InputError(f"speed override {speed!r} is not a number; {valid}")
    try:
        value = float(speed)
    except (TypeError, ValueError):
        raise InputError(f"speed override {speed!r} is not a number; {valid}") from None
    if not math.isfinite(value):
        raise InputError(f"speed override {value} is not a finite number; {valid}")
    if value <= 0.0:
        raise InputError(f"speed override {value:g} must be positive; {valid}; to stop the "
                         "arm for a while, use pause() and resume()")
    if value < MIN_SPEED:
        raise InputError(f"speed override {value:g} is too slow: {valid}; to stop the arm for "
                         "a while, use pause() and resume()")
    if value > MAX_SPEED:
        raise InputError(f"speed override {value:g} is too fast: {valid}; a plan never runs "
                         "faster than its joint limits allow, whatever the override")
    return value


class MotionControl:
    """Pause, resume, speed override and stop of the motions of one robot (thread-safe).

    Args:
        speed: The speed override at the start [-] (1: as planned).

    Raises:
        InputError: For a bad ``speed`` (see :meth:`set_speed`).
    """

    def __init__(self, speed: float = 1.0):
        self._lock = threading.Lock()
        self._paused = False
        self._speed = check_speed_override(speed)
        self._stop: StopRequest | None = None
        self._rate = math.nan
        self._cap = math.nan
        self._cap_reported = False

    # ---- the API --------------------------------------------------------------------------
    def pause(self) -> None:
        """Decelerate the running motion to a stop along its path and hold there.

        The deceleration keeps the joints within their velocity, acceleration and jerk limits;
        a motion too close to its end to stop before it finishes. Motions started while paused
        start held. Does nothing when already paused.
        """
        with self._lock:
            was, self._paused = self._paused, True
        if not was:
            logger.info("pause: the motion decelerates along its path and holds")

    def resume(self) -> None:
        """Go on along the path: accelerate back to the speed override. Nothing when not paused."""
        with self._lock:
            was, self._paused = self._paused, False
        if was:
            logger.info("resume: the motion accelerates back along its path")

    def toggle(self) -> bool:
        """Pause when running, resume when paused (one atomic step).

        Returns:
            Whether the control is paused now.
        """
        with self._lock:
            self._paused = not self._paused
            paused = self._paused
        logger.info("%s", "pause" if paused else "resume")
        return paused

    def set_speed(self, speed: float) -> float:
        """Set the speed override: ``speed`` times as fast as planned.

        The change is gradual (continuous velocity and acceleration, bounded jerk). An override
        above what the running plan allows within the joint limits is capped at that
        (:attr:`ControlState.cap`, logged), never exceeded; the override asked for stays in
        force for later motions, which may allow more.

        Args:
            speed: The factor [-], :data:`MIN_SPEED` to :data:`MAX_SPEED`.

        Returns:
            The override applied to the running motion (``speed`` when no motion runs).

        Raises:
            InputError: For NaN, infinity, zero, a negative factor, or one out of range;
                nothing changes then.
        """
        value = check_speed_override(speed)
        with self._lock:
            self._speed = value
            cap = self._cap
            self._cap_reported = False
        if math.isfinite(cap) and value > cap:
            self._report_cap(value, cap)
            return cap
        return value

    def scale_speed(self, factor: float) -> float:
        """Multiply the override in effect by ``factor`` [-] (one atomic step).

        The result is kept from :data:`MIN_SPEED` to the running plan's cap (for keys such as
        ``+`` and ``-``).

        Returns:
            The new override.
        """
        if not (math.isfinite(factor) and factor > 0.0):
            raise InputError(f"speed factor {factor!r} must be a positive finite number")
        with self._lock:
            top = self._cap if math.isfinite(self._cap) else MAX_SPEED
            now = min(self._speed, top)
            self._speed = min(max(now * factor, MIN_SPEED), top)
            self._cap_reported = True  # kept within the cap: nothing to report
            return self._speed

    def stop(self) -> bool:
        """Stop the running motion like a stop signal: decelerate within the limits and hold.

        The motion ends with :class:`~armctl.robot.errors.MotionStopped`; a second call during
        the deceleration holds at once (the goal becomes the present reading).

        Returns:
            Whether a motion was running to be stopped.
        """
        with self._lock:
            stop = self._stop
        if stop is None:
            return False
        stop.request("a stop request (MotionControl.stop)")
        return True

    @property
    def paused(self) -> bool:
        """Whether a pause is asked for."""
        with self._lock:
            return self._paused

    @property
    def speed(self) -> float:
        """The speed override asked for [-]."""
        with self._lock:
            return self._speed

    def state(self) -> ControlState:
        """A consistent snapshot of the control and of the running motion."""
        with self._lock:
            moving = self._stop is not None
            cap = self._cap
            applied = min(self._speed, cap) if math.isfinite(cap) else self._speed
            return ControlState(
                paused=self._paused, speed=self._speed, moving=moving,
                rate=self._rate if math.isfinite(self._rate) else None,
                cap=cap if math.isfinite(cap) else None, applied=applied,
                capped=math.isfinite(cap) and self._speed > cap,
                held=moving and self._paused and self._rate == 0.0)

    # ---- the streaming loop's side --------------------------------------------------------
    def begin(self, stop: StopRequest) -> None:
        """A motion starts streaming; :meth:`stop` requests go to ``stop`` until :meth:`end`."""
        with self._lock:
            self._stop = stop
            self._rate = math.nan
            self._cap = math.nan
            self._cap_reported = False
            paused = self._paused
        if paused:
            logger.warning("the motion control is paused: the motion starts held where the "
                           "arm is; resume to go")

    def set_cap(self, cap: float) -> None:
        """The running plan allows overrides up to ``cap`` [-] (reported when exceeded)."""
        with self._lock:
            self._cap = float(cap)
            speed = self._speed
        if speed > cap:
            self._report_cap(speed, cap)

    def wanted(self) -> float:
        """The rate the running motion should head for [-]: 0 paused, else the capped override."""
        with self._lock:
            if self._paused:
                return 0.0
            return min(self._speed, self._cap) if math.isfinite(self._cap) else self._speed

    def report(self, rate: float) -> None:
        """The running motion advances at ``rate`` [-] now."""
        with self._lock:
            self._rate = float(rate)

    def end(self) -> None:
        """The motion has ended (also by a stop or a fault)."""
        with self._lock:
            self._stop = None
            self._rate = math.nan
            self._cap = math.nan

    def _report_cap(self, speed: float, cap: float) -> None:
        with self._lock:
            if self._cap_reported:
                return
            self._cap_reported = True
        logger.warning("speed override x%.2f capped at x%.2f: faster would exceed a joint's "
                       "velocity, acceleration or jerk limit on this motion", speed, cap)
