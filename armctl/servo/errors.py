"""Errors of the servo bus; every one is a :class:`armctl.errors.BusError` (exit code 4).

Each names the port and, where it applies, the servo id, the register and what the servo
answered, and says how to fix it. ``details`` carries the same facts as data (printed with
``--json``).
"""

from __future__ import annotations

import errno
from typing import Any

from armctl.errors import BusError

__all__ = [
    "AccessError",
    "CommError",
    "CorruptReplyError",
    "EepromLockedError",
    "NoReplyError",
    "PortError",
    "ServoAlarmError",
    "ServoBusError",
    "ServoMissingError",
    "ServoRejectedError",
    "WrongModelError",
    "port_error",
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
    """

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
        text = f"{where}: {problem}"
        if answer:
            text += f" (servo answered: {answer})"
        if fix:
            text += f"\n  fix: {fix}"
        super().__init__(text)

    @property
    def details(self) -> dict[str, Any]:
        """The facts of the error as data."""
        return {"port": self.port, "servo_id": self.servo_id, "register": self.register,
                "answer": self.answer, "problem": self.problem}


class PortError(ServoBusError):
    """The serial port cannot be opened: missing, busy, or no permission."""


class CommError(ServoBusError):
    """A transaction failed after its retries."""


class NoReplyError(CommError):
    """A servo did not answer in time (after the retries)."""


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


def port_error(port: str, exc: BaseException) -> PortError:
    """The :class:`PortError` for an exception raised while opening ``port``."""
    code = getattr(exc, "errno", None)
    text = str(exc)
    if code == errno.ENOENT or "No such file" in text:
        return PortError("no such port", port,
                         fix="plug the adapter in and list ports with 'armctl ports'")
    if code == errno.EACCES or "Permission denied" in text:
        return PortError("permission denied", port,
                         fix="add yourself to the serial group: 'sudo usermod -aG dialout "
                             "$USER', then log out and back in")
    if code == errno.EBUSY or "busy" in text.lower():
        return PortError("the port is busy", port, fix="close the program that uses it")
    return PortError(f"cannot open the port: {text}", port)
