"""``armctl sim`` commands: every bad line is an error line and the simulator goes on."""

from __future__ import annotations

import os
import select
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from armctl.config import load_spec
from armctl.servo import (
    CorruptedReply,
    DroppedReply,
    LatencySpike,
    LateReply,
    MissingServo,
    Register,
    ServoBus,
    SimulatedBus,
    simulated_bus,
)
from armctl.servo.sim.console import SimConsole, parse_fault

pytestmark = pytest.mark.timeout(60)

BAD_LINES = [
    # the line of the report: a state fault given a count
    "fault missing_servo 4 2", "fault hardware_alarm 3 5", "fault lockup_after_overload 2 1",
    # unknown commands and kinds
    "hello", "faults please", "fault", "fault bogus 3", "fault dropped 3", "FAULT",
    # wrong number of words
    "set", "set elbow_flex", "set elbow_flex 1 deg extra", "ticks", "ticks 3",
    "ticks 3 100 200", "get now", "clear 1 2", "quit now", "fault dropped_reply",
    "fault dropped_reply 3 2 4",
    # words that are not numbers (or not finite)
    "set elbow_flex abc", "set elbow_flex nan", "set elbow_flex inf deg", "set elbow_flex 1 rad",
    "ticks x 100", "ticks 3 1.5", "ticks 3 abc", "fault dropped_reply x",
    "fault dropped_reply 3 many", "fault dropped_reply 3 0", "fault dropped_reply 3 -1",
    "fault late_reply 3 delay=abc", "fault late_reply 3 delay=-0.1", "fault late_reply 3 delay=",
    "fault dropped_reply 3 every=0", "fault dropped_reply 3 every=x", "clear x",
    "fault wrong_model 3 model=70000", "fault truncated_reply 3 keep=-1",
    # unknown servos and joints
    "fault dropped_reply 99", "fault missing_servo 300", "ticks 99 100", "clear 42",
    "set no_such_joint 0.1",
    # parameters a fault does not take
    "fault missing_servo 4 delay=0.1", "fault dropped_reply 3 alarm=overload",
    "fault hardware_alarm 3 alarm=fire", "fault dropped_reply 3 delay",
    "fault latency_spike every=2 bogus=1",
]


@pytest.fixture
def sim() -> Iterator[SimulatedBus]:
    with simulated_bus(load_spec("so101")) as bus:
        yield bus


def _ping(sim: SimulatedBus, sid: int = 1) -> int:
    assert sim.mapping is not None
    with ServoBus(sim.port, sim.protocol, sim.baudrate, models={sid: "sts3215"},
                  latency_ms=8.0) as bus:
        return bus.ping(sid).model_number


def test_every_bad_line_is_an_error_line(sim: SimulatedBus) -> None:
    console = SimConsole(sim)
    for line in BAD_LINES:
        reply = console.execute(line)
        assert not reply.ok and not reply.quit, line
        assert reply.text.startswith("error: ") and "\n" not in reply.text.strip(), line
        assert "Traceback" not in reply.text
    assert sim.faults == ()  # nothing half-applied
    assert _ping(sim) == 777  # and the simulator still answers


def test_good_lines(sim: SimulatedBus) -> None:
    console = SimConsole(sim)
    assert console.execute("fault late_reply 3 forever delay=0.06 every=2").ok
    assert console.execute("fault latency_spike 5 delay=0.05").ok
    assert console.execute("fault dropped_reply 2").ok
    assert console.execute("fault missing_servo 4").ok
    assert set(sim.faults) == {LateReply(3, None, 0.06, 2), LatencySpike(5, 0.05),
                               DroppedReply(2), MissingServo(4)}
    assert "LateReply" in console.execute("faults").text
    assert console.execute("clear 4").ok and MissingServo(4) not in sim.faults
    assert console.execute("clear").ok and sim.faults == ()
    assert console.execute("set elbow_flex 10 deg").ok
    assert "elbow_flex (id 3): 0.17" in console.execute("get").text  # 10 deg, to a tick
    assert console.execute("ticks 1 2100").ok and sim.positions[1] == 2100
    assert "commands:" in console.execute("help").text
    assert console.execute("  ").text == ""
    assert console.execute("quit").quit


def test_parse_fault_builds_every_kind() -> None:
    assert parse_fault(["dropped_reply", "3", "forever", "every=2"]) == \
        DroppedReply(3, None, every=2)
    assert parse_fault(["latency_spike", "always", "delay=0.05"]) == LatencySpike(None, 0.05)
    assert parse_fault(["late_reply", "1", "3", "delay=0.02"]) == LateReply(1, 3, 0.02)


def _read_line(proc: subprocess.Popen[str], timeout: float = 20.0) -> str:
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], timeout)
    assert ready, "the simulator printed nothing"
    return proc.stdout.readline()


def test_armctl_sim_survives_bad_stdin_lines() -> None:
    proc = subprocess.Popen([sys.executable, "-m", "armctl", "sim", "so101"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    try:
        assert proc.stdin is not None
        banner = _read_line(proc)
        port = banner.split(" on ")[1].split(" at ")[0]
        assert os.path.exists(port)
        bad = ["fault missing_servo 4 2", "fault bogus 1", "ticks 3", "set elbow_flex x",
               "fault dropped_reply 99"]
        for line in bad:
            proc.stdin.write(line + "\n")
            proc.stdin.flush()
            assert _read_line(proc).startswith("error: "), line
        assert proc.poll() is None and os.path.exists(port)
        proc.stdin.write("fault late_reply 1 2 delay=0.04\n")
        proc.stdin.flush()
        assert _read_line(proc).strip() == "ok"
        time.sleep(0.05)
        with ServoBus(port, load_spec("so101").bus.protocol,  # type: ignore[union-attr]
                      models={1: "sts3215"}, retries=4, latency_ms=8.0) as bus:
            assert bus.ping(1).model_number == 777  # still answering (after the late ones)
            assert bus.read(1, Register.ID) == 1
        proc.stdin.write("quit\n")
        proc.stdin.flush()
        assert proc.wait(timeout=10) == 0
        assert "Traceback" not in (proc.stderr.read() if proc.stderr else "")
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_scenario_file_takes_every(tmp_path: Path) -> None:
    from armctl.servo.sim.scenario import load_scenario

    f = tmp_path / "s.yaml"
    f.write_text("faults:\n  - {kind: corrupted_reply, servo: 2, count: null, every: 3}\n"
                 "  - {kind: late_reply, servo: 1, delay: 0.06, count: null}\n")
    assert [fault for _, fault in load_scenario(f)] == [CorruptedReply(2, None, every=3),
                                                        LateReply(1, None, 0.06)]
