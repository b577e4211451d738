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
        frac = min(info.t / info.duration, 1.0) if info.duration > 0 else 1.0
        bar = "#" * int(frac * 30)
        state = ("stopping" if info.stopping else "paused" if info.paused and info.rate == 0
                 else "pausing" if info.paused else "moving")
        speed = f"  speed {info.speed:.0%}" if abs(info.speed - 1.0) > 1e-9 else ""
        sys.stderr.write(f"\r{state:<8} [{bar:<30}] {frac:4.0%}  t {info.t:5.2f}/"
                         f"{info.duration:.2f} s  error {math.degrees(info.tracking_error):5.2f}"
                         f" deg{speed} \x1b[K")
        sys.stderr.flush()

    def done(self) -> None:
        """End the bar's line (once, and only if a bar was drawn)."""
        if self.enabled and self._last:
            sys.stderr.write("\n")
            self._last = 0.0
