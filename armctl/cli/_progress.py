"""The progress bar of the motion commands: a live line on a terminal."""

from __future__ import annotations

import math
import sys
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from armctl.robot import CycleInfo


class Progress:
    """A one-line progress bar with the live tracking error, on a terminal only.

    It shows whether the motion moves, is pausing, is paused or stops, and the speed override
    when it is not 100 %.
    """

    def __init__(self, enabled: bool, unit: str = "rad"):
        self.enabled = enabled and sys.stderr.isatty()
        self.unit = unit
        self._last = 0.0

    def __call__(self, info: CycleInfo) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self._last < 0.1 and info.t < info.duration:
            return
        self._last = now
        sys.stderr.write(f"\r{progress_text(info)} \x1b[K")
        sys.stderr.flush()

    def done(self) -> None:
        """End the bar's line (once, and only if a bar was drawn)."""
        if self.enabled and self._last:
            sys.stderr.write("\n")
            self._last = 0.0


def progress_text(info: CycleInfo) -> str:
    """The progress line of one cycle (a bar of 30 characters, the plan's share done).

    The time shown is the plan's (where along the plan the command is, at most its duration;
    after the plan's end the arm settles at the goal); the time since the start is added when
    a pause or a speed override made it differ from the plan's time by more than 0.05 s.
    """
    frac = min(info.t / info.duration, 1.0) if info.duration > 0 else 1.0
    bar = "#" * int(frac * 30)
    t = min(info.t, info.duration)
    state = ("stopping" if info.stopping else "paused" if info.paused and info.rate == 0
             else "pausing" if info.paused
             else "settling" if info.t >= info.duration > 0 else "moving")
    speed = f"  speed {info.speed:.0%}" if abs(info.speed - 1.0) > 1e-9 else ""
    wall = (f" ({info.elapsed:.2f} s since the start)"
            if abs(info.elapsed - info.t) > 0.05 and info.t < info.duration else "")
    return (f"{state:<8} [{bar:<30}] {frac:4.0%}  t {t:5.2f}/{info.duration:.2f} s{wall}  error "
            f"{math.degrees(info.tracking_error):5.2f} deg{speed}")
