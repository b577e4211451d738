"""Which processes have a serial port open (what ``fuser`` shows), to name a port's holder.

Read from ``/proc/PID/fd`` on Linux; elsewhere, and for processes whose descriptors this user
may not read, nothing is found.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

__all__ = ["PortHolder", "port_holders"]


@dataclass(frozen=True)
class PortHolder:
    """A process that has a port open.

    Attributes:
        pid: Its process id.
        command: Its command line (``"?"`` when unreadable).
    """

    pid: int
    command: str

    @property
    def is_armctl(self) -> bool:
        """Whether it is an armctl command (the ``armctl`` program or ``python -m armctl``)."""
        words = self.command.split()
        return any(os.path.basename(w) == "armctl" for w in words[:3])

    def __str__(self) -> str:
        return f"pid {self.pid}: {self.command}"


def _command(pid: str, proc: Path) -> str:
    try:
        raw = (proc / pid / "cmdline").read_bytes()
    except OSError:
        return "?"
    words = [w.decode(errors="replace") for w in raw.split(b"\0") if w]
    if len(words) > 2 and words[1] == "-m" and words[2] == "armctl":
        words = ["armctl", *words[3:]]  # python -m armctl ...
    elif words and os.path.basename(words[0]).startswith("python") and len(words) > 1 and \
            os.path.basename(words[1]) == "armctl":
        words = ["armctl", *words[2:]]  # python .../bin/armctl ...
    elif words and os.path.basename(words[0]) == "armctl":
        words = ["armctl", *words[1:]]
    return " ".join(words) or "?"


def port_holders(port: str, proc: str | os.PathLike[str] = "/proc") -> list[PortHolder]:
    """The processes (other than this one) that have ``port`` open, by process id.

    Args:
        port: The port's path (symlinks are resolved).
        proc: The proc file system.
    """
    target = os.path.realpath(port)
    root = Path(proc)
    found: list[PortHolder] = []
    try:
        pids = sorted((p for p in os.listdir(root) if p.isdigit()), key=int)
    except OSError:
        return found
    me = os.getpid()
    for pid in pids:
        if int(pid) == me:
            continue
        fd_dir = root / pid / "fd"
        try:
            fds = os.listdir(fd_dir)
        except OSError:  # gone, or not ours to read
            continue
        for fd in fds:
            try:
                if os.readlink(fd_dir / fd) == target:
                    found.append(PortHolder(int(pid), _command(pid, root)))
                    break
            except OSError:
                continue
    return found
