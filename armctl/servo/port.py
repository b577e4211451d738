"""The serial port under both vendor SDKs: exclusive, flushed before transmit, read ahead.

``dynamixel_sdk`` and ``scservo_sdk`` share a ``PortHandler`` design; :func:`port_class`
subclasses either to fix what users suffer from (``docs/bus.md``):

* The port is opened exclusively (``flock``, and ``TIOCEXCL`` on a real serial device), so that
  no second program talks on the same bus.
* Input is flushed before every transmit (``clearPort``; SDK-FT 1.0.0 and SDK-DXL 3.8.4 only
  ``flush()`` output, so a late reply would be read as the next answer).
* The reply timeout uses a configurable adapter latency instead of the fixed 16 ms.
* A write is one system call (pyserial's write would wait in ``select`` after it).
* A read takes every byte that has arrived in one system call and
  keeps what the SDK did not ask for yet (the SDKs ask for a packet a few bytes at a time);
  waiting for bytes sleeps in ``select`` until they arrive or the request's timeout ends,
  instead of spinning a core.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import time
from typing import Any

import serial

__all__ = ["IO_ERRORS", "port_class"]

_AGAIN = (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR)
#: Longest single wait for input [s]; the SDK checks its timeout between waits.
_MAX_WAIT = 0.05
#: Longest wait for room in the output buffer [s].
_WRITE_WAIT = 1.0


def _io_errors() -> tuple[type[BaseException], ...]:
    try:
        import termios
    except ImportError:  # not POSIX
        return (OSError,)
    return (OSError, termios.error)


#: What pyserial raises for a failed read, write, flush or ioctl on an open port
#: (``SerialException`` is an ``OSError``; ``tcflush`` raises ``termios.error``).
IO_ERRORS = _io_errors()


def _is_pseudo_terminal(fd: int) -> bool:
    """Whether ``fd`` is the slave side of a pseudo-terminal (Linux: majors 136-143)."""
    try:
        return 136 <= os.major(os.fstat(fd).st_rdev) <= 143
    except (OSError, AttributeError):
        return False


def _exclusive(fd: int, on: bool) -> None:
    """Set or clear the terminal's exclusive mode (further opens fail with EBUSY).

    Not on pseudo-terminals: the simulator keeps its pty's slave side open, so the mode would
    outlive a client that was killed.
    """
    try:
        import termios
    except ImportError:
        return
    request = getattr(termios, "TIOCEXCL" if on else "TIOCNXCL", None)
    if request is None or _is_pseudo_terminal(fd):
        return
    with contextlib.suppress(OSError):
        import fcntl

        fcntl.ioctl(fd, request)


def port_class(base: type) -> type:
    """A subclass of an SDK's ``PortHandler`` class ``base`` with armctl's port handling.

    Args:
        base: ``dynamixel_sdk.PortHandler`` or ``scservo_sdk.PortHandler``.

    Returns:
        The subclass; its ``latency_ms`` [ms] is the adapter latency used in reply timeouts,
        ``unread()`` the number of bytes read ahead and not yet taken.
    """

    class Port(base):
        latency_ms = 16.0
        is_open: bool

        def __init__(self, port_name: str):
            super().__init__(port_name)
            self._ahead = bytearray()  # bytes read from the port that the SDK has not taken
            self._fd = -1

        def setupPort(self, cflag_baud: int) -> bool:
            """Open the port as the SDK does, but exclusively (pyserial ``flock``)."""
            if self.is_open:
                self.closePort()
            self.ser = serial.Serial(port=self.port_name, baudrate=self.baudrate,
                                     bytesize=serial.EIGHTBITS, timeout=0, write_timeout=0,
                                     exclusive=True)
            self.is_open = True
            self._fd = self.ser.fileno()
            _exclusive(self._fd, True)
            self.ser.reset_input_buffer()
            self._ahead = bytearray()
            self.tx_time_per_byte = (1000.0 / self.baudrate) * 10.0
            return True

        def closePort(self) -> None:
            with contextlib.suppress(*IO_ERRORS, ValueError):
                _exclusive(self.ser.fileno(), False)
            with contextlib.suppress(*IO_ERRORS):
                self.ser.close()
            self.is_open = False
            self._ahead = bytearray()
            self._fd = -1

        def clearPort(self) -> None:
            """Discard all input: what the port holds and what was read ahead."""
            self.ser.reset_input_buffer()
            self._ahead.clear()

        def unread(self) -> int:
            """Bytes read from the port and not yet taken by the SDK."""
            return len(self._ahead)

        def setPacketTimeout(self, packet_length: int) -> None:
            self.packet_start_time = self.getCurrentTime()
            self.packet_timeout = (self.tx_time_per_byte * packet_length
                                   + 2.0 * self.latency_ms + 2.0)

        def writePort(self, packet: Any) -> int:
            """Write a packet: one system call while the output buffer has room.

            Returns:
                The bytes written (fewer than the packet's only if the port accepted nothing
                for :data:`_WRITE_WAIT`).
            """
            data = packet if isinstance(packet, (bytes, bytearray)) else bytes(packet)
            done = int(self.ser.write(data))  # non-blocking (write_timeout 0)
            if done < len(data):  # the output buffer is full: wait for room (rare)
                deadline = time.monotonic() + _WRITE_WAIT
                while done < len(data) and time.monotonic() < deadline:
                    select.select([], [self._fd], [], _MAX_WAIT)
                    done += int(self.ser.write(data[done:]))
            return done

        def _fill(self, ready: bool) -> None:
            """Append every byte that has arrived (never blocks).

            Args:
                ready: ``select`` reported the port readable (so it must have data).

            Raises:
                serial.SerialException: The read failed, or the device hung up (it reports
                    readiness but has no data, as a disconnected device does on Linux).
            """
            try:
                data = os.read(self._fd, 4096)
            except OSError as exc:
                if exc.errno in _AGAIN:
                    return
                raise serial.SerialException(f"read failed: {exc}") from exc
            if not data:
                if not ready:
                    return  # nothing has arrived (the port reads with VMIN = 0)
                raise serial.SerialException(
                    "device reports readiness to read but returned no data (device "
                    "disconnected or multiple access on port?)")
            self._ahead += data

        def readPort(self, length: int) -> Any:
            """Up to ``length`` bytes: those read ahead, then what has arrived.

            With nothing to give, waits in ``select`` until bytes arrive or the request's
            timeout (``setPacketTimeout``) ends.
            """
            ahead = self._ahead
            if len(ahead) < length:
                self._fill(False)
                if not ahead:
                    left = (self.packet_timeout
                            - (self.getCurrentTime() - self.packet_start_time)) / 1000.0
                    try:
                        ready, _, _ = select.select([self._fd], [], [],
                                                    min(max(left, 0.0), _MAX_WAIT))
                    except (OSError, ValueError):
                        ready = []
                    if ready:
                        self._fill(True)
            data = bytes(ahead[:length])
            del ahead[:length]
            return data

    return Port
