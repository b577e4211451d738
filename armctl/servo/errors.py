"""Errors of the servo bus; every one is a :class:`armctl.errors.BusError` (exit code 4).

Each names the port and, where it applies, the servo id, the register and what the servo
answered, and says how to fix it. ``details`` carries the same facts as data (printed with
``--json``).
"""

from __future__ import annotations

import errno

from armctl.errors import BusError

__all__ = [
    "AccessError",
    "CommError",
    "CorruptReplyError",
    "EepromLockedError",
    "LateReplyError",
    "NoReplyError",
    "PortError",
    "PortIOError",
    "PortVanishedError",
    "ServoAlarmError",
    "ServoBusError",
    "ServoMissingError",
    "ServoRejectedError",
    "WrongModelError",
    "port_error",
    "port_io_error",
]


class ServoBusError(BusError):
    """Base of the servo-bus errors.

    Args:
        problem: What went wrong.
        port: The serial port (or ``"sim"``).
        servo_id: The servo concerned, when one is.
        register: The register concerned, when one is.
        answer: What the servo answered (decoded), when it answered.
        fix: How to fix it.

    ``details``: ``port``, ``servo_id``, ``register``, ``answer`` and ``problem``.
    """

    #: What joins the location and the problem ("port /dev/ttyACM0: no such port").
    joiner = ": "

    def __init__(self, problem: str, port: str, servo_id: int | None = None,
                 register: str | None = None, answer: str | None = None, fix: str | None = None):
        self.problem = problem
        self.port = port
        self.servo_id = servo_id
        self.register = register
        self.answer = answer
        self.fix = fix
        where = f"port {port}"
        if servo_id is not None:
            where += f", servo {servo_id}"
        if register is not None:
            where += f", register {register}"
        text = f"{where}{self.joiner}{problem}"
        if answer:
            text += f" (servo answered: {answer})"
        if fix:
            text += f"\n  fix: {fix}"
        super().__init__(text, {"port": port, "servo_id": servo_id, "register": register,
                                "answer": answer, "problem": problem})


class PortError(ServoBusError):
    """The serial port cannot be opened: missing, busy, or no permission."""


class PortIOError(ServoBusError):
    """Reading or writing the open port failed (adapter unplugged, or another program on it).

    Never retried: the transaction's outcome is unknown, and the port may be gone.
    """


class PortVanishedError(PortIOError):
    """The port's device file disappeared while it was open (the adapter was unplugged)."""

    joiner = " "


class CommError(ServoBusError):
    """A transaction failed after its retries."""


class NoReplyError(CommError):
    """A servo did not answer in time (after the retries)."""


class LateReplyError(NoReplyError):
    """A servo's replies arrive after their timeout (so they cannot be matched to requests).

    ``servo_id`` is the servo whose late replies were seen, which may differ from the servo
    whose answer was being waited for (a late reply holds up the replies behind it).
    """


class CorruptReplyError(CommError):
    """A reply arrived but was incomplete or failed its CRC/checksum (after the retries)."""


class ServoMissingError(NoReplyError):
    """A servo the config expects does not answer a ping at all."""


class WrongModelError(ServoBusError):
    """A servo reports a different model number than the config says."""


class ServoRejectedError(ServoBusError):
    """The servo answered with an error number (instruction, range, length, limit...)."""


class AccessError(ServoRejectedError):
    """Write to a read-only or unknown register, or read of an unknown address."""


class EepromLockedError(AccessError):
    """An EEPROM register could not be written (torque on, or the EEPROM is locked)."""


class ServoAlarmError(ServoBusError):
    """The servo reports a hardware alarm (overload, overheating, input voltage, ...)."""


_LIST_PORTS = "list the serial ports with 'armctl ports'"


def port_error(port: str, exc: BaseException) -> PortError:
    """The :class:`PortError` for an exception raised while opening ``port``."""
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code == errno.ENOENT or "No such file" in text:
        return PortError("no such port", port, fix=f"plug the adapter in and {_LIST_PORTS}")
    if code == errno.EACCES or "Permission denied" in text:
        return PortError("permission denied", port,
                         fix="add yourself to the serial group: 'sudo usermod -aG dialout "
                             "$USER', then log out and back in")
    if code in (errno.EBUSY, errno.EAGAIN) or "busy" in text.lower() or \
            "exclusively lock" in text:
        from armctl.servo.port_holders import port_holders

        holders = port_holders(port)
        held = f"; open in {'; '.join(str(h) for h in holders)}" if holders else ""
        return PortError(f"port busy: in use by another program{held}", port,
                         fix="close the other program (another armctl, a serial terminal, "
                             f"a robot framework); 'fuser {port}' shows which; 'armctl status "
                             "CONFIG --port PORT' watches an armctl command that owns it")
    if code == errno.EISDIR or "Is a directory" in text:
        return PortError("not a serial port: it is a directory", port,
                         fix=f"give the adapter's device, e.g. /dev/ttyACM0; {_LIST_PORTS}")
    if code == errno.ENOTTY or "Inappropriate ioctl" in text:
        return PortError("not a serial port: the path is not a terminal device "
                         "(Inappropriate ioctl for device)", port,
                         fix=f"give the adapter's device, e.g. /dev/ttyACM0; {_LIST_PORTS}")
    return PortError(f"cannot open the port: {text}", port)


def port_io_error(port: str, exc: BaseException) -> PortIOError:
    """The :class:`PortIOError` for an exception raised by I/O on the open ``port``.

    A port whose device file no longer exists vanished (:class:`PortVanishedError`).
    """
    import os

    if not os.path.exists(port):
        return PortVanishedError("vanished (unplugged?)", port,
                                 fix=f"plug the adapter back in, {_LIST_PORTS}, and start again; "
                                     "the servos keep their last goal")
    return PortIOError(f"reading or writing the port failed: {exc}", port,
                       fix="check the adapter's cable and that no other program uses the port; "
                           "the servos keep their last goal")
