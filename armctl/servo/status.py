"""What a servo's answer means to the layers above the bus: ping and feedback records.

What a status packet's error byte means differs per protocol; each vendor's adapter (the
``sdk`` module of its package) interprets it.
"""

from __future__ import annotations

from dataclasses import dataclass

from armctl.servo_tables import Alarm

__all__ = ["Feedback", "PingResult"]


@dataclass(frozen=True)
class PingResult:
    """A servo that answered a ping.

    Attributes:
        servo_id: Its id.
        model_number: The model number it reported.
        model: The model name armctl knows for that number, or ``None``.
        firmware: Firmware version, when the protocol reports it.
    """

    servo_id: int
    model_number: int
    model: str | None
    firmware: int | None = None


@dataclass(frozen=True)
class Feedback:
    """One servo's state from one sync read (raw servo units).

    Attributes:
        servo_id: The servo.
        position: Present position [tick].
        velocity: Present velocity [tick/s].
        load: Present load or current, signed, in the model's unit (0.1 % or mA).
        voltage: Input voltage [V].
        temperature: Temperature [degC].
        error: The status packet's error byte.
        alarms: Hardware alarms the servo reports.
    """

    servo_id: int
    position: int
    velocity: float
    load: int
    voltage: float
    temperature: int
    error: int
    alarms: tuple[Alarm, ...] = ()
