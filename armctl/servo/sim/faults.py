"""Faults the simulated bus can inject, as frozen dataclasses.

Faults that act on replies (:class:`DroppedReply`, :class:`CorruptedReply`,
:class:`TruncatedReply`, :class:`LateReply`, :class:`LatencySpike`) are used up one reply at a
time (``count`` replies; ``count=None`` means until cleared), and act on one reply in ``every``
(1: each; 2: every other one, an intermittent fault that a retry hides). The others are states:
:class:`MissingServo` (silent, ignores every instruction), :class:`HardwareAlarm` (latched error
bits), :class:`WrongModel` (reports another model number), :class:`LockupAfterOverload`
(overload alarm, then silence until the servo is rebooted or power-cycled) and :class:`Obstacle`
(the shaft is blocked at a position: the servo answers normally but cannot get past it).
"""

from __future__ import annotations

from dataclasses import dataclass

from armctl.servo_tables import Alarm

__all__ = [
    "Alarm",
    "CorruptedReply",
    "DroppedReply",
    "Fault",
    "HardwareAlarm",
    "LateReply",
    "LatencySpike",
    "LockupAfterOverload",
    "MissingServo",
    "Obstacle",
    "TruncatedReply",
    "WrongModel",
]


@dataclass(frozen=True)
class DroppedReply:
    """The servo processes the instruction but its reply is lost."""

    servo_id: int
    count: int | None = 1
    every: int = 1


@dataclass(frozen=True)
class CorruptedReply:
    """The reply's CRC/checksum byte is flipped."""

    servo_id: int
    count: int | None = 1
    every: int = 1


@dataclass(frozen=True)
class TruncatedReply:
    """Only the first ``keep`` bytes of the reply are sent."""

    servo_id: int
    count: int | None = 1
    keep: int = 5
    every: int = 1


@dataclass(frozen=True)
class LateReply:
    """The reply is sent ``delay`` [s] late (past the host's timeout for 60 ms).

    Like bytes held in a slow USB adapter: the replies after it on the line wait behind it.
    """

    servo_id: int
    count: int | None = 1
    delay: float = 0.06
    every: int = 1


@dataclass(frozen=True)
class LatencySpike:
    """Every reply on the bus is delayed by ``delay`` [s] (a USB or OS hiccup)."""

    count: int | None = 1
    delay: float = 0.01
    every: int = 1


@dataclass(frozen=True)
class MissingServo:
    """The servo is not on the bus (loose cable): it ignores everything."""

    servo_id: int


@dataclass(frozen=True)
class HardwareAlarm:
    """A latched hardware alarm; overload and overheating also switch torque off."""

    servo_id: int
    alarm: Alarm = Alarm.OVERLOAD


@dataclass(frozen=True)
class WrongModel:
    """The servo reports ``model_number`` instead of its own."""

    servo_id: int
    model_number: int = 1190


@dataclass(frozen=True)
class LockupAfterOverload:
    """Overload alarm, then no reply to anything until a reboot instruction or power cycle."""

    servo_id: int


@dataclass(frozen=True)
class Obstacle:
    """Something blocks the shaft at present position ``ticks`` (``None``: where it is now).

    The servo answers and takes goals as usual, but the shaft cannot move past that position
    from the side it is on; pushing against it, the servo reports a high load (no alarm).
    """

    servo_id: int
    ticks: int | None = None


Fault = (DroppedReply | CorruptedReply | TruncatedReply | LateReply | LatencySpike | MissingServo
         | HardwareAlarm | WrongModel | LockupAfterOverload | Obstacle)

FAULT_KINDS: dict[str, type] = {
    "dropped_reply": DroppedReply,
    "corrupted_reply": CorruptedReply,
    "truncated_reply": TruncatedReply,
    "late_reply": LateReply,
    "latency_spike": LatencySpike,
    "missing_servo": MissingServo,
    "hardware_alarm": HardwareAlarm,
    "wrong_model": WrongModel,
    "lockup_after_overload": LockupAfterOverload,
    "obstacle": Obstacle,
}
