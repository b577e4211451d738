"""Serve the live state of the robot that owns a port to watching processes.

The control loop only stores its latest values (:meth:`LivePublisher.cycle`,
:meth:`LivePublisher.reading`: one tuple assignment, no lock, no I/O); a server thread turns
them into snapshot lines at :attr:`LivePublisher.rate_hz` and sends them to every watcher
(see :mod:`armctl.robot.live_state` for the format). A watcher that does not keep up (its
socket buffer is full) or that went away is dropped, never waited for.

The socket is removed when the publisher closes. A socket left behind by an owner that died is
replaced: the publisher is started only by the process that holds the port's lock, so an
existing socket of that port can only be stale.
"""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import select
import socket
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from armctl.errors import InputError, json_safe
from armctl.robot.live_state import (
    Activity,
    LiveHello,
    LiveSnapshot,
    LiveStateError,
    port_key,
    socket_path,
)
from armctl.typing import Array

__all__ = ["DEFAULT_RATE_HZ", "MAX_WATCHERS", "ControlReading", "LivePublisher", "control_reader",
           "cycle_hook", "hello_for", "publish_robot"]

logger = logging.getLogger(__name__)

#: Snapshots per second [Hz].
DEFAULT_RATE_HZ = 25.0
#: Most watchers served at once (more are refused by closing their connection).
MAX_WATCHERS = 16


@dataclass(frozen=True)
class ControlReading:
    """Pause and speed override of the running motion, as a snapshot shows them.

    Attributes:
        paused: Whether the motion is paused.
        speed: The speed override factor.
    """

    paused: bool | None = None
    speed: float | None = None


def _vector(v: Array | None) -> tuple[float, ...] | None:
    return None if v is None else tuple(float(x) for x in v)


class LivePublisher:
    """Publishes one owner's live state on the port's socket.

    Args:
        hello: Who owns the port (sent to every watcher first).
        rate_hz: Snapshots per second [Hz].
        control: Returns the pause and speed override (called by the server thread; ``None``:
            none to show).
        path: The socket (default :func:`~armctl.robot.live_state.socket_path` of the port).
    """

    def __init__(self, hello: LiveHello, rate_hz: float = DEFAULT_RATE_HZ,
                 control: Callable[[], ControlReading] | None = None,
                 path: str | os.PathLike[str] | None = None):
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise InputError(f"the live-state rate must be a positive number of snapshots a "
                             f"second, got {rate_hz}")
        self.hello = hello
        self.rate_hz = float(rate_hz)
        self.control = control
        self.path = os.fspath(path) if path is not None else os.fspath(
            socket_path(hello.port, create_dir=True))
        # (activity, description, t, duration, measured, commanded, stopping, monotonic time):
        # replaced whole by the control loop, read whole by the server thread.
        self._latest: tuple[Activity, str, float | None, float | None, Array | None,
                            Array | None, bool, float] = (
            Activity.IDLE, "", None, None, None, None, False, time.monotonic())
        #: Torque on for every servo (``False``: off for every one; ``None``: unknown, or on
        #: for some only); set by the owner.
        self.torque: bool | None = None
        self._listener: socket.socket | None = None
        self._inode: tuple[int, int] | None = None
        self._thread: threading.Thread | None = None
        self._closing = threading.Event()
        self._wake_r, self._wake_w = -1, -1
        self._clients: list[tuple[socket.socket, int]] = []  # (connection, next seq)
        #: Watchers dropped because they did not keep up or went away.
        self.dropped = 0

    # ---- life cycle -------------------------------------------------------------------------
    def start(self) -> LivePublisher:
        """Bind the socket (replacing a stale one) and start serving.

        Raises:
            LiveStateError: The socket cannot be created.
        """
        if self._thread is not None:
            return self
        if not hasattr(socket, "AF_UNIX"):
            raise LiveStateError("this platform has no Unix domain sockets: other processes "
                                 "cannot watch the arm")
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.path)  # stale: only the port's owner publishes for it
        listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            listener.bind(self.path)
            os.chmod(self.path, 0o600)  # (its directory is the user's own already)
            listener.listen(MAX_WATCHERS)
            listener.setblocking(False)
            st = os.stat(self.path)
        except OSError as exc:
            listener.close()
            raise LiveStateError(f"cannot serve the live state on {self.path}: {exc}",
                                 {"path": self.path}) from None
        self._listener, self._inode = listener, (st.st_dev, st.st_ino)
        self._wake_r, self._wake_w = os.pipe()
        self._thread = threading.Thread(target=self._serve, name="armctl-live-state",
                                        daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        """Stop serving (idempotent): the last snapshot and ``end`` go to the watchers first.

        The socket is removed.
        """
        if self._thread is None:
            return
        self._closing.set()
        with contextlib.suppress(OSError):
            os.write(self._wake_w, b"x")
        self._thread.join(timeout=2.0)
        self._thread = None
        for fd in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._wake_r = self._wake_w = -1
        try:  # remove the socket only if it is still ours
            st = os.stat(self.path)
            if (st.st_dev, st.st_ino) == self._inode:
                os.unlink(self.path)
        except OSError:
            pass
        if self._listener is not None:
            self._listener.close()
            self._listener = None

    def __enter__(self) -> LivePublisher:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def watchers(self) -> int:
        """Watchers connected now."""
        return len(self._clients)

    # ---- what the owner stores (cheap, from the control loop) ---------------------------------
    def cycle(self, activity: Activity, description: str, t: float | None,
              duration: float | None, commanded: Array | None, measured: Array | None,
              stopping: bool = False) -> None:
        """Store one control cycle (bus joint order, [rad]/[m]); never blocks.

        ``measured`` ``None`` keeps the last reading.
        """
        last = self._latest
        self._latest = (activity, description, t, duration,
                        last[4] if measured is None else np.array(measured, dtype=float),
                        None if commanded is None else np.array(commanded, dtype=float),
                        stopping, time.monotonic())

    def reading(self, measured: Array) -> None:
        """Store a reading of the joints outside a motion (bus joint order, [rad]/[m])."""
        last = self._latest
        self._latest = (last[0], last[1], last[2], last[3], np.array(measured, dtype=float),
                        last[5], last[6], time.monotonic())

    def idle(self) -> None:
        """The motion ended: the owner is idle (the last values are kept)."""
        last = self._latest
        self._latest = (Activity.IDLE, "", None, None, last[4], last[5], False, last[7])

    def snapshot(self, seq: int = 0) -> LiveSnapshot:
        """The state now, as a watcher receives it."""
        activity, description, t, duration, measured, commanded, stopping, at = self._latest
        control = ControlReading()
        if self.control is not None:
            try:
                control = self.control()
            except Exception as exc:  # the owner's control must not end the publisher
                logger.debug("reading the motion control failed: %s", exc)
        return LiveSnapshot(seq, time.time(), activity, description, t, duration,
                            _vector(measured), _vector(commanded),
                            max(time.monotonic() - at, 0.0), stopping, control.paused,
                            control.speed, self.torque)

    # ---- the server thread --------------------------------------------------------------------
    def _serve(self) -> None:
        try:
            self._loop()
        except Exception as exc:  # never into the owner: its watchers see the end
            logger.warning("serving the live state stopped: %s", exc)
            for conn, _ in self._clients:
                conn.close()
            self._clients = []

    def _loop(self) -> None:
        listener = self._listener
        assert listener is not None  # start() set it  # mypy.
        period = 1.0 / self.rate_hz
        due = time.monotonic()
        hello = (json.dumps(json_safe(self.hello.as_json()), allow_nan=False) + "\n").encode()
        while not self._closing.is_set():
            # with nobody watching, sleep until a watcher connects or the publisher closes
            wait = max(due - time.monotonic(), 0.0) if self._clients else None
            try:
                ready, _, _ = select.select([listener.fileno(), self._wake_r], [], [], wait)
            except (OSError, ValueError):
                break
            if listener.fileno() in ready:
                self._accept(listener, hello)
            now = time.monotonic()
            if now >= due and self._clients:
                self._broadcast()
                due += period
                if due <= now:  # behind (or the first watcher after a pause): no burst
                    due = now + period
        # the last state (the arm where the owner left it), then the end
        self._broadcast()
        end = b'{"type": "end"}\n'
        for conn, _ in self._clients:
            self._send(conn, end)
            conn.close()
        self._clients = []

    def _accept(self, listener: socket.socket, hello: bytes) -> None:
        while True:
            try:
                conn, _ = listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:
                logger.debug("accepting a watcher failed: %s", exc)
                return
            conn.setblocking(False)
            if len(self._clients) >= MAX_WATCHERS or not self._send(conn, hello):
                conn.close()
                self.dropped += 1
                continue
            self._clients.append((conn, 0))

    def _broadcast(self) -> None:
        kept: list[tuple[socket.socket, int]] = []
        base = json_safe(self.snapshot().as_json())  # strict JSON: NaN is null
        for conn, seq in self._clients:
            base["seq"] = seq
            if self._send(conn, (json.dumps(base, allow_nan=False) + "\n").encode()):
                kept.append((conn, seq + 1))
            else:
                conn.close()
                self.dropped += 1
        self._clients = kept

    @staticmethod
    def _send(conn: socket.socket, data: bytes) -> bool:
        """Send a whole line without waiting; ``False`` (drop the watcher) if it cannot."""
        try:
            return conn.send(data, getattr(socket, "MSG_NOSIGNAL", 0)) == len(data)
        except OSError:  # BlockingIOError: its buffer is full; BrokenPipeError: it went away
            return False


def hello_for(arm: str, config: str, port: str, joints: Sequence[str], units: Sequence[str],
              rate_hz: float = DEFAULT_RATE_HZ, argv: Sequence[str] | None = None
              ) -> LiveHello:
    """The hello of this process for an arm on ``port``.

    Args:
        arm: The arm's name.
        config: Its config file, or its bundled name.
        port: The port as given.
        joints: The bus joints, in bus order.
        units: ``"rad"`` or ``"m"`` per joint.
        rate_hz: Snapshots per second [Hz].
        argv: The command line (default ``sys.argv``).
    """
    import sys

    args = list(sys.argv if argv is None else argv)
    program = os.path.basename(args[0]) if args else ""
    verb = ""
    if program in ("armctl", "__main__.py") and len(args) > 1:
        verb = next((a for a in args[1:] if not a.startswith("-")), "")
    shown = ["armctl", *args[1:]] if program in ("armctl", "__main__.py") else args
    return LiveHello(arm, config, port, port_key(port), os.getpid(), " ".join(shown), verb,
                     tuple(joints), tuple(units), float(rate_hz), time.time())


def control_reader(owner: object) -> Callable[[], ControlReading]:
    """Reads pause and speed override from ``owner.control`` when it has one.

    ``owner.control`` (a motion control with a ``state()`` snapshot whose ``paused`` and
    ``speed`` are read) is looked up at every call, so an owner without one shows neither.
    """
    def read() -> ControlReading:
        control = getattr(owner, "control", None)
        state = getattr(control, "state", None)
        if state is None:
            return ControlReading()
        now = state()
        paused, speed = getattr(now, "paused", None), getattr(now, "speed", None)
        return ControlReading(None if paused is None else bool(paused),
                              None if speed is None else float(speed))
    return read


def cycle_hook(publisher: LivePublisher, activity: Activity, description: str,
               on_cycle: Callable[[Any], None] | None) -> Callable[[Any], None]:
    """An executor ``on_cycle`` that stores each cycle in ``publisher``, then calls ``on_cycle``.

    The cycle is a :class:`~armctl.robot.executor.CycleInfo` (``t``, ``duration``, ``command``,
    ``measured``, ``stopping``).
    """
    def hook(info: Any) -> None:
        publisher.cycle(activity, description, info.t, info.duration, info.command,
                        info.measured, info.stopping)
        if on_cycle is not None:
            on_cycle(info)
    return hook


def publish_robot(owner: object, arm: str, config: str, port: str, joints: Sequence[str],
                  units: Sequence[str]) -> LivePublisher | None:
    """Start publishing the live state of a robot that opened ``port`` (``None`` if it cannot).

    A publisher that cannot start (e.g. the runtime directory belongs to another user) is
    logged as a warning: the robot works on without being watchable.

    Args:
        owner: The robot (its ``control``, when it has one, gives pause and speed).
        arm: The arm's name.
        config: Its config file, or its bundled name.
        port: The port it opened.
        joints: The bus joints, in bus order.
        units: ``"rad"`` or ``"m"`` per joint.
    """
    try:
        return LivePublisher(hello_for(arm, config, port, joints, units),
                             control=control_reader(owner)).start()
    except LiveStateError as exc:
        logger.warning("other processes cannot watch this arm: %s", exc)
        return None
