"""The baud rate a client set on a pty, so that simulated servos can ignore a wrong one.

The pty's termios are shared by both ends: the speed pyserial set on the port is visible on the
simulator's own slave descriptor. Standard rates come back as ``B...`` constants from
``tcgetattr``; custom ones (``BOTHER``) are read with the Linux ``TCGETS2`` ioctl
(``struct termios2``: ``c_ispeed``/``c_ospeed`` are its int fields 9 and 10).
"""

from __future__ import annotations

import array
import sys
import termios

__all__ = ["client_baudrate"]

_SPEEDS = {getattr(termios, name): int(name[1:]) for name in dir(termios)
           if name.startswith("B") and name[1:].isdigit()}
_BOTHER = 0o010000
_TCGETS2 = 0x802C542A


def client_baudrate(fd: int) -> int | None:
    """The output baud rate set on ``fd`` [bit/s], or ``None`` when it cannot be told."""
    try:
        speed = termios.tcgetattr(fd)[5]
    except (termios.error, OSError):
        return None
    if speed in _SPEEDS and speed != 0:
        return _SPEEDS[speed]
    if sys.platform.startswith("linux") and speed == _BOTHER:
        import fcntl

        buf = array.array("i", [0] * 11)
        try:
            fcntl.ioctl(fd, _TCGETS2, buf)
        except OSError:
            return None
        return int(buf[10]) or None
    return None
