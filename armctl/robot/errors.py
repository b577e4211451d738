"""Errors of the robot layer: a motion stopped for safety, with the servo or joint named."""

from __future__ import annotations

from enum import Enum

from armctl.errors import InputError, JointLimitError, MotionAborted

__all__ = ["JointValueError", "MotionStopped", "StopReason"]


class StopReason(Enum):
    """Why a motion was stopped."""

    USER = "user"  # Ctrl-C or an explicit stop request
    SERVO_ERROR = "servo_error"  # a servo reported a hardware alarm
    LOST_SERVO = "lost_servo"  # a servo stopped answering
    TRACKING = "tracking_error"  # measured position too far from the command


class MotionStopped(MotionAborted):
    """A motion was stopped: the arm decelerated within its limits and holds its position.

    Args:
        reason: Why.
        message: What happened, naming the joint and servo.
        joint: The joint concerned, if one.
        servo_id: The servo concerned, if one.
        held: Joint values [rad]/[m] commanded at the end of the stop.
        time: When along the plan the stop began [s].
    """

    def __init__(self, reason: StopReason, message: str, joint: str | None = None,
                 servo_id: int | None = None, held: object = None, time: float = 0.0):
        self.reason = reason
        self.joint = joint
        self.servo_id = servo_id
        self.held = held
        self.time = time
        self.details = {"reason": reason.value, "joint": joint, "servo_id": servo_id,
                        "time": time}
        super().__init__(message)


class JointValueError(JointLimitError):
    """A requested joint value is outside its limits, reported in the unit the user wrote.

    The attributes are in SI units ([rad] or [m]) like those of :class:`JointLimitError`; only
    the message uses the user's unit.

    Args:
        joint: The joint's name.
        value: The requested value [rad]/[m].
        lower: Lower limit [rad]/[m].
        upper: Upper limit [rad]/[m].
        message: The whole message, in the user's unit, with a hint how to fix it.
    """

    def __init__(self, joint: str, value: float, lower: float, upper: float, message: str):
        self.joint = joint
        self.value = value
        self.lower = lower
        self.upper = upper
        self.details = {"joint": joint, "value": value, "lower": lower, "upper": upper}
        InputError.__init__(self, message)
