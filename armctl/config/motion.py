"""The ``motion:`` section of an arm config: defaults for moves, streaming and stopping."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from armctl.config.source import Section

__all__ = ["ExitPolicy", "MotionSpec", "parse_motion"]


class ExitPolicy(Enum):
    """What the arm does when a session (a ``Robot`` block, a command) ends normally.

    A stopped motion or an error never applies it: the arm holds where it is.
    """

    HOLD = "hold"  # keep torque on and hold the present position
    PARK = "park"  # move to the ``park`` pose, then hold
    RELEASE = "release"  # switch torque off (a raised arm will fall)


@dataclass(frozen=True)
class MotionSpec:
    """Motion defaults.

    Attributes:
        rate_hz: Streaming loop rate in [Hz].
        speed: Default speed factor applied to the joint velocity and acceleration limits.
        max_tracking_error: Largest allowed |commanded - measured| joint error in [rad] before
            the motion is stopped.
        exit_policy: What to do at the normal end of a session (never after a stop).
    """

    rate_hz: float = 50.0
    speed: float = 1.0
    max_tracking_error: float = 0.2
    exit_policy: ExitPolicy = ExitPolicy.HOLD


def parse_motion(sec: Section) -> MotionSpec:
    """Validate a ``motion:`` section."""
    sec.check_keys([], ["rate_hz", "speed", "max_tracking_error", "exit_policy"])
    spec = MotionSpec(
        rate_hz=sec.number("rate_hz", 50.0, positive=True),
        speed=sec.number("speed", 1.0, positive=True),
        max_tracking_error=sec.number("max_tracking_error", 0.2, angle=True, positive=True),
        exit_policy=sec.choice("exit_policy", ExitPolicy, [p.value for p in ExitPolicy],
                               ExitPolicy.HOLD),
    )
    if not 1.0 <= spec.rate_hz <= 1000.0:
        raise sec.error(f"rate_hz {spec.rate_hz} is outside 1 to 1000 Hz", "rate_hz")
    if spec.speed > 4.0:
        raise sec.error(f"speed {spec.speed} is above the maximum factor 4", "speed")
    return spec
