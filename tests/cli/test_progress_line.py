"""The progress line of the motion commands: plan time, settling and wall time kept apart."""

from __future__ import annotations

import numpy as np

from armctl.cli._progress import progress_text
from armctl.robot import CycleInfo


def info(t: float, duration: float, elapsed: float, **kw: object) -> CycleInfo:
    z = np.zeros(2)
    return CycleInfo(t=t, duration=duration, command=z, measured=z, tracking_error=0.0,
                     stopping=False, elapsed=elapsed, **kw)  # type: ignore[arg-type]


def test_the_plan_time_never_passes_the_plan_duration() -> None:
    line = progress_text(info(2.90, 2.84, 3.4))  # cycles after the plan's end: settling
    assert line.startswith("settling") and "t  2.84/2.84 s" in line and "100%" in line
    assert "since the start" not in line


def test_wall_time_is_shown_apart_when_a_pause_or_speed_change_made_it_differ() -> None:
    line = progress_text(info(1.0, 2.84, 1.8, speed=0.5))
    assert line.startswith("moving") and "t  1.00/2.84 s (1.80 s since the start)" in line
    assert "speed 50%" in line and "#" * 10 in line and "#" * 11 not in line
    assert "since the start" not in progress_text(info(1.0, 2.84, 1.02))  # as planned


def test_paused_pausing_and_stopping() -> None:
    assert progress_text(info(1.0, 2.0, 3.0, paused=True, rate=0.0)).startswith("paused")
    assert progress_text(info(1.0, 2.0, 3.0, paused=True, rate=0.4)).startswith("pausing")
    z = np.zeros(1)
    stopping = CycleInfo(1.0, 2.0, z, z, 0.0, True)
    assert progress_text(stopping).startswith("stopping")
