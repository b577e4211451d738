"""Stop requests: Ctrl-C (SIGINT) handling that asks the streaming loop to stop safely.

The first Ctrl-C asks for a controlled stop (decelerate within the limits, then hold). A second
one asks for the exit policy (hold, park or release) once the arm is at rest. Neither interrupts
the stop itself: the arm is never left moving or dropped half-way.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

__all__ = ["StopRequest", "ignore_sigint", "sigint_stops"]


class StopRequest:
    """A thread-safe flag that counts stop requests."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._count = 0
        self.reason = ""

    def request(self, reason: str = "stop requested") -> None:
        """Ask for a stop (a second call asks for the exit policy)."""
        with self._lock:
            self._count += 1
            if not self.reason:
                self.reason = reason

    @property
    def requested(self) -> bool:
        """Whether a stop was asked for."""
        return self._count > 0

    @property
    def escalated(self) -> bool:
        """Whether a second request came (apply the exit policy)."""
        return self._count > 1

    def clear(self) -> None:
        """Forget earlier requests."""
        with self._lock:
            self._count = 0
            self.reason = ""


@contextmanager
def sigint_stops(stop: StopRequest, message: bool = True) -> Iterator[StopRequest]:
    """Route SIGINT to ``stop`` while the block runs (main thread only; elsewhere a no-op).

    Args:
        stop: The request to set.
        message: Print what each Ctrl-C does on stderr.
    """
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    import sys

    def handler(signum: int, frame: FrameType | None) -> None:
        stop.request("Ctrl-C")
        if message:
            text = ("stopping: decelerating, then holding position (Ctrl-C again to apply the "
                    "exit policy)" if not stop.escalated else
                    "exit policy will be applied once the arm is at rest")
            print(f"\narmctl: {text}", file=sys.stderr, flush=True)

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, previous)


@contextmanager
def ignore_sigint(reason: str) -> Iterator[None]:
    """Ignore Ctrl-C while the block runs (parking must not be cut short), saying why.

    Args:
        reason: What is running, e.g. ``"parking"``.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    import sys

    def handler(signum: int, frame: FrameType | None) -> None:
        print(f"\narmctl: {reason}: Ctrl-C is ignored until it is done", file=sys.stderr,
              flush=True)

    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
