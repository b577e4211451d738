"""Keys during a motion command: space pauses and resumes, ``+`` and ``-`` change the speed.

While a motion verb runs with a terminal on stdin, a background thread reads single keys
(:class:`~armctl.cli._keys.KeyReader`, cbreak mode) and only calls the robot's thread-safe
:class:`~armctl.robot.motion_control.MotionControl`; the streaming loop follows it. The terminal
is restored on every way out. Without a terminal on stdin (scripts, CI) nothing is read and
nothing changes.
"""

from __future__ import annotations

import logging
import sys
import threading
from types import TracebackType
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from armctl.cli._keys import KeyReader
    from armctl.robot.motion_control import MotionControl

__all__ = ["SPEED_STEP", "MotionKeys"]

logger = logging.getLogger(__name__)

#: Factor of one ``+`` (faster) or ``-`` (slower) [-].
SPEED_STEP = 1.25
#: Keys that pause and resume, speed up and slow down.
PAUSE_KEYS = (" ", "p")
FASTER_KEYS = ("+", "=")
SLOWER_KEYS = ("-", "_")
#: How often the key thread looks whether it should end [s].
_POLL = 0.05


class MotionKeys:
    """Read motion keys in a background thread while the ``with`` block runs.

    Args:
        control: The robot's motion control.
        enabled: Read keys at all (e.g. not for a dry run).
        announce: Say which keys do what on stderr when they are active.

    Attributes:
        active: Whether keys are read (stdin is a terminal and ``enabled``).
    """

    def __init__(self, control: MotionControl, enabled: bool = True, announce: bool = True):
        self.control = control
        self.enabled = enabled
        self.announce = announce
        self.active = False
        self._reader: KeyReader | None = None
        self._thread: threading.Thread | None = None
        self._done = threading.Event()

    def __enter__(self) -> MotionKeys:
        if not self.enabled:
            return self
        from armctl.cli._keys import KeyReader

        reader = KeyReader()
        if not reader.active:
            return self
        reader.__enter__()
        self._reader = reader
        self.active = True
        try:
            self._thread = threading.Thread(target=self._run, name="armctl-motion-keys",
                                            daemon=True)
            self._thread.start()
        except BaseException:
            self._close()
            raise
        if self.announce:
            print("keys: space pause/resume, + faster, - slower, Ctrl-C stop", file=sys.stderr,
                  flush=True)
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self._close()

    def _close(self) -> None:
        """End the key thread and restore the terminal (idempotent)."""
        self._done.set()
        thread, self._thread = self._thread, None
        if thread is not None:
            thread.join(1.0)
        reader, self._reader = self._reader, None
        if reader is not None:
            reader.restore()

    def _run(self) -> None:
        reader = self._reader
        assert reader is not None
        while not self._done.is_set():
            key = reader.key(_POLL)
            if key is None:
                if reader.closed:
                    return
                continue
            try:
                self.handle(key)
            except Exception:  # a key must never end the motion: log and read on
                logger.exception("motion key %r failed", key)

    def handle(self, key: str) -> None:
        """Act on one key (unknown keys are ignored)."""
        if key in PAUSE_KEYS:
            self.control.toggle()
        elif key in FASTER_KEYS:
            self.control.scale_speed(SPEED_STEP)
        elif key in SLOWER_KEYS:
            self.control.scale_speed(1.0 / SPEED_STEP)
