"""Single keypresses from the terminal, without Enter: the keys of ``jog`` and of running motions.

:class:`KeyReader` switches a terminal to cbreak mode (no line buffering, no echo) while it is
in use and restores the previous mode on every way out of its ``with`` block (an exception, a
``KeyboardInterrupt``, or the interpreter's exit). Ctrl-C stays a signal (``ISIG`` is kept), so
the command's stop handling sees it as always.

Keys come back as strings: a printable character is itself (``" "`` for space); the others have
names: ``"UP"``, ``"DOWN"``, ``"LEFT"``, ``"RIGHT"``, ``"HOME"``, ``"END"``, ``"PAGE-UP"``,
``"PAGE-DOWN"``, ``"INSERT"``, ``"DELETE"``, ``"ENTER"``, ``"ESC"``, ``"BACKSPACE"``, ``"TAB"``,
``"CTRL-D"`` and so on for control characters, ``"F1"``..``"F12"``, and ``"UNKNOWN"`` for an
escape sequence this reader does not name.
"""

from __future__ import annotations

import atexit
import codecs
import os
import select
import sys
from types import TracebackType
from typing import Any, TextIO

__all__ = ["KeyReader"]

#: How long a lone ESC byte waits for the rest of an escape sequence [s].
ESC_WAIT = 0.05

_CSI_FINAL = {"A": "UP", "B": "DOWN", "C": "RIGHT", "D": "LEFT", "H": "HOME", "F": "END",
              "P": "F1", "Q": "F2", "R": "F3", "S": "F4"}
_CSI_TILDE = {"1": "HOME", "2": "INSERT", "3": "DELETE", "4": "END", "5": "PAGE-UP",
              "6": "PAGE-DOWN", "7": "HOME", "8": "END", "11": "F1", "12": "F2", "13": "F3",
              "14": "F4", "15": "F5", "17": "F6", "18": "F7", "19": "F8", "20": "F9",
              "21": "F10", "23": "F11", "24": "F12"}
_CONTROL = {"\r": "ENTER", "\n": "ENTER", "\t": "TAB", "\x7f": "BACKSPACE", "\x08": "BACKSPACE"}


class KeyReader:
    """Reads one key at a time from a terminal (or any file descriptor), in cbreak mode.

    Use it as a context manager, from one thread::

        with KeyReader() as keys:
            while (key := keys.key(timeout=0.1)) != "q":
                ...

    Args:
        stream: Where keys come from (default ``sys.stdin``). A stream without a file
            descriptor gives no keys (:attr:`closed` at once).

    Attributes:
        closed: True once the input has ended (end of file, or no readable input at all).
    """

    def __init__(self, stream: TextIO | None = None) -> None:
        self._stream = stream if stream is not None else sys.stdin
        try:
            self._fd: int | None = self._stream.fileno()
        except (AttributeError, OSError, ValueError):
            self._fd = None
        self._saved: list[Any] | None = None
        self._buffer = ""
        self._decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
        self.closed = self._fd is None

    @property
    def active(self) -> bool:
        """Whether the input is a terminal (keys arrive as they are pressed)."""
        return self._fd is not None and os.isatty(self._fd)

    def __enter__(self) -> KeyReader:
        if self.active and sys.platform != "win32":
            import termios

            assert self._fd is not None
            self._saved = termios.tcgetattr(self._fd)
            mode = termios.tcgetattr(self._fd)
            mode[3] &= ~(termios.ICANON | termios.ECHO)  # lflag: keep ISIG (Ctrl-C)
            mode[6][termios.VMIN] = 1
            mode[6][termios.VTIME] = 0
            termios.tcsetattr(self._fd, termios.TCSANOW, mode)
            atexit.register(self.restore)
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.restore()

    def restore(self) -> None:
        """Put the terminal back in the mode it had before (idempotent)."""
        if self._saved is None or self._fd is None:
            return
        import termios

        saved, self._saved = self._saved, None
        try:
            termios.tcsetattr(self._fd, termios.TCSADRAIN, saved)
        except (termios.error, OSError):
            pass  # the terminal is gone (closed window): nothing to restore
        atexit.unregister(self.restore)

    # ---- reading -----------------------------------------------------------------------------
    def _fill(self, timeout: float | None) -> bool:
        """Read what has arrived into the buffer, waiting at most ``timeout`` [s].

        Returns:
            Whether anything arrived (``False`` on a timeout or at the end of input).
        """
        if self.closed or self._fd is None:
            return False
        try:
            ready, _, _ = select.select([self._fd], [], [], timeout)
        except (OSError, ValueError):
            self.closed = True
            return False
        if not ready:
            return False
        try:
            data = os.read(self._fd, 256)
        except OSError:
            data = b""
        if not data:
            self.closed = True
            return False
        self._buffer += self._decoder.decode(data)
        return True

    def key(self, timeout: float | None = None) -> str | None:
        """The next key, waiting at most ``timeout`` [s] (``None``: until one comes).

        Returns:
            The key (see the module's docstring for names), or ``None`` on a timeout or at
            the end of input (then :attr:`closed` is set).
        """
        if not self._buffer and not self._fill(timeout):
            return None
        if self._buffer.startswith("\x1b"):
            if len(self._buffer) == 1:
                self._fill(ESC_WAIT)
            return self._escape()
        ch, self._buffer = self._buffer[0], self._buffer[1:]
        if ch in _CONTROL:
            if ch == "\r" and self._buffer.startswith("\n"):
                self._buffer = self._buffer[1:]
            return _CONTROL[ch]
        if ord(ch) < 0x20:
            return f"CTRL-{chr(ord(ch) + 0x40)}"
        return ch

    def _escape(self) -> str:
        """Take one escape sequence (or a lone ESC) from the front of the buffer."""
        buf = self._buffer
        if len(buf) == 1 or buf[1] not in "[O":
            self._buffer = buf[1:]
            return "ESC"
        intro = buf[1]
        for _ in range(2):  # a sequence cut between two reads: wait once for its end
            end = next((i for i in range(2, len(buf)) if "\x40" <= buf[i] <= "\x7e"), None)
            if end is not None:
                break
            self._fill(ESC_WAIT)
            buf = self._buffer
        else:
            self._buffer = ""
            return "UNKNOWN"
        body, final = buf[2:end], buf[end]
        self._buffer = buf[end + 1:]
        if final == "~":
            return _CSI_TILDE.get(body.split(";")[0], "UNKNOWN")
        if intro == "O" or not body or body.startswith("1;"):
            return _CSI_FINAL.get(final, "UNKNOWN")
        return "UNKNOWN"
