"""Errors of the robot layer: a motion stopped for safety, with the servo or joint named."""

from __future__ import annotations

from enum import Enum

from armctl.errors import MotionAborted

__all__ = ["MotionStopped", "StopReason"]


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
