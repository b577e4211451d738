"""Watch the robot that owns a port from another process.

:func:`attach` connects to the live state the port's owner publishes
(:mod:`armctl.robot.live_publisher`) and returns a :class:`LiveWatcher`: the owner's
:class:`~armctl.robot.live_state.LiveHello` and its snapshots, read one at a time
(:meth:`LiveWatcher.next`, :meth:`LiveWatcher.snapshots`) or kept up to date by a background
thread (:meth:`LiveWatcher.follow`, :attr:`LiveWatcher.latest`). Watching never touches the
port.
"""

from __future__ import annotations

import contextlib
import os
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

from armctl.robot.errors import LiveStateError, OwnerGone
from armctl.robot.live_state import LiveHello, LiveSnapshot, decode_line, port_key, socket_path

__all__ = ["LiveWatcher", "OwnerGone", "attach"]

#: Longest line accepted from an owner [bytes].
_MAX_LINE = 1 << 20


class LiveWatcher:
    """A connection to the live state of a port's owner (use :func:`attach`).

    Attributes:
        hello: Who owns the port.
        latest: The newest snapshot (``None`` before the first); kept up to date by
            :meth:`follow`.
        ended: Why the watch ended (``None`` while it runs).
    """

    def __init__(self, conn: socket.socket, hello: LiveHello, buffer: bytes = b""):
        self._conn = conn
        self._buffer = bytearray(buffer)
        self.hello = hello
        self.latest: LiveSnapshot | None = None
        self.ended: str | None = None
        self._thread: threading.Thread | None = None
        self._changed = threading.Condition()

    # ---- reading ------------------------------------------------------------------------------
    def _line(self, timeout: float | None) -> bytes | None:
        """The next line, ``None`` at the end of the stream.

        Raises:
            TimeoutError: Nothing complete arrived within ``timeout`` [s].
            LiveStateError: A line longer than any the owner sends.
        """
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            end = self._buffer.find(b"\n")
            if end >= 0:
                line = bytes(self._buffer[:end])
                del self._buffer[:end + 1]
                return line
            if len(self._buffer) > _MAX_LINE:
                raise LiveStateError("the port's owner sent a line longer than "
                                     f"{_MAX_LINE} bytes")
            left = None if deadline is None else max(deadline - time.monotonic(), 0.0)
            if left == 0.0:
                raise TimeoutError("no snapshot in time")
            self._conn.settimeout(left)
            try:
                data = self._conn.recv(4096)
            except TimeoutError:
                raise
            except OSError:
                return None
            if not data:
                return None
            self._buffer += data

    def next(self, timeout: float | None = 2.0) -> LiveSnapshot:
        """The next snapshot.

        Args:
            timeout: Longest wait [s] (``None``: no limit).

        Raises:
            OwnerGone: The owner closed the port or exited.
            TimeoutError: No snapshot within ``timeout`` (the owner is alive but hung).
            LiveStateError: A malformed line.
        """
        if self.ended is not None:
            raise OwnerGone(self.ended, {"pid": self.hello.pid})
        while True:
            line = self._line(timeout)
            item = None if line is None else decode_line(line)
            if item is None:
                if self.ended is None:  # (else the watcher was closed meanwhile)
                    self.ended = (f"{self._who()} released the port" if line is not None else
                                  f"{self._who()} exited or stopped publishing")
                self._publish(None)
                raise OwnerGone(self.ended, {"pid": self.hello.pid})
            if isinstance(item, LiveSnapshot):
                self._publish(item)
                return item

    def snapshots(self, timeout: float | None = 2.0) -> Iterator[LiveSnapshot]:
        """Every snapshot until the owner closes the port or exits.

        Raises:
            TimeoutError, LiveStateError: As :meth:`next`.
        """
        while True:
            try:
                yield self.next(timeout)
            except OwnerGone:
                return

    def _who(self) -> str:
        h = self.hello
        return f"pid {h.pid} ({h.command})"

    def _publish(self, snap: LiveSnapshot | None) -> None:
        with self._changed:
            if snap is not None:
                self.latest = snap
            self._changed.notify_all()

    # ---- following in the background ----------------------------------------------------------
    def follow(self) -> LiveWatcher:
        """Read snapshots in a background thread, keeping :attr:`latest` (until the end)."""
        if self._thread is not None:
            return self

        def loop() -> None:
            while self.ended is None:
                try:
                    self.next(timeout=None)
                except OwnerGone:
                    return
                except (LiveStateError, OSError) as exc:
                    self.ended = f"the live state of {self._who()} broke off: {exc}"
                    self._publish(None)
                    return

        self._thread = threading.Thread(target=loop, name="armctl-live-watch", daemon=True)
        self._thread.start()
        return self

    def wait_newer(self, seq: int, timeout: float) -> LiveSnapshot | None:
        """With :meth:`follow`: wait for a snapshot after ``seq`` (or the end); the latest."""
        with self._changed:
            self._changed.wait_for(lambda: self.ended is not None or (
                self.latest is not None and self.latest.seq > seq), timeout)
            return self.latest

    def close(self) -> None:
        """Stop watching (the owner goes on)."""
        if self.ended is None:
            self.ended = "the watcher closed"
        with contextlib.suppress(OSError):
            self._conn.shutdown(socket.SHUT_RDWR)
        self._conn.close()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
            self._thread = None

    def __enter__(self) -> LiveWatcher:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def attach(port: str, wait: float = 0.0, path: str | os.PathLike[str] | None = None
           ) -> LiveWatcher | None:
    """Connect to the live state of ``port``'s owner.

    Args:
        port: The port (a device or an ``armctl sim`` pty; symlinks are resolved).
        wait: Keep trying this long [s] for an owner that is opening the port and has not
            started publishing yet.
        path: The socket (default :func:`~armctl.robot.live_state.socket_path` of the port).

    Returns:
        The watcher, ``None`` when no armctl process publishes for the port (none owns it, or
        its owner is gone and left a stale socket).

    Raises:
        LiveStateError: The owner answered with a malformed hello, another protocol version,
            or a hello for another port.
    """
    sock_path = Path(path) if path is not None else socket_path(port)
    deadline = time.monotonic() + max(wait, 0.0)
    while True:
        conn = _connect(sock_path)
        if conn is not None or time.monotonic() >= deadline:
            break
        time.sleep(0.05)
    if conn is None:
        return None
    try:
        line, rest = _first_line(conn, 2.0)
        hello = None if line is None else decode_line(line)
    except LiveStateError:
        conn.close()
        raise
    if not isinstance(hello, LiveHello):
        conn.close()
        return None  # the owner closed at this moment, or never greeted
    if hello.real_port != port_key(port):
        conn.close()
        raise LiveStateError(f"the live state at {sock_path} is of port {hello.real_port}, "
                             f"not {port_key(port)}", {"port": port})
    return LiveWatcher(conn, hello, rest)


def _first_line(conn: socket.socket, timeout: float) -> tuple[bytes | None, bytes]:
    """The first line on a new connection and what followed it (``None``: nothing in time)."""
    data = b""
    deadline = time.monotonic() + timeout
    while b"\n" not in data:
        left = deadline - time.monotonic()
        if left <= 0 or len(data) > _MAX_LINE:
            return None, b""
        conn.settimeout(left)
        try:
            chunk = conn.recv(4096)
        except OSError:  # includes the timeout
            return None, b""
        if not chunk:
            return None, b""
        data += chunk
    line, _, rest = data.partition(b"\n")
    return line, rest


def _connect(path: Path) -> socket.socket | None:
    """A connection to the socket at ``path``; ``None`` when none listens there."""
    if not hasattr(socket, "AF_UNIX"):
        return None  # no owner can publish on this platform
    conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    try:
        conn.connect(os.fspath(path))
    except OSError:  # missing, stale (refused), or not a socket
        conn.close()
        return None
    return conn
