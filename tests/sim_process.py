"""``armctl sim so101`` in a process of its own, for tests that drive it from other processes.

(A plain module rather than conftest.py, as tests/armctl_testpaths.py.)
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys

import numpy as np

__all__ = ["SO_JOINTS", "SimProcess"]

#: The SO-101's joints, in its config's order.
SO_JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll",
             "gripper")


class SimProcess:
    """``armctl sim so101 --json``: its pty in :attr:`port`; ``joints()`` asks the simulator."""

    def __init__(self) -> None:
        self.proc = subprocess.Popen([sys.executable, "-m", "armctl", "sim", "so101", "--json"],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                     env=dict(os.environ, PYTHONUNBUFFERED="1"))
        assert self.proc.stdout is not None
        head = ""
        while not head.rstrip().endswith("}"):
            line = self.proc.stdout.readline()
            assert line, "armctl sim ended before it printed its port"
            head += line
        self.port: str = json.loads(head)["port"]

    def joints(self) -> np.ndarray:
        """The servos' joint values [rad] as the simulator itself reports them ('get')."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write("get\n")
        self.proc.stdin.flush()
        values = {}
        for _ in SO_JOINTS:
            m = re.match(r"(\w+) \(id \d+\): (\S+)", self.proc.stdout.readline())
            assert m is not None
            values[m.group(1)] = float(m.group(2))
        return np.array([values[n] for n in SO_JOINTS])

    def close(self) -> None:
        """Quit the simulator (killed when it does not quit within 10 s)."""
        if self.proc.poll() is None:
            assert self.proc.stdin is not None
            try:
                self.proc.stdin.write("quit\n")
                self.proc.stdin.flush()
                self.proc.wait(timeout=10)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
        self.proc.wait(10)
