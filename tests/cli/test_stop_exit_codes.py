"""Stop signals on the command line: exit codes, where the arm stopped, hold instead of park.

The subprocess tests run ``armctl move-joints`` against ``armctl sim`` (the simulated bus on a
pty, in its own process) and read the servos from the simulator after the command has ended.
The in-process tests place a signal at an exact moment (after the stop, after a finished motion,
before the motion), with handlers of their own that fail the test if a signal escaped armctl.
"""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from armctl_testpaths import CONFIGS
from sim_process import SimProcess

import armctl.cli._motion_report as motion_report
from armctl.arm import load_arm
from armctl.cli import main
from armctl.cli._progress import Progress
from armctl.config.motion import ExitPolicy
from armctl.robot import Robot

pytestmark = pytest.mark.timeout(90)

GOAL = [1.2, -0.9, 0.9, 0.4, 0.0, 0.0]
JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")
ENV = dict(os.environ, PYTHONUNBUFFERED="1")


class Sim(SimProcess):
    """``armctl sim so101`` in a subprocess, and an arm config that points at its pty."""

    def __init__(self, tmp_path: Path):
        super().__init__()
        text = (CONFIGS / "so101.yaml").read_text(encoding="utf-8")
        assert text.count("port: sim") == 1
        self.config = tmp_path / "so101.yaml"
        self.config.write_text(text.replace("port: sim", f"port: {self.port}"), encoding="utf-8")


@pytest.fixture
def sim(tmp_path: Path) -> Iterator[Sim]:
    s = Sim(tmp_path)
    yield s
    s.close()


def start_moving(sim: Sim, *extra: str) -> subprocess.Popen[str]:
    """``armctl move-joints`` towards GOAL with --exit-policy park; returns once the arm moves."""
    proc = subprocess.Popen([sys.executable, "-m", "armctl", "move-joints", str(sim.config),
                             *map(str, GOAL), "--exit-policy", "park", *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    deadline = time.monotonic() + 60
    while sim.joints()[0] < 0.15:  # shoulder_pan on its way to 1.2 rad
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "the arm did not start moving"
        time.sleep(0.01)
    return proc


def stopped_table(out: str) -> np.ndarray:
    """The joints of the 'stopped ... the arm holds here' table, in rad."""
    head = out.index("the arm holds here")
    rows = out[head:].splitlines()[3:3 + len(JOINTS)]
    got = {}
    for row in rows:
        name, value, unit = row.split()
        assert unit == "deg"
        got[name] = np.radians(float(value))
    return np.array([got[n] for n in JOINTS])


def check_holds(sim: Sim, stopped: np.ndarray) -> None:
    """After the command: the arm is where the output says, stays there, and did not park."""
    arm = load_arm("so101")
    at_exit = sim.joints()
    assert np.allclose(at_exit, stopped, atol=0.012)  # the report is in 0.01 deg
    time.sleep(0.3)
    assert np.allclose(sim.joints(), at_exit, atol=2e-3)  # holding still
    assert np.max(np.abs(at_exit - arm.named_pose("park"))) > 0.3  # not parked
    assert np.max(np.abs(at_exit - np.array(GOAL))) > 0.1  # stopped part-way


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_a_signal_mid_motion_stops_reports_and_holds(sim: Sim, sig: str) -> None:
    proc = start_moving(sim)
    proc.send_signal(getattr(signal, sig))
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 5, err
    assert "Traceback" not in err
    assert f"stopped by {'Ctrl-C (SIGINT)' if sig == 'SIGINT' else sig}" in err
    assert "decelerated and holds its position" in err
    assert "exit policy 'park' not applied" in err
    assert re.search(r"tool xyz \[.*\] m, rpy \[.*\] deg", out)
    check_holds(sim, stopped_table(out))


def test_json_says_where_the_arm_stopped(sim: Sim) -> None:
    proc = start_moving(sim, "--json")
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 5, err
    data = json.loads(out)
    assert data["ok"] is False and data["error"]["exit_code"] == 5
    details = data["error"]["details"]
    assert details["reason"] == "user" and details["signal"] == "SIGTERM"
    where = details["stopped_at"]
    stopped = np.array([where["joints"][n] for n in JOINTS])
    arm = load_arm("so101")
    pose = arm.fk(stopped)
    assert np.allclose(where["xyz"], pose[:3, 3], atol=1e-9)
    assert len(where["rpy"]) == 3
    check_holds(sim, stopped)


def test_a_second_signal_during_the_deceleration_holds_at_once(sim: Sim) -> None:
    proc = start_moving(sim)
    proc.send_signal(signal.SIGINT)
    time.sleep(0.04)  # the controlled stop takes about 0.3 s at this speed
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 5, err
    assert "held it at once at its present position" in err
    check_holds(sim, stopped_table(out))


# ---- in-process: signals at exact moments -----------------------------------------------------
class Escaped(Exception):
    """A signal reached the test's own handler: armctl did not handle it."""


@pytest.fixture
def own_handlers() -> Iterator[None]:
    """Handlers that fail the test if a signal gets past armctl (instead of killing pytest)."""

    def escaped(signum: int, frame: Any) -> None:
        raise Escaped(signal.Signals(signum).name)

    saved = {s: signal.signal(s, escaped) for s in (signal.SIGTERM, signal.SIGHUP)}
    yield
    for s, h in saved.items():
        signal.signal(s, h)


def stop_at(t_stop: float, monkeypatch: pytest.MonkeyPatch, sig: int = signal.SIGINT) -> None:
    """Send ``sig`` to this process once the motion has run ``t_stop`` seconds."""
    sent: list[float] = []

    def progress(self: Any, info: Any) -> None:
        if info.t >= t_stop and not sent:
            sent.append(info.t)
            os.kill(os.getpid(), sig)

    monkeypatch.setattr(Progress, "__call__", progress)


def record_close(monkeypatch: pytest.MonkeyPatch, signum: int | None = None) -> list[Any]:
    """Record the policy every Robot.close gets (and the simulator), sending ``signum`` first."""
    seen: list[Any] = []
    original = Robot.close

    def close(self: Robot, policy: ExitPolicy | None = None) -> None:
        seen.append((policy, self.bus.simulator))
        if signum is not None:
            os.kill(os.getpid(), signum)
        original(self, policy)

    monkeypatch.setattr(Robot, "close", close)
    return seen


def check_held_at_the_goal(seen: list[Any], goal: list[float]) -> None:
    """The bus closed once, holding (not parked), with the arm at ``goal``."""
    (policy, sim), = seen
    assert policy is ExitPolicy.HOLD
    q = sim.joint_positions()
    assert np.allclose([q[n] for n in JOINTS], goal, atol=0.02)  # at the goal, not parked


@pytest.mark.usefixtures("own_handlers")
@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM"])
def test_a_signal_after_the_stop_keeps_the_stops_exit_code(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], name: str) -> None:
    late = getattr(signal, name)
    stop_at(0.3, monkeypatch)
    original_text = motion_report.stop_text

    def report(robot: Any, stopped: Any) -> str:  # while the report is printed
        os.kill(os.getpid(), late)
        return original_text(robot, stopped)

    monkeypatch.setattr(motion_report, "stop_text", report)
    seen = record_close(monkeypatch, late)  # and while the bus closes
    code = main(["move-joints", "so101", *map(str, GOAL), "--exit-policy", "park"])
    out, err = capsys.readouterr()
    assert code == 5, err
    assert "the arm holds here" in out
    assert f"{name} received while finishing: ignored" in err
    assert [p for p, _ in seen] == [ExitPolicy.HOLD]


@pytest.mark.usefixtures("own_handlers")
def test_a_signal_after_a_finished_motion_exits_5_and_skips_the_exit_policy(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """The arm has moved: 5 (it holds), not 143, which says that nothing moved."""
    goal = [0.2, -0.2, 0.2, 0.0, 0.0, 0.0]
    done = Progress.done

    def finished(self: Any) -> None:  # the motion has ended; the exit policy is next
        os.kill(os.getpid(), signal.SIGTERM)
        done(self)

    monkeypatch.setattr(Progress, "done", finished)
    seen = record_close(monkeypatch)
    code = main(["move-joints", "so101", *map(str, goal), "--exit-policy", "park", "--json"])
    out, err = capsys.readouterr()
    assert code == 5, err
    assert json.loads(out)["ok"] is True  # the report of the finished move is complete
    assert "SIGTERM after the motion had finished" in err
    assert "exit policy 'park' not applied" in err
    check_held_at_the_goal(seen, goal)


@pytest.mark.usefixtures("own_handlers")
@pytest.mark.parametrize(("name", "code"), [("SIGINT", 130), ("SIGTERM", 143), ("SIGHUP", 129)])
def test_a_signal_before_the_motion_moves_nothing(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], name: str,
        code: int) -> None:
    sig = getattr(signal, name)
    original = Robot.plan_joints

    def planning(self: Robot, *args: Any, **kwargs: Any) -> Any:
        os.kill(os.getpid(), sig)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Robot, "plan_joints", planning)
    seen = record_close(monkeypatch)
    assert main(["move-joints", "so101", *map(str, GOAL), "--exit-policy", "park"]) == code
    err = capsys.readouterr().err
    assert f"interrupted by {name}; nothing moved" in err
    (policy, sim), = seen
    assert policy is ExitPolicy.HOLD
    q = sim.joint_positions()
    assert np.allclose([q[n] for n in JOINTS], 0.0, atol=1e-3)  # still at its start


@pytest.mark.usefixtures("own_handlers")
def test_signal_handlers_are_restored_after_a_command(capsys: pytest.CaptureFixture[str]) -> None:
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    assert main(["move-joints", "so101", "0.1", "0", "0", "0", "0", "0"]) == 0
    assert {s: signal.getsignal(s) for s in before} == before
    capsys.readouterr()


# ---- a signal as the motion reaches its goal --------------------------------------------------
@pytest.mark.usefixtures("own_handlers")
def test_a_signal_in_the_last_cycle_holds_at_the_goal_and_exits_5(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    goal = [0.2, -0.2, 0.2, 0.0, 0.0, 0.0]

    def progress(self: Any, info: Any) -> None:
        if info.t >= info.duration:  # the last cycle
            os.kill(os.getpid(), signal.SIGTERM)

    monkeypatch.setattr(Progress, "__call__", progress)
    seen = record_close(monkeypatch)
    code = main(["move-joints", "so101", *map(str, goal), "--exit-policy", "park"])
    out, err = capsys.readouterr()
    assert code == 5, err
    assert "stopped by SIGTERM as the motion reached its goal; the arm holds there" in err
    assert "the arm holds here" in out  # where it stopped, as for any stop
    assert "exit policy 'park' not applied" in err
    check_held_at_the_goal(seen, goal)


@pytest.mark.usefixtures("own_handlers")
def test_a_signal_while_the_servos_settle_holds_and_exits_5(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.robot import Executor

    goal = [0.2, -0.2, 0.2, 0.0, 0.0, 0.0]
    original = Executor._settle
    sent: list[int] = []

    def settle(self: Executor, *args: Any, **kwargs: Any) -> Any:
        if not sent:  # the end of the motion: the servos settle at the goal
            sent.append(signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Executor, "_settle", settle)
    seen = record_close(monkeypatch)
    code = main(["move-joints", "so101", *map(str, goal), "--exit-policy", "park", "--json"])
    out, err = capsys.readouterr()
    assert sent and code == 5, err
    error = json.loads(out)["error"]
    assert error["details"]["reason"] == "user" and error["details"]["signal"] == "SIGINT"
    assert "reached its goal" in error["message"]
    check_held_at_the_goal(seen, goal)


@pytest.mark.usefixtures("own_handlers")
def test_a_signal_after_a_dry_run_gives_128_plus_its_number(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """Nothing moved: the signal's own code, as before a motion."""
    done = Progress.done

    def finished(self: Any) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        done(self)

    monkeypatch.setattr(Progress, "done", finished)
    code = main(["move-joints", "so101", *map(str, GOAL), "--dry-run"])
    err = capsys.readouterr().err
    assert code == 143, err
    assert "interrupted by SIGTERM; nothing moved" in err
