"""Clocks: the time base of the motion loop, teaching and the simulated servos.

A :class:`Clock` tells the time (:meth:`Clock.now` [s]) and waits for a moment
(:meth:`Clock.sleep_until`). :class:`WallClock` is real time. :class:`SimulatedClock` is time that
passes only when someone sleeps: a motion streamed to the simulated bus with a simulated clock
runs as fast as the CPU allows, and the simulated servos move by the simulated time between two
requests, so the same move gives the same readings on every run, however loaded the machine.

The executor, teaching and the simulator take a clock as a constructor argument; without one they
use :func:`default_clock` (a :class:`WallClock` unless :func:`set_default_clock` chose another),
so that a test or a script can run everything it opens in simulated time::

    previous = set_default_clock(SimulatedClock())
    try:
        with Robot.open("so101") as robot:
            robot.move_joints(q)
    finally:
        set_default_clock(previous)
"""

from __future__ import annotations

import threading
import time
from typing import Protocol, runtime_checkable

__all__ = ["Clock", "SimulatedClock", "WallClock", "default_clock", "set_default_clock"]


@runtime_checkable
class Clock(Protocol):
    """A time base: the time now and a wait until a given time."""

    def now(self) -> float:
        """The time now [s] (monotonic; only differences mean anything)."""
        ...

    def sleep_until(self, t: float) -> None:
        """Return at time ``t`` [s] (at once if it has passed)."""
        ...


class WallClock:
    """Real time: :func:`time.perf_counter` and :func:`time.sleep`."""

    def now(self) -> float:
        """The performance counter [s]."""
        return time.perf_counter()

    def sleep_until(self, t: float) -> None:
        """Sleep until the performance counter reaches ``t`` [s]."""
        wait = t - time.perf_counter()
        if wait > 0.0:
            time.sleep(wait)

    def __repr__(self) -> str:
        return "WallClock()"


class SimulatedClock:
    """Simulated time: it stands still until someone sleeps, then jumps to the wake-up time.

    Thread-safe: the simulated bus reads it in its own thread while the motion loop sleeps.

    Args:
        start: The time at creation [s].
    """

    def __init__(self, start: float = 0.0):
        self._t = float(start)
        self._lock = threading.Lock()

    def now(self) -> float:
        """The simulated time [s]."""
        with self._lock:
            return self._t

    def sleep_until(self, t: float) -> None:
        """Advance the simulated time to ``t`` [s] (never backwards); returns at once."""
        with self._lock:
            if t > self._t:
                self._t = float(t)

    def advance(self, dt: float) -> None:
        """Let ``dt`` [s] of simulated time pass (``dt`` >= 0)."""
        if dt < 0.0:
            raise ValueError(f"a simulated clock cannot go back: advance({dt!r})")
        with self._lock:
            self._t += float(dt)

    def __repr__(self) -> str:
        return f"SimulatedClock(t={self.now():.6f})"


_default: Clock = WallClock()
_default_lock = threading.Lock()


def default_clock() -> Clock:
    """The clock that executors, teaching sessions and simulated buses use when given none."""
    return _default


def set_default_clock(clock: Clock | None) -> Clock:
    """Make ``clock`` the default (``None``: real time again).

    Only objects created afterwards use it; pass a clock explicitly to mix time bases.

    Returns:
        The previous default, to restore it.
    """
    global _default
    with _default_lock:
        previous = _default
        _default = clock if clock is not None else WallClock()
    return previous
