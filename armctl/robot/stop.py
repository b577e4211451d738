"""Stop requests: SIGINT (Ctrl-C), SIGTERM and SIGHUP routed to a controlled stop, and hold.

While a motion streams (:meth:`armctl.robot.Executor.run`, which every motion of
:class:`armctl.robot.Robot` goes through, wraps it in :func:`signals_stop`):

* the **first** stop signal asks for a controlled stop: the streaming loop decelerates from the
  commanded state within the joints' velocity, acceleration and jerk limits, then holds with
  torque on (:class:`~armctl.robot.errors.MotionStopped`);
* a **second** signal during that deceleration holds at once: the goal becomes the present
  reading (torque stays on), so the arm stops where it is, as fast as the servos can;
* a signal in the last cycle of a motion, or while the servos settle at its goal, stops it
  too: the arm holds at the goal and the motion still ends with
  :class:`~armctl.robot.errors.MotionStopped` (never a reported success after a stop request);
* signals after the stop has finished do not interrupt anything (see :class:`SignalGuard`).

A stop never leads to the exit policy: parking or releasing happens only when a block or a
command ends normally, or when it is asked for explicitly (``Robot.close(ExitPolicy.PARK)``).

The handlers only record the request (a signal handler must not write to a stream the program
may be writing to); the streaming loop reports it through the ``armctl.robot`` loggers. They are
installed in the main thread only (elsewhere these context managers do nothing) and the
previous handlers are restored afterwards.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

from armctl.robot.errors import SignalInterrupt, _signal_name

__all__ = ["STOP_SIGNALS", "SignalGuard", "StopRequest", "signal_name", "signals_stop"]

#: The signals that stop a motion: Ctrl-C, ``kill`` (and service managers), a closed terminal.
STOP_SIGNALS: tuple[signal.Signals, ...] = tuple(
    getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGHUP") if hasattr(signal, name))


def signal_name(signum: int) -> str:
    """``"SIGINT"`` for 2, and so on (``"signal N"`` for a number without a name)."""
    return _signal_name(signum) or ""


class StopRequest:
    """A record of stop requests: how many, why, and the first signal's number.

    Safe to call from a signal handler and from other threads: a request is one list append
    (atomic), so a signal that arrives while the main thread is inside :meth:`request` neither
    blocks on a lock nor loses a request.
    """

    def __init__(self) -> None:
        self._requests: list[tuple[str, int | None]] = []

    def request(self, reason: str = "stop requested", signum: int | None = None) -> None:
        """Ask for a controlled stop (a second call asks to hold at once).

        Args:
            reason: What asked, for messages, e.g. ``"Ctrl-C (SIGINT)"``.
            signum: The signal's number, when a signal asked.
        """
        self._requests.append((reason, signum))

    @property
    def requested(self) -> bool:
        """Whether a stop was asked for."""
        return len(self._requests) > 0

    @property
    def escalated(self) -> bool:
        """Whether a second request came: hold at once (goal = present position)."""
        return len(self._requests) > 1

    @property
    def reason(self) -> str:
        """What asked first (``""`` when nothing did)."""
        return self._requests[0][0] if self._requests else ""

    @property
    def signum(self) -> int | None:
        """The number of the signal that asked first, if a signal did."""
        return self._requests[0][1] if self._requests else None

    def clear(self) -> None:
        """Forget earlier requests."""
        del self._requests[:]


def _reason(signum: int) -> str:
    name = signal_name(signum)
    return f"Ctrl-C ({name})" if signum == signal.SIGINT else name


@contextmanager
def signals_stop(stop: StopRequest, signals: tuple[int, ...] = STOP_SIGNALS
                 ) -> Iterator[StopRequest]:
    """Route the stop signals to ``stop`` while the block runs (main thread only).

    When the handlers being replaced belong to a :class:`SignalGuard`, the guard is told that a
    motion ran (and which signal, if any, asked it to stop), so that a signal arriving after the
    motion is recorded instead of interrupting, and the command skips its exit policy.

    Args:
        stop: The request to set.
        signals: The signals to route (default :data:`STOP_SIGNALS`).
    """
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return

    def handler(signum: int, frame: FrameType | None) -> None:
        stop.request(_reason(signum), signum)

    previous: dict[int, Any] = {}
    try:
        for s in signals:
            previous[s] = signal.signal(s, handler)
        yield stop
    finally:
        for h in previous.values():  # before the guard's handlers are back
            guard = getattr(h, "__self__", None)
            if isinstance(guard, SignalGuard):
                guard.motion_ran(stop)
        for s, h in previous.items():
            signal.signal(s, h)


class SignalGuard:
    """The stop signals for the whole of a command that moves the arm.

    Until a motion has run, a signal interrupts what is under way (opening the bus, planning)
    by raising :class:`~armctl.robot.errors.SignalInterrupt`: nothing has moved. During a motion
    :func:`signals_stop` takes over, and hands the guard the signal that stopped the motion, if
    one did (:attr:`stopped_by`). Once a motion has run, a signal is only recorded
    (:attr:`signum`): it neither cuts the report short nor replaces the outcome of a stop, and
    the caller skips the exit policy.

    Use :meth:`installed` around the command (main thread only; elsewhere it does nothing).

    Attributes:
        signum: The first signal recorded after a motion had run (or after :meth:`defer`).
        stopped_by: The signal that asked a motion to stop, if one did.
        moved: Whether a motion ran (the arm may have moved).
    """

    def __init__(self) -> None:
        self.signum: int | None = None
        self.stopped_by: int | None = None
        self.moved = False
        self.deferring = False

    def defer(self) -> None:
        """From now on, record signals instead of interrupting."""
        self.deferring = True

    def motion_ran(self, stop: StopRequest) -> None:
        """A motion ran: record signals from now on, and the one that stopped it (if any)."""
        self.moved = True
        self.deferring = True
        if self.stopped_by is None and stop.signum is not None:
            self.stopped_by = stop.signum

    @property
    def signalled(self) -> bool:
        """Whether a signal stopped a motion or was recorded after one."""
        return self.signum is not None or self.stopped_by is not None

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if not self.deferring:
            raise SignalInterrupt(signum, signal_name(signum))
        if self.signum is None:
            self.signum = signum

    @contextmanager
    def installed(self, signals: tuple[int, ...] = STOP_SIGNALS) -> Iterator[SignalGuard]:
        """Install the guard's handlers while the block runs, then restore the previous ones."""
        if threading.current_thread() is not threading.main_thread():
            yield self
            return
        previous: dict[int, Any] = {}
        try:
            for s in signals:
                previous[s] = signal.signal(s, self._handle)
            yield self
        finally:
            for s, h in previous.items():
                signal.signal(s, h)
