"""Errors of the robot layer: a motion stopped for safety, with the servo or joint named."""

from __future__ import annotations

from enum import Enum

from armctl.errors import ArmctlError, InputError, JointLimitError, MotionAborted, json_safe

__all__ = ["JointValueError", "LiveStateError", "MotionStopped", "OwnerGone", "SignalInterrupt",
           "StopReason"]


class StopReason(Enum):
    """Why a motion was stopped."""

    USER = "user"  # a stop signal (Ctrl-C, SIGTERM, SIGHUP) or an explicit stop request
    SERVO_ERROR = "servo_error"  # a servo reported a hardware alarm
    LOST_SERVO = "lost_servo"  # a servo stopped answering
    TRACKING = "tracking_error"  # measured position too far from the command
    BUS_IO = "bus_io_error"  # the port failed (adapter unplugged, another program on it)
    NOT_REACHED = "not_reached"  # a joint stopped short of the goal at the end of a motion


class MotionStopped(MotionAborted):
    """A motion was stopped: the arm decelerated within its limits and holds its position.

    Args:
        reason: Why.
        message: What happened, naming the joint and servo.
        joint: The joint concerned, if one.
        servo_id: The servo concerned, if one.
        held: Joint values [rad]/[m] commanded at the end of the stop.
        time: When along the plan the stop began [s].
        signum: The signal that asked for the stop (``reason`` USER), if one.

    Attributes:
        stopped_at: Where the arm stopped, once known (:meth:`locate`): ``joints`` (name ->
            value [rad]/[m], read back after the stop), ``xyz`` [m] and ``rpy`` [rad] of the
            tool by FK of those joints (lists); ``None`` before.

    ``details``: ``reason`` (the value of :class:`StopReason`), ``joint``, ``servo_id``,
    ``time``, ``signal`` (e.g. ``"SIGINT"``, or ``None``) and, once known, ``stopped_at``.
    """

    def __init__(self, reason: StopReason, message: str, joint: str | None = None,
                 servo_id: int | None = None, held: object = None, time: float = 0.0,
                 signum: int | None = None):
        self.reason = reason
        self.joint = joint
        self.servo_id = servo_id
        self.held = held
        self.time = time
        self.signum = signum
        self.stopped_at: dict[str, object] | None = None
        super().__init__(message, {"reason": reason.value, "joint": joint, "servo_id": servo_id,
                                   "time": time, "signal": _signal_name(signum)})

    def locate(self, joints: dict[str, float], xyz: object, rpy: object) -> None:
        """Record where the arm stopped (also under ``details["stopped_at"]``).

        Args:
            joints: Joint values read back after the stop, by name [rad]/[m].
            xyz: Tool position by FK of those joints ``(3,)`` [m].
            rpy: Tool roll, pitch, yaw ``(3,)`` [rad].
        """
        self.stopped_at = json_safe({"joints": dict(joints), "xyz": xyz, "rpy": rpy})
        self.details["stopped_at"] = self.stopped_at


class SignalInterrupt(KeyboardInterrupt):
    """A stop signal (SIGINT, SIGTERM, SIGHUP) arrived while no motion was under way.

    A :class:`KeyboardInterrupt`, so that SIGTERM and SIGHUP end a command the way Ctrl-C does;
    the command line exits with 128 + the signal number (130, 143, 129).

    Args:
        signum: The signal's number.
        name: The signal's name, e.g. ``"SIGTERM"``.
    """

    def __init__(self, signum: int, name: str):
        self.signum = signum
        self.name = name
        super().__init__(f"interrupted by {name}")


def _signal_name(signum: int | None) -> str | None:
    if signum is None:
        return None
    import signal

    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


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

    ``details`` as for :class:`JointLimitError`, in SI units.
    """

    def __init__(self, joint: str, value: float, lower: float, upper: float, message: str):
        self.joint = joint
        self.value = value
        self.lower = lower
        self.upper = upper
        InputError.__init__(self, message,
                            {"joint": joint, "value": value, "lower": lower, "upper": upper})


class LiveStateError(ArmctlError):
    """The live state of a port's owner cannot be published or read (the message says why)."""


class OwnerGone(LiveStateError):
    """The port's owner closed the port or exited: the watch is over.

    ``details``: ``pid`` of the owner.
    """
