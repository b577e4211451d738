"""The live state of a robot, as its owner publishes it to other processes.

One process owns a servo port (it opens it exclusively); other processes watch it. The owner
serves its state on a Unix domain socket named after the port (:func:`socket_path`), as JSON
lines (:data:`PROTOCOL_VERSION`):

* one ``hello`` (:class:`LiveHello`) when a watcher connects: who owns the port (arm, config,
  pid, command line) and the joints on the bus;
* ``snapshot`` lines (:class:`LiveSnapshot`) at a fixed rate: measured and commanded joints
  [rad]/[m], what runs, the plan's time and duration, pause and speed, torque;
* one ``end`` line when the owner closes the port.

The socket lives in a directory of the user's own (:func:`runtime_dir`, mode 0700), so only
the same user sees another process's arm. :mod:`armctl.robot.live_publisher` serves it,
:mod:`armctl.robot.live_watch` reads it.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import stat
import tempfile
from dataclasses import asdict, dataclass, fields
from enum import Enum
from pathlib import Path
from typing import Any

from armctl.robot.errors import LiveStateError

__all__ = [
    "MAX_SOCKET_PATH",
    "PROTOCOL_VERSION",
    "Activity",
    "LiveHello",
    "LiveSnapshot",
    "LiveStateError",
    "decode_line",
    "port_key",
    "runtime_dir",
    "socket_path",
]

#: Version of the line format; a watcher refuses a hello of another version.
PROTOCOL_VERSION = 1
#: Longest path a Unix domain socket can have (108 bytes with the terminating NUL on Linux).
MAX_SOCKET_PATH = 107


class Activity(Enum):
    """What the owner of a port is doing."""

    IDLE = "idle"
    MOVE = "move"
    PLAY = "play"
    TEACH = "teach"
    TELEOP = "teleop"
    JOG = "jog"

    @classmethod
    def of_verb(cls, verb: str) -> Activity:
        """What a motion streamed by the armctl command ``verb`` is (:attr:`MOVE` for most)."""
        return {"play": cls.PLAY, "teach": cls.TEACH, "teleop": cls.TELEOP,
                "jog": cls.JOG}.get(verb, cls.MOVE)


@dataclass(frozen=True)
class LiveHello:
    """Who owns a port: the first line a watcher reads.

    Attributes:
        arm: The arm's name.
        config: The arm's config file (or the bundled name when it has no file).
        port: The port as the owner named it.
        real_port: The port's real path (symlinks resolved): what the socket is named after.
        pid: The owner's process id.
        command: The owner's command line.
        verb: The armctl verb the owner runs (``""`` when not run from the command line).
        joints: Names of the joints on the bus, the order of every snapshot's vectors.
        units: ``"rad"`` or ``"m"`` per joint of :attr:`joints`.
        rate_hz: Snapshots per second [Hz].
        started: When the owner started publishing (Unix time [s]).
        version: :data:`PROTOCOL_VERSION`.
    """

    arm: str
    config: str
    port: str
    real_port: str
    pid: int
    command: str
    verb: str
    joints: tuple[str, ...]
    units: tuple[str, ...]
    rate_hz: float
    started: float
    version: int = PROTOCOL_VERSION

    def as_json(self) -> dict[str, Any]:
        """The hello as a JSON object (``"type": "hello"``)."""
        data = asdict(self)
        data["joints"], data["units"] = list(self.joints), list(self.units)
        return {"type": "hello", **data}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> LiveHello:
        """Parse a hello object.

        Raises:
            LiveStateError: Another protocol version or a missing or mistyped field.
        """
        version = data.get("version")
        if version != PROTOCOL_VERSION:
            raise LiveStateError(f"the port's owner speaks live-state version {version!r}, this "
                                 f"armctl version {PROTOCOL_VERSION}; use the same armctl for "
                                 "both", {"version": version})
        try:
            return cls(str(data["arm"]), str(data["config"]), str(data["port"]),
                       str(data["real_port"]), int(data["pid"]), str(data["command"]),
                       str(data["verb"]), tuple(str(j) for j in data["joints"]),
                       tuple(str(u) for u in data["units"]), float(data["rate_hz"]),
                       float(data["started"]), int(version))
        except (KeyError, TypeError, ValueError) as exc:
            raise LiveStateError(f"malformed hello from the port's owner: {exc!r}",
                                 {"line": data}) from None


@dataclass(frozen=True)
class LiveSnapshot:
    """The owner's state at one moment.

    Attributes:
        seq: Snapshot number, counting from 0 for each watcher's connection.
        time: When the snapshot was taken (Unix time [s]).
        activity: What runs.
        description: The running plan's description (``""`` when idle).
        t: Planned time of the last cycle [s] (``None`` when idle).
        duration: Planned duration of the running motion [s] (``None`` when idle).
        measured: Joints read back [rad]/[m], in :attr:`LiveHello.joints` order (``None``
            before the first reading).
        commanded: Goal positions last sent [rad]/[m] (``None`` before the first command).
        age: Time since the last reading or command [s].
        stopping: A stop (deceleration) is under way.
        paused: The motion is paused (``None``: the owner has no pause control).
        speed: The speed override factor (``None``: the owner has no speed control).
        torque: Torque is on for every servo (``False``: off for every one; ``None``: unknown,
            or on for some only).
    """

    seq: int
    time: float
    activity: Activity
    description: str
    t: float | None
    duration: float | None
    measured: tuple[float, ...] | None
    commanded: tuple[float, ...] | None
    age: float
    stopping: bool = False
    paused: bool | None = None
    speed: float | None = None
    torque: bool | None = None

    @property
    def progress(self) -> float | None:
        """Fraction of the motion done, 0..1 (``None`` when idle or of zero duration)."""
        if self.t is None or not self.duration:
            return None
        return min(max(self.t / self.duration, 0.0), 1.0)

    def as_json(self) -> dict[str, Any]:
        """The snapshot as a JSON object (``"type": "snapshot"``)."""
        data = {f.name: getattr(self, f.name) for f in fields(self)}
        data["activity"] = self.activity.value
        for key in ("measured", "commanded"):
            if data[key] is not None:
                data[key] = list(data[key])
        return {"type": "snapshot", **data}

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> LiveSnapshot:
        """Parse a snapshot object.

        Raises:
            LiveStateError: A missing or mistyped field.
        """
        def vector(v: Any) -> tuple[float, ...] | None:  # null: a value not known (NaN)
            return None if v is None else tuple(math.nan if x is None else float(x) for x in v)

        def number(v: Any) -> float | None:
            return None if v is None else float(v)

        try:
            return cls(int(data["seq"]), float(data["time"]), Activity(data["activity"]),
                       str(data["description"]), number(data["t"]), number(data["duration"]),
                       vector(data["measured"]), vector(data["commanded"]),
                       float(data["age"]), bool(data["stopping"]),
                       None if data["paused"] is None else bool(data["paused"]),
                       number(data["speed"]),
                       None if data["torque"] is None else bool(data["torque"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise LiveStateError(f"malformed snapshot from the port's owner: {exc!r}",
                                 {"line": data}) from None


def decode_line(line: bytes | str) -> LiveHello | LiveSnapshot | None:
    """Parse one line: a hello, a snapshot, or ``None`` for the owner's ``end`` line.

    Raises:
        LiveStateError: Not JSON, or an unknown or malformed object.
    """
    try:
        data = json.loads(line)
    except ValueError as exc:
        raise LiveStateError(f"the port's owner sent a line that is not JSON: {exc}") from None
    kind = data.get("type") if isinstance(data, dict) else None
    if kind == "hello":
        return LiveHello.from_json(data)
    if kind == "snapshot":
        return LiveSnapshot.from_json(data)
    if kind == "end":
        return None
    raise LiveStateError(f"the port's owner sent an unknown line type {kind!r}")


def runtime_dir(create: bool = False) -> Path:
    """The directory of this user's live-state sockets.

    ``$XDG_RUNTIME_DIR/armctl`` when ``XDG_RUNTIME_DIR`` names a directory, else
    ``armctl-UID`` in the temporary directory. It is created with mode 0700 and must belong to
    this user and be closed to others (a directory that another user made could carry a false
    owner's socket).

    Args:
        create: Create it when missing.

    Raises:
        LiveStateError: It exists but is not a directory of this user's, or is open to others.
    """
    base = os.environ.get("XDG_RUNTIME_DIR", "")
    uid = os.getuid() if hasattr(os, "getuid") else 0
    path = (Path(base) / "armctl" if base and Path(base).is_dir()
            else Path(tempfile.gettempdir()) / f"armctl-{uid}")
    if create:
        try:
            path.mkdir(mode=0o700, exist_ok=True)
        except OSError as exc:
            raise LiveStateError(f"cannot create the live-state directory {path}: {exc}",
                                 {"path": str(path)}) from None
    try:
        st = path.lstat()
    except FileNotFoundError:
        return path
    if not stat.S_ISDIR(st.st_mode) or st.st_uid != uid or st.st_mode & 0o077:
        raise LiveStateError(
            f"the live-state directory {path} is not a private directory of this user's (it "
            f"must belong to uid {uid} with mode 0700); remove it, or set XDG_RUNTIME_DIR",
            {"path": str(path)})
    return path


def port_key(port: str) -> str:
    """The port's identity: its real path (symlinks such as /dev/serial/by-id resolved)."""
    return os.path.realpath(port)


def socket_path(port: str, create_dir: bool = False) -> Path:
    """The live-state socket of ``port`` (named after its real path).

    Raises:
        LiveStateError: See :func:`runtime_dir`, or a path too long for a Unix socket.
    """
    digest = hashlib.sha256(port_key(port).encode()).hexdigest()[:16]
    path = runtime_dir(create_dir) / f"live-{digest}.sock"
    if len(os.fsencode(path)) > MAX_SOCKET_PATH:
        raise LiveStateError(f"the live-state socket path {path} is longer than a Unix socket "
                             f"allows ({MAX_SOCKET_PATH} bytes); set XDG_RUNTIME_DIR to a "
                             "shorter directory", {"path": str(path)})
    return path
