"""``armctl jog`` through a real terminal: a pseudo-terminal, keys in, the screen read back.

The command runs as its own process on the built-in simulated bus (wall-clock time), with its
standard input on a pty in cbreak mode, as in a terminal. The keyframe file it writes is checked
against the steps sent (not against the status text), and ``armctl play`` must accept it.
"""

from __future__ import annotations

import fcntl
import json
import math
import os
import re
import select
import signal
import struct
import subprocess
import sys
import termios
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.motion import load_keyframes

pytestmark = pytest.mark.timeout(240)

_STATUS = re.compile(r"\[(\w+) (\d+):(\w+) step ([^\]]*) speed (\d+)% kf (\d+)\] joints\[deg\] "
                     r"([^|]*)\| tcp\[mm\] (\S+) (\S+) (\S+) rpy\[deg\] [^|]*\| ?(.*)$")


@dataclass(frozen=True)
class Status:
    """The status line, read off the screen."""

    mode: str
    target: str
    keyframes: int
    joints: list[float]
    tcp: list[float]
    message: str


class Terminal:
    """``armctl jog`` in a pseudo-terminal 250 columns wide."""

    def __init__(self, *args: str, json_out: bool = False):
        master, slave = os.openpty()
        fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 50, 250, 0, 0))
        env = {k: v for k, v in os.environ.items() if k not in ("COLUMNS", "LINES")}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "armctl", "jog", *args],
            stdin=slave, stdout=subprocess.PIPE if json_out else slave, stderr=slave, env=env,
            start_new_session=True)
        os.close(slave)
        self.master = master
        self.screen = ""

    def read(self, seconds: float = 0.05) -> None:
        end = time.monotonic() + seconds
        while True:
            ready, _, _ = select.select([self.master], [], [], max(end - time.monotonic(), 0))
            if not ready:
                return
            try:
                data = os.read(self.master, 65536)
            except OSError:  # the process has ended
                return
            self.screen += data.decode(errors="replace")

    def send(self, keys: str) -> None:
        os.write(self.master, keys.encode())

    def status(self) -> Status | None:
        """The last status line drawn."""
        for part in reversed(re.split(r"[\r\n]", self.screen)):
            m = _STATUS.search(part.replace("\x1b[K", ""))
            if m:
                return Status(m.group(1), m.group(3), int(m.group(6)),
                              [float(v) for v in m.group(7).split()],
                              [float(m.group(i)) for i in (8, 9, 10)], m.group(11).strip())
        return None

    def wait(self, check: Callable[[Status], bool], what: str, timeout: float = 20.0) -> Status:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.read(0.05)
            st = self.status()
            if st is not None and check(st):
                return st
        raise AssertionError(f"timed out waiting for {what}; last status: {self.status()}\n"
                             f"screen tail: {self.screen[-1500:]!r}")

    def close(self) -> int:
        try:
            code = self.proc.wait(timeout=20)
        finally:
            self.read(0.1)
            os.close(self.master)
        return code


@pytest.fixture
def terminals() -> Iterator[list[Terminal]]:
    made: list[Terminal] = []
    yield made
    for t in made:
        if t.proc.poll() is None:
            t.proc.send_signal(signal.SIGKILL)
            t.proc.wait()


def idle(message: str) -> Callable[[Status], bool]:
    return lambda st: st.message == message


def test_jog_steps_records_keyframes_and_play_accepts_them(
        terminals: list[Terminal], tmp_path: Path, capsys: pytest.CaptureFixture[str],
        simulated_time: object) -> None:  # for the in-process 'armctl play' at the end
    path = tmp_path / "jogged.yaml"
    term = Terminal("so101", "--sim", "-o", str(path), "--speed", "1", "--deg-steps", "2", "5",
                    "--mm-steps", "2", "10")
    terminals.append(term)
    st = term.wait(lambda s: s.message.startswith("ready"), "the first status line", 60)
    assert st.mode == "joint" and st.target == "shoulder_pan"
    start = list(st.joints)
    # the help screen lists the keys
    term.send("?")
    term.wait(idle("help above"), "the help")
    assert "space         stop the running step" in term.screen
    # joint 1 (shoulder_pan) +5 deg, record
    term.send("]")
    term.wait(idle("step 5 deg / 10 mm"), "the bigger step")
    term.send("+")
    st = term.wait(idle("shoulder_pan +5.0 deg"), "the pan step")
    assert st.joints[0] == pytest.approx(start[0] + 5, abs=0.3)
    term.send("k")
    st = term.wait(idle("keyframe 1 recorded"), "keyframe 1")
    assert st.keyframes == 1
    # joint 2 (shoulder_lift) -5 deg twice, record
    term.send("2")
    term.wait(idle("selected shoulder_lift"), "the selection")
    for k in (1, 2):
        lift = start[1] - 5 * k

        def lifted(s: Status, lift: float = lift) -> bool:
            return s.message == "shoulder_lift -5.0 deg" and abs(s.joints[1] - lift) < 0.3

        term.send("-")
        term.wait(lifted, f"lift step {k}")
    term.send("k")
    term.wait(idle("keyframe 2 recorded"), "keyframe 2")
    # the tool 2 mm up along the base z, record
    term.send("m3[")
    term.wait(lambda s: s.mode == "base" and s.target == "z" and
              s.message == "step 2 deg / 2 mm", "base z")
    before = term.status()
    assert before is not None
    term.send("+")
    # (the first straight line may compile IK kernels on a fresh install: a longer wait)
    st = term.wait(idle("base z +2.0 mm"), "the z step", 150)
    assert st.tcp[2] == pytest.approx(before.tcp[2] + 2.0, abs=0.8)  # read back: +- a tick
    term.send("k")
    term.wait(idle("keyframe 3 recorded"), "keyframe 3")
    # a turn the 5-joint arm cannot make is refused, and the status line says why
    term.send("6+")
    st = term.wait(lambda s: "refused" in s.message, "the refusal")
    assert "5 joints cannot turn the tool about base z here" in st.message
    assert "cannot turn it about the base frame's z axis" in term.screen  # the whole story
    assert "Traceback" not in term.screen
    # key repeat: 15 jog keys at once make one step, not fifteen
    term.send("mm1]")  # base -> tool -> joint, joint 1, 5 deg
    term.wait(lambda s: s.mode == "joint" and s.target == "shoulder_pan" and
              s.message == "step 5 deg / 10 mm", "joint 1, 5 deg")
    pan = term.status()
    assert pan is not None
    term.send("-" * 15)
    st = term.wait(lambda s: s.message.startswith("shoulder_pan -5.0 deg (")
                   and "dropped" in s.message, "the repeated step")
    time.sleep(0.5)
    term.read(0.2)
    st2 = term.status()
    assert st2 is not None and st2.message == st.message  # nothing more came
    assert st2.joints[0] == pytest.approx(pan.joints[0] - 5, abs=0.3)  # one step
    term.send("q")
    assert term.close() == 0
    assert "4 steps" in term.screen or "5 steps" in term.screen
    assert "3 keyframes in" in term.screen

    # the file holds the steps sent, in the format 'armctl teach' writes
    arm = load_arm("so101")
    program = load_keyframes(path, arm)
    assert len(program.keyframes) == 3
    q = np.array([kf.q for kf in program.keyframes], dtype=float)
    s0 = np.radians(start[:5])
    # the goals sent (the status shows the start to 0.1 deg: the simulated servos start at 0)
    assert np.allclose(s0, 0.0, atol=math.radians(0.05))
    assert np.allclose(q[0], np.radians([5, 0, 0, 0, 0]), atol=1e-6)
    assert np.allclose(q[1], np.radians([5, -10, 0, 0, 0]), atol=1e-6)
    full = [np.append(v, 0.0) for v in q]
    up = arm.fk(full[2])[:3, 3] - arm.fk(full[1])[:3, 3]
    assert np.allclose(up, [0, 0, 0.002], atol=2e-5)  # a straight 2 mm up
    # and 'armctl play' replays it on the simulated bus
    code = main(["play", str(path), "so101", "--sim", "--json"])
    out = capsys.readouterr().out
    assert code == 0, out
    assert json.loads(out)["ok"] is True


def test_a_step_into_a_scene_obstacle_is_refused_with_the_pair(
        terminals: list[Terminal], tmp_path: Path) -> None:
    scene = tmp_path / "block.yaml"
    scene.write_text("obstacles:\n  - {name: block, shape: box, size: [0.06, 0.02, 0.08], "
                     "origin: {xyz: [0.39, -0.045, 0.226]}}\n", encoding="utf-8")
    term = Terminal("so101", "--sim", "--scene", str(scene), "--mm-steps", "1", "5", "20")
    terminals.append(term)
    term.wait(lambda s: s.message.startswith("ready"), "the first status line", 60)
    term.send("m2]]")  # base frame, y, 20 mm
    term.wait(lambda s: s.mode == "base" and s.target == "y" and "20 mm" in s.message,
              "base y, 20 mm")
    before = term.status()
    assert before is not None
    term.send("-")
    st = term.wait(lambda s: "refused" in s.message, "the refusal", 150)
    assert "gripper_link and block would come within their 5 mm padding" in st.message
    assert st.joints == before.joints  # nothing moved
    assert "refused: straight line" in term.screen  # the whole explanation above the line
    term.send("q")
    assert term.close() == 0


def test_space_stops_a_step_and_ctrl_c_quits_holding(terminals: list[Terminal],
                                                      tmp_path: Path) -> None:
    term = Terminal("so101", "--sim", "--speed", "0.1", "--deg-steps", "30",
                    "--mm-steps", "20", "--json", json_out=True)
    terminals.append(term)
    term.wait(lambda s: s.message.startswith("ready"), "the first status line", 60)
    term.send("+")
    term.wait(lambda s: s.message.startswith("moving") and s.joints[0] > 2, "the step under way")
    term.send(" ")
    st = term.wait(lambda s: s.message.startswith("shoulder_pan +30.0 deg: stopped"),
                   "the stop")
    assert 2 < st.joints[0] < 29  # stopped short of the step
    term.send("+")
    term.wait(lambda s: s.message.startswith("moving"), "the next step under way")
    os.killpg(term.proc.pid, signal.SIGINT)  # Ctrl-C, as the terminal sends it
    code = term.close()
    assert code == 5  # stopped for a signal once the arm had moved: it holds
    assert term.proc.stdout is not None
    data = json.loads(term.proc.stdout.read())
    assert data["ended"] == "signal" and data["steps"] == 0
    assert data["ok"] is False  # as the exit code says
    assert "Traceback" not in term.screen


def test_ctrl_c_before_anything_moved_exits_130(terminals: list[Terminal]) -> None:
    term = Terminal("so101", "--sim")
    terminals.append(term)
    term.wait(lambda s: s.message.startswith("ready"), "the first status line", 60)
    os.killpg(term.proc.pid, signal.SIGINT)
    assert term.close() == 130
    assert "interrupted by SIGINT; nothing moved" in term.screen
    assert "Traceback" not in term.screen


def test_jog_needs_a_terminal(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["jog", "so101", "--sim", "--json"])
    out, _ = capsys.readouterr()
    assert code == 2
    assert "armctl jog needs a terminal" in json.loads(out)["error"]["message"]
    proc = subprocess.run([sys.executable, "-m", "armctl", "jog", "so101", "--sim"],
                          stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=60,
                          check=False)
    assert proc.returncode == 2
    assert "needs a terminal" in proc.stderr and "Traceback" not in proc.stderr
