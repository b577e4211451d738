"""``armctl teleop LEADER FOLLOWER`` in process, on the built-in simulated buses, simulated time."""

from __future__ import annotations

import json
import re
from collections.abc import Iterator
from pathlib import Path

import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.clock import SimulatedClock
from armctl.motion import load_keyframes

pytestmark = pytest.mark.timeout(60)


@pytest.fixture(autouse=True)
def _simulated(simulated_time: SimulatedClock | None) -> Iterator[None]:
    yield


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(["teleop", *argv])
    out, err = capsys.readouterr()
    return code, out, err


@pytest.mark.parametrize(("leader", "follower"), [("so101_leader", "so101"),
                                                  ("koch_leader", "koch_follower")])
def test_bundled_pairs_follow_and_report_json(capsys: pytest.CaptureFixture[str], leader: str,
                                              follower: str) -> None:
    code, out, err = run(capsys, leader, follower, "--duration", "0.5", "--json")
    assert code == 0, err
    data = json.loads(out)
    assert data["ok"] is True and data["command"] == "teleop"
    body = data
    assert body["leader"] == leader and body["follower"] == follower
    assert "shoulder_pan" in body["joints"] and not body["unpaired"]
    assert body["cycles"] >= 50 and body["dropped_cycles"] == 0
    assert body["rate_hz"] == 100.0


def test_scale_option_clamps_and_says_so(capsys: pytest.CaptureFixture[str]) -> None:
    # the follower's shoulder leans back (an offset inside its limits), so that the elbow at its
    # clamped upper limit folds the forearm over the base, not into the table
    code, out, err = run(capsys, "so101_leader", "so101", "--duration", "0.3",
                         "--scale", "elbow_flex=1:5", "--scale", "shoulder_lift=1:-1.3")
    assert code == 0, err
    assert "clamped to the effective limits (cycles): elbow_flex" in out
    assert "clamped" in err  # the warning, once


@pytest.mark.parametrize(("argv", "message"), [
    (["--scale", "elbow=2"], "elbow_flex"),
    (["--scale", "elbow_flex"], "JOINT=SCALE"),
    (["--every", "20"], "--every needs --record"),
    (["--rate", "0"], "--rate"),
    (["--leader-port", "/dev/armctl-x", "--follower-port", "/dev/armctl-x"], "need a bus each"),
])
def test_bad_options_are_one_clear_error(capsys: pytest.CaptureFixture[str], argv: list[str],
                                         message: str) -> None:
    code, _, err = run(capsys, "so101_leader", "so101", "--duration", "0.1", *argv)
    assert code != 0
    assert message in err


def test_no_common_joints(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "so101_leader", "omx", "--duration", "0.1")
    assert code != 0
    assert "share no joint" in err


def test_record_a_trajectory_then_play_it(capsys: pytest.CaptureFixture[str],
                                          tmp_path: Path) -> None:
    out_file = tmp_path / "teleop.yaml"
    code, out, err = run(capsys, "so101_leader", "so101", "--duration", "0.5", "--record",
                         str(out_file), "--every", "50")
    assert code == 0, err
    prog = load_keyframes(out_file, load_arm("so101"))
    assert prog.timed and len(prog.keyframes) >= 10
    # no silent overwrite
    code, _, err = run(capsys, "so101_leader", "so101", "--duration", "0.1", "--record",
                       str(out_file), "--every", "50")
    assert code != 0 and "exists already" in err
    code, out, err = run(capsys, "so101_leader", "so101", "--duration", "0.1", "--record",
                         str(out_file), "--every", "50", "--force")
    assert code == 0, err
    code = main(["play", str(out_file), "so101", "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert json.loads(out)["ok"] is True


@pytest.mark.realtime
def test_ctrl_c_stops_under_control_and_exits_0() -> None:
    import os
    import signal
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-m", "armctl", "teleop", "so101_leader", "so101"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    assert proc.stderr is not None
    said = ""
    deadline = time.monotonic() + 40
    while "following at" not in said:
        line = proc.stderr.readline()
        assert line and time.monotonic() < deadline, said
        said += line
    time.sleep(0.3)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert "cut short" not in err and "Traceback" not in err
    assert "the follower holds (torque on)" in out
    assert re.search(r"\d+ cycles in [\d.]+ s \(\d+\.\d Hz, \d+ dropped\)", out), out


def test_enter_records_named_keyframes(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    import io
    import sys

    monkeypatch.setattr(sys, "stdin", io.StringIO("first\n\nlast\n"))
    out_file = tmp_path / "keys.yaml"
    code, out, err = run(capsys, "so101_leader", "so101", "--duration", "2", "--record",
                         str(out_file))
    assert code == 0, err
    assert "press Enter to record a keyframe" in err
    prog = load_keyframes(out_file, load_arm("so101"))
    assert [k.name for k in prog.keyframes] == ["first", "", "last"]
    assert not prog.timed and all(k.gripper is not None for k in prog.keyframes)
    assert f"3 keyframes in {out_file}" in out


@pytest.mark.realtime
def test_two_sim_processes_on_their_ports(capsys: pytest.CaptureFixture[str]) -> None:
    """Each arm as ``armctl sim`` in its own process; the follower ends at the leader's pose."""
    import os
    import subprocess
    import sys

    procs: list[subprocess.Popen[str]] = []

    def start(config: str) -> tuple[subprocess.Popen[str], str]:
        proc = subprocess.Popen([sys.executable, "-m", "armctl", "sim", config, "--json"],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                                env=dict(os.environ, PYTHONUNBUFFERED="1"))
        procs.append(proc)
        assert proc.stdout is not None
        head = ""
        while not head.rstrip().endswith("}"):
            line = proc.stdout.readline()
            assert line, f"armctl sim {config} ended before it printed its port"
            head += line
        return proc, json.loads(head)["port"]

    def console(proc: subprocess.Popen[str], line: str, replies: int) -> list[str]:
        assert proc.stdin is not None and proc.stdout is not None
        proc.stdin.write(line + "\n")
        proc.stdin.flush()
        return [proc.stdout.readline() for _ in range(replies)]

    try:
        (lead, lead_port), (fol, fol_port) = start("so101_leader"), start("so101")
        console(lead, "set shoulder_pan 0.5", 1)
        console(lead, "set elbow_flex 0.7", 1)
        code = main(["teleop", "so101_leader", "so101", "--leader-port", lead_port,
                     "--follower-port", fol_port, "--duration", "0.5", "--json"])
        out, err = capsys.readouterr()
        assert code == 0, err
        data = json.loads(out)
        assert data["cycles"] >= 45 and data["dropped_cycles"] <= 2
        got = {}
        for line in console(fol, "get", 6):
            m = re.match(r"(\w+) \(id \d+\): (\S+)", line)
            assert m is not None, line
            got[m.group(1)] = float(m.group(2))
        assert got["shoulder_pan"] == pytest.approx(0.5, abs=0.02)
        assert got["elbow_flex"] == pytest.approx(0.7, abs=0.02)
    finally:
        for proc in procs:
            proc.kill()
            proc.wait(10)
