"""Keyframe keys of ``armctl teleop --record``: every Enter on the terminal asks for a keyframe."""

from __future__ import annotations

import sys
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from armctl.robot.teleop import TeleopRecorder

__all__ = ["read_keyframe_keys"]


def read_keyframe_keys(recorder: TeleopRecorder, say: Callable[[str], None]) -> threading.Thread:
    """Read terminal lines in a background thread; each asks for a keyframe at the next cycle.

    The text typed before Enter names the keyframe. The thread ends at the end of input; it
    is a daemon, so it never keeps the command alive.

    Args:
        recorder: The recorder to ask (:meth:`TeleopRecorder.mark` is thread-safe).
        say: Shows a line to the user.

    Returns:
        The started thread.
    """

    def read() -> None:
        for line in sys.stdin:
            name = line.strip()
            recorder.mark(name)
            say(f"keyframe {name or '(unnamed)'}")

    thread = threading.Thread(target=read, name="teleop-keys", daemon=True)
    thread.start()
    return thread
