"""Retries are counted per servo and reported: an intermittent fault never ends in silence."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest

from armctl.cli import main
from armctl.config import load_spec
from armctl.config.bus import Protocol
from armctl.robot import Robot
from armctl.robot.executor import RETRY_WARNING_MIN
from armctl.servo import (
    CorruptedReply,
    DroppedReply,
    ServoBus,
    SimServoSpec,
    SimulatedBus,
    TruncatedReply,
    simulated_bus,
)

pytestmark = pytest.mark.timeout(60)
SO_SIM = Path(__file__).parent / "data" / "so_sim.yaml"
GOAL = np.array([0.3, 0.2, 0.2, 0.0, 0.0, 0.01])


@pytest.mark.parametrize("fault", [DroppedReply(2, count=None, every=2),
                                   CorruptedReply(2, count=None, every=2),
                                   TruncatedReply(2, count=None, every=2)],
                         ids=["dropped", "corrupt", "truncated"])
@pytest.mark.parametrize("protocol", [Protocol.FEETECH, Protocol.DYNAMIXEL],
                         ids=["feetech", "dynamixel"])
def test_every_other_reply_failing_is_counted_per_servo(protocol: Protocol,
                                                        fault: object) -> None:
    model = "sts3215" if protocol is Protocol.FEETECH else "xl430-w250"
    sim = SimulatedBus([SimServoSpec(i, model) for i in (1, 2, 3)], protocol)
    sim.start()
    bus = ServoBus(sim.port, protocol, models={i: model for i in (1, 2, 3)}, latency_ms=8.0)
    bus.open()
    try:
        sim.servo(2).set_present_position(1500)
        sim.inject(fault)  # type: ignore[arg-type]
        for _ in range(10):  # each read: the first attempt fails, the retry succeeds
            assert bus.read_feedback([1, 2, 3])[2].position == 1500
        # at least one per read for the faulty servo (a loaded computer can add timeouts)
        assert bus.retry_counts().get(2, 0) >= 10
    finally:
        bus.close()
        sim.stop()


def test_a_motion_reports_its_retries_and_warns(caplog: pytest.LogCaptureFixture) -> None:
    with Robot.open(SO_SIM) as robot:
        sim = robot.bus.simulator  # type: ignore[attr-defined]
        assert sim is not None
        sim.inject(DroppedReply(3, count=None, every=2))
        with caplog.at_level(logging.WARNING, logger="armctl.robot.executor"):
            report = robot.move_joints(GOAL, speed=1.0)
        assert report.result is not None
        stats = report.result.stats
        assert stats.retries.get(3, 0) >= stats.cycles
        warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
        assert any("servo 3 (joint 'elbow_flex')" in w and "retries" in w for w in warnings)
        # the built-in simulator has no cable to check: the warning says what it can be
        assert any("no hardware is involved" in w for w in warnings)
        assert not any("cable" in w for w in warnings)


def test_a_few_retries_are_reported_without_a_warning(caplog: pytest.LogCaptureFixture
                                                      ) -> None:
    with Robot.open(SO_SIM) as robot:
        sim = robot.bus.simulator  # type: ignore[attr-defined]
        assert sim is not None
        cycles: list[object] = []

        def on_cycle(info: object) -> None:  # a few dropped replies during the motion
            cycles.append(info)
            if len(cycles) == 1:
                sim.inject(DroppedReply(4, count=RETRY_WARNING_MIN - 1))
        with caplog.at_level(logging.WARNING, logger="armctl.robot.executor"):
            result = robot.execute(robot.plan_joints(GOAL, 1.0), on_cycle=on_cycle)
        assert result.stats.retries.get(4, 0) >= RETRY_WARNING_MIN - 1
        assert not [r for r in caplog.records if "servo 4" in r.getMessage()]
        before = robot.bus.retry_counts().get(4, 0)  # type: ignore[attr-defined]
        report = robot.move_joints(np.zeros(6), speed=1.0)  # counted per motion
        after = robot.bus.retry_counts().get(4, 0)  # type: ignore[attr-defined]
        assert report.result is not None
        assert report.result.stats.retries.get(4, 0) == after - before  # not the earlier ones


def test_cli_prints_and_returns_the_retries(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    sim = simulated_bus(load_spec(SO_SIM))
    sim.start()
    try:
        cfg = tmp_path / "arm.yaml"
        cfg.write_text(SO_SIM.read_text().replace("port: sim", f"port: {sim.port}"))
        sim.inject(CorruptedReply(2, count=None, every=2))
        code = main(["move-joints", str(cfg), "0.2", "0.1", "0.1", "0", "0", "0", "--json"])
        captured = capsys.readouterr()
        data = json.loads(captured.out)
        assert "check its cable" in captured.err  # a port: it may be real hardware
        assert code == 0 and data["moved"]
        (entry,) = data["bus_retries"]
        assert entry["servo_id"] == 2 and entry["joint"] == "shoulder_lift"
        assert entry["count"] >= 10
        code = main(["move-joints", str(cfg), "0", "0", "0", "0", "0", "0"])
        out = capsys.readouterr().out
        assert code == 0
        line = next(ln for ln in out.splitlines() if ln.startswith("bus retries"))
        assert "servo 2 (shoulder_lift)" in line
        sim.clear_faults()
        code = main(["move-joints", str(cfg), "0.1", "0", "0", "0", "0", "0", "--json"])
        assert code == 0
        counts = {e["servo_id"]: e["count"] for e in json.loads(capsys.readouterr().out)[
            "bus_retries"]}
        assert counts.get(2, 0) < 10  # the fault is gone (a loaded computer may add a few)
    finally:
        sim.stop()


def test_counts_start_at_zero_when_the_bus_opens() -> None:
    with SimulatedBus([SimServoSpec(1, "sts3215")], Protocol.FEETECH) as sim:
        sim.inject(DroppedReply(1))
        with ServoBus(sim.port, Protocol.FEETECH, models={1: "sts3215"}, latency_ms=8.0) as bus:
            bus.ping(1)
            assert bus.retry_counts().get(1, 0) >= 1
        bus.open()
        assert bus.retry_counts() == {}
        bus.close()
