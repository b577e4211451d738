"""What a servo's answer means: ping and feedback records, and the status packet's error byte.

The error byte differs per protocol (e-Manual Protocol 2.0 and 1.0 "Status Packet"; SDK-FT
``ERRBIT_*``):

* Dynamixel 2.0: bits 0-6 are an error *number* (1 result fail ... 7 access error); bit 7 is the
  Alert bit, a latched hardware alarm whose cause is in Hardware Error Status (address 70).
* Dynamixel 1.0: a bit field; input voltage, overheating and overload are alarms, angle limit,
  range, checksum and instruction are refusals.
* Feetech: a bit field of live alarms; the data is still returned.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from armctl.config.bus import Protocol
from armctl.servo_tables import Alarm, alarms_from_bits

__all__ = ["Feedback", "PingResult", "StatusStyle", "alarms_in", "refusal"]

_DXL2_ERRORS = {1: "result fail", 2: "instruction error", 3: "CRC error",
                4: "data range error (value outside the register's range)",
                5: "data length error", 6: "data limit error (outside the position limits)",
                7: "access error"}
_DXL1_ERRORS = {0x02: "angle limit error", 0x08: "range error", 0x10: "checksum error",
                0x40: "instruction error"}
_DXL1_ALARMS = 0x25  # input voltage, overheating, overload (the Feetech bit positions)


class StatusStyle(Enum):
    """How a protocol encodes the error byte."""

    DYNAMIXEL2 = "dynamixel2"
    DYNAMIXEL1 = "dynamixel1"
    FEETECH = "feetech"

    @classmethod
    def of(cls, protocol: Protocol) -> StatusStyle:
        """The style of a wire protocol."""
        return {Protocol.DYNAMIXEL: cls.DYNAMIXEL2, Protocol.DYNAMIXEL1: cls.DYNAMIXEL1,
                Protocol.FEETECH: cls.FEETECH}[protocol]


def refusal(style: StatusStyle, error: int) -> tuple[str, bool] | None:
    """What the servo refused, if anything.

    Returns:
        ``None``, or ``(text, access)`` where ``access`` marks an access-type refusal (Dynamixel
        2.0 error 7; a Protocol 1.0 range error, which for a value armctl range-checked before
        sending means the register could not be written).
    """
    if style is StatusStyle.DYNAMIXEL2:
        num = error & 0x7F
        return (_DXL2_ERRORS.get(num, f"error {num}"), num == 7) if num else None
    if style is StatusStyle.DYNAMIXEL1:
        bits = error & ~_DXL1_ALARMS & 0x7F
        if not bits:
            return None
        text = ", ".join(t for b, t in _DXL1_ERRORS.items() if bits & b) or f"bits 0x{bits:02x}"
        return text, bool(bits & 0x08)
    return None


def alarms_in(style: StatusStyle, error: int) -> tuple[Alarm, ...] | None:
    """The hardware alarms an error byte reports.

    Returns:
        The alarms (empty when none), or ``None`` for a Dynamixel 2.0 Alert bit, whose cause
        must be read from Hardware Error Status.
    """
    if style is StatusStyle.DYNAMIXEL2:
        return None if error & 0x80 else ()
    if style is StatusStyle.DYNAMIXEL1:
        return alarms_from_bits(error & _DXL1_ALARMS, True)
    return alarms_from_bits(error, True)


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
