"""Single keys from a terminal: a real pty, bytes as a terminal sends them, the mode restored."""

from __future__ import annotations

import io
import os
import pty
import termios
from collections.abc import Iterator

import pytest

from armctl.cli._keys import KeyReader


class _Tty:
    """The slave side of a pty as a text stream (what ``sys.stdin`` is in a terminal)."""

    def __init__(self, fd: int) -> None:
        self.fd = fd

    def fileno(self) -> int:
        return self.fd


@pytest.fixture()
def terminal() -> Iterator[tuple[int, _Tty]]:
    master, slave = pty.openpty()
    try:
        yield master, _Tty(slave)
    finally:
        os.close(master)
        os.close(slave)


def _keys(reader: KeyReader, n: int) -> list[str | None]:
    return [reader.key(timeout=1.0) for _ in range(n)]


def test_keys_and_sequences_are_named(terminal: tuple[int, _Tty]) -> None:
    master, tty = terminal
    with KeyReader(tty) as reader:  # type: ignore[arg-type]
        assert reader.active
        os.write(master, b"a \x1b[A\x1b[B\x1bOC\x1b[D\r\t\x7f\x04\x1b[3~\x1b[5~\x1b[15~\xc3\xa9+")
        got = _keys(reader, 15)
    assert got == ["a", " ", "UP", "DOWN", "RIGHT", "LEFT", "ENTER", "TAB", "BACKSPACE",
                   "CTRL-D", "DELETE", "PAGE-UP", "F5", "\u00e9", "+"]


def test_lone_escape_and_timeout(terminal: tuple[int, _Tty]) -> None:
    master, tty = terminal
    with KeyReader(tty) as reader:  # type: ignore[arg-type]
        assert reader.key(timeout=0.01) is None
        os.write(master, b"\x1b")
        assert reader.key(timeout=1.0) == "ESC"
        os.write(master, b"\x1bx")  # Alt-x: ESC, then the key
        assert _keys(reader, 2) == ["ESC", "x"]


def test_sequence_split_between_reads(terminal: tuple[int, _Tty]) -> None:
    master, tty = terminal
    with KeyReader(tty) as reader:  # type: ignore[arg-type]
        os.write(master, b"\x1b[")
        assert reader._fill(1.0)  # the first half only
        os.write(master, b"A")
        assert reader.key(timeout=1.0) == "UP"


def test_cbreak_while_reading_then_restored(terminal: tuple[int, _Tty]) -> None:
    _, tty = terminal
    before = termios.tcgetattr(tty.fd)
    assert before[3] & termios.ICANON and before[3] & termios.ECHO
    with pytest.raises(RuntimeError), KeyReader(tty) as reader:  # type: ignore[arg-type]
        during = termios.tcgetattr(tty.fd)
        assert not during[3] & termios.ICANON and not during[3] & termios.ECHO
        assert during[3] & termios.ISIG  # Ctrl-C is still a signal
        assert reader.active
        raise RuntimeError("an error inside the block")
    assert termios.tcgetattr(tty.fd) == before


def test_not_a_terminal() -> None:
    r, w = os.pipe()
    try:
        with os.fdopen(r, "r", closefd=False) as stream, KeyReader(stream) as reader:
            assert not reader.active
            os.write(w, b"q")
            assert reader.key(timeout=1.0) == "q"
            os.close(w)
            w = -1
            assert reader.key(timeout=1.0) is None
            assert reader.closed
    finally:
        os.close(r)
        if w >= 0:
            os.close(w)


def test_stream_without_descriptor() -> None:
    reader = KeyReader(io.StringIO("abc"))
    assert not reader.active and reader.closed
    with reader:
        assert reader.key(timeout=0.0) is None
