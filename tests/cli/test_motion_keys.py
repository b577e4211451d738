"""Keys during motion commands: space pauses and resumes, + and - change the speed.

Through a real pseudo-terminal: ``armctl move-joints ... --sim`` runs with the pty as its
terminal; the test presses space, sees "paused" on the progress line and the plan time stand
still, presses space again and the move finishes with exit 0; the motion log shows the held
cycles, and the terminal is back in its own mode afterwards. In-process tests drive
:class:`MotionKeys` through a pty too, and check that nothing is read without a terminal.
"""

from __future__ import annotations

import os
import re
import select
import subprocess
import sys
import termios
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from armctl.cli._motion_keys import SPEED_STEP, MotionKeys
from armctl.robot import MotionControl

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="needs a POSIX pty")

_MODE = termios.ICANON | termios.ECHO


class Pty:
    """A pseudo-terminal: ``slave`` for the program, ``master`` for the test's keyboard."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        self.out = b""

    def read(self, seconds: float, until: bytes | None = None) -> bytes:
        """Collect output for ``seconds`` [s] (or until ``until`` appears); all so far."""
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            ready, _, _ = select.select([self.master], [], [], 0.05)
            if ready:
                try:
                    data = os.read(self.master, 65536)
                except OSError:
                    break
                if not data:
                    break
                self.out += data
                if until is not None and until in self.out:
                    break
        return self.out

    def close(self) -> None:
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


@pytest.fixture
def pty_pair() -> Iterator[Pty]:
    p = Pty()
    yield p
    p.close()


def progress_lines(out: bytes) -> list[tuple[str, float]]:
    """(state, plan time [s]) of every progress line drawn."""
    text = out.decode(errors="replace")
    return [(m.group(1), float(m.group(2)))
            for m in re.finditer(r"(moving|pausing|paused|stopping) +\[[# ]*\] +\d+%  t +"
                                 r"([0-9.]+)/", text)]


def test_space_pauses_and_resumes_a_move_through_a_terminal(pty_pair: Pty,
                                                            tmp_path: Path) -> None:
    before = termios.tcgetattr(pty_pair.slave)
    log = tmp_path / "move.csv"
    proc = subprocess.Popen(
        [sys.executable, "-m", "armctl", "move-joints", "so101", "1.2", "-0.9", "0.9", "0.4",
         "0", "0", "--sim", "--speed", "0.3", "--log", str(log)],
        stdin=pty_pair.slave, stdout=pty_pair.slave, stderr=pty_pair.slave, cwd=tmp_path)
    try:
        out = pty_pair.read(30.0, until=b"moving ")
        assert b"keys: space pause/resume" in out, out[-2000:]
        pty_pair.read(0.3)
        os.write(pty_pair.master, b" ")
        pty_pair.read(5.0, until=b"paused ")
        pty_pair.read(0.8)  # held for a while
        os.write(pty_pair.master, b" ")
        deadline = time.monotonic() + 30.0
        while proc.poll() is None and time.monotonic() < deadline:
            pty_pair.read(0.2)
        pty_pair.read(0.3)
        code = proc.wait(5.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    out = pty_pair.out
    assert code == 0, out[-3000:]
    states = progress_lines(out)
    paused = [t for s, t in states if s == "paused"]
    assert len(paused) >= 5, states
    assert max(paused) - min(paused) < 1e-9  # the plan time stands still while paused
    first_paused = next(i for i, (s, _) in enumerate(states) if s == "paused")
    resumed = [t for s, t in states[first_paused:] if s == "moving"]
    assert resumed and max(resumed) > paused[0] + 0.5  # moving again, further along
    assert b"streamed" in out and b"reached" in out
    # the log: cycles with the plan time and the commands unchanged (the arm held)
    data = np.loadtxt(log, delimiter=",", skiprows=2)
    cmd = data[:, 1::2]
    still = (np.diff(data[:, 0]) == 0) & np.all(np.diff(cmd, axis=0) == 0, axis=1)
    assert int(still.sum()) >= 25  # >= 0.5 s at 50 Hz
    assert np.allclose(cmd[-1, :4], [1.2, -0.9, 0.9, 0.4], atol=1e-6)
    # the terminal is in its own mode again
    after = termios.tcgetattr(pty_pair.slave)
    assert after[3] & _MODE == before[3] & _MODE == _MODE


def test_keys_steer_the_control_and_the_terminal_is_restored(pty_pair: Pty,
                                                             monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    stdin = os.fdopen(os.dup(pty_pair.slave), "r")
    monkeypatch.setattr(sys, "stdin", stdin)
    control = MotionControl()
    try:
        with pytest.raises(RuntimeError, match="boom"):
            with MotionKeys(control, announce=False) as keys:
                assert keys.active
                assert termios.tcgetattr(pty_pair.slave)[3] & _MODE == 0  # cbreak, no echo
                os.write(pty_pair.master, b" ++")
                deadline = time.monotonic() + 3.0
                while control.speed < SPEED_STEP**2 - 1e-9 and time.monotonic() < deadline:
                    time.sleep(0.01)
                assert control.paused
                assert control.speed == pytest.approx(SPEED_STEP**2)
                os.write(pty_pair.master, b"- x")
                deadline = time.monotonic() + 3.0
                while control.paused and time.monotonic() < deadline:
                    time.sleep(0.01)
                assert not control.paused
                assert control.speed == pytest.approx(SPEED_STEP)
                raise RuntimeError("boom")
        assert termios.tcgetattr(pty_pair.slave)[3] & _MODE == _MODE
    finally:
        stdin.close()


def test_slower_keys_stop_at_the_slowest_speed() -> None:
    control = MotionControl()
    keys = MotionKeys(control, enabled=False)
    for _ in range(40):
        keys.handle("-")
    assert control.speed == pytest.approx(0.01)
    keys.handle("?")  # ignored
    assert control.speed == pytest.approx(0.01) and not control.paused


def test_without_a_terminal_no_key_is_read(monkeypatch: pytest.MonkeyPatch) -> None:
    r, w = os.pipe()
    stdin = os.fdopen(r, "r")
    monkeypatch.setattr(sys, "stdin", stdin)
    control = MotionControl()
    try:
        with MotionKeys(control, announce=False) as keys:
            os.write(w, b" +")
            time.sleep(0.2)
            assert not keys.active
        assert not control.paused and control.speed == 1.0
        assert os.read(r, 10) == b" +"  # left for whoever reads stdin
    finally:
        stdin.close()
        os.close(w)
