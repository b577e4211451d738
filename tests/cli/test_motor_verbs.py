"""``armctl reboot``, ``armctl setup-motors`` and the tool pose of ``armctl status``, on the
simulated bus."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import REPO

from armctl.cli import main
from armctl.cli import motors as motors_cli
from armctl.config import load_spec
from armctl.config.bus import Protocol
from armctl.kinematics.model import KinematicModel
from armctl.servo import Alarm, HardwareAlarm, Register, SimServoSpec, SimulatedBus, simulated_bus
from armctl.servo.sim.servo import SimServo
from armctl.spatial import rpy_to_matrix

pytestmark = pytest.mark.timeout(60)
SO_SIM = REPO / "tests" / "servo" / "data" / "so_sim.yaml"
NAMES = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")


def _json(capsys: pytest.CaptureFixture[str]) -> dict:
    return json.loads(capsys.readouterr().out)


def _config(tmp_path: Path, port: str, baudrate: int = 1_000_000) -> Path:
    cfg = tmp_path / "arm.yaml"
    cfg.write_text(SO_SIM.read_text().replace("port: sim", f"port: {port}")
                   .replace("baudrate: 1000000", f"baudrate: {baudrate}"))
    return cfg


# ---- status: tool pose ---------------------------------------------------------------------------
def test_status_shows_the_tool_pose_of_the_read_joints(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["status", str(SO_SIM), "--once", "--json"]) == 0
    out = _json(capsys)
    q = [j["position"] for j in out["joints"]]
    tool = out["tool"]
    assert tool["frame"] == "tip"
    pose = KinematicModel(load_spec(SO_SIM)).fk(q)
    np.testing.assert_allclose(tool["xyz"], pose[:3, 3], atol=1e-9)
    np.testing.assert_allclose(rpy_to_matrix(tool["rpy"]), pose[:3, :3], atol=1e-9)
    # by hand: every joint near zero, the links lie along x (0.11 + 0.13 + 0.05 + 0.05) 0.05 up
    np.testing.assert_allclose(tool["xyz"], [0.34, 0.0, 0.05], atol=2e-3)
    assert main(["status", str(SO_SIM), "--once"]) == 0
    text = capsys.readouterr().out
    line = next(s for s in text.splitlines() if s.startswith("tool 'tip'"))
    assert "xyz [m] 0.34" in line and "rpy [deg]" in line
    assert f"{math.degrees(tool['rpy'][1]):.2f}" in line


def test_status_has_no_tool_pose_when_a_joint_before_the_tool_has_no_servo(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    cfg = tmp_path / "arm.yaml"  # the gripper carries the tip frame; here it has no servo
    text = SO_SIM.read_text()
    line = next(s for s in text.splitlines() if s.strip().startswith("gripper: {id: 6"))
    cfg.write_text(text.replace(line + "\n", ""))
    assert main(["status", str(cfg), "--once", "--json"]) == 0
    out = _json(capsys)
    assert [j["joint"] for j in out["joints"]] == list(NAMES[:-1]) and out["tool"] is None


# ---- reboot --------------------------------------------------------------------------------------
def test_reboot_clears_a_latched_alarm_and_leaves_torque_off(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sim = simulated_bus(load_spec(SO_SIM))
    sim.start()
    try:
        cfg = _config(tmp_path, sim.port)
        sim.servo(2).set(Register.TORQUE_ENABLE, 1)
        sim.inject(HardwareAlarm(3, Alarm.OVERHEATING))
        assert sim.servo(3).alarm_bits != 0
        assert main(["reboot", str(cfg), "elbow_flex", "shoulder_lift", "--json"]) == 0
        out = _json(capsys)
        assert out["rebooted"] == ["elbow_flex", "shoulder_lift"]
        assert out["alarms_before"]["elbow_flex"] == ["overheating"]
        assert out["alarms_cleared"] == {"elbow_flex": ["overheating"], "shoulder_lift": []}
        assert out["alarms_after"] == {"elbow_flex": [], "shoulder_lift": []}
        assert out["torque"] == {"elbow_flex": False, "shoulder_lift": False}
        assert sim.servo(3).alarm_bits == 0 and not sim.servo(2).torque
        assert main(["reboot", str(cfg)]) == 0
        text = capsys.readouterr().out
        assert "torque is off" in text and all(n in text for n in NAMES)
    finally:
        sim.stop()


def test_reboot_refuses_an_unknown_joint(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["reboot", str(SO_SIM), "elbow"]) == 2
    assert "unknown servo joint 'elbow'" in capsys.readouterr().err


# ---- setup-motors --------------------------------------------------------------------------------
def _factory_servo() -> SimServo:
    """A new STS3215 as it leaves the factory: id 1 at 1 Mbit/s."""
    return SimulatedBus([SimServoSpec(1, "sts3215")], Protocol.FEETECH).servos[0]


def test_setup_motors_gives_each_servo_its_id_and_baud(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    pool = [_factory_servo() for _ in NAMES]
    sim = SimulatedBus([], Protocol.FEETECH)
    prompts: list[str] = []

    def connect_next(prompt: str) -> None:
        prompts.append(prompt)
        sim.servos[:] = [pool[len(prompts) - 1]]  # the user swaps in the next new servo

    monkeypatch.setattr(motors_cli, "wait_enter", connect_next)
    sim.start()
    try:
        cfg = _config(tmp_path, sim.port, 500_000)
        assert main(["setup-motors", str(cfg), "--json"]) == 0
    finally:
        sim.stop()
    out = _json(capsys)
    assert [(s["joint"], s["from_id"], s["id"], s["baudrate"]) for s in out["servos"]] == [
        (n, 1, NAMES.index(n) + 1, 500_000) for n in reversed(NAMES)]
    assert {s["from_baudrate"] for s in out["servos"]} == {1_000_000}  # found at the factory rate
    # the gripper (last joint) first
    assert [p.split("'")[1] for p in prompts] == list(reversed(NAMES))
    for servo, name in zip(pool, reversed(NAMES), strict=True):
        assert servo.id == NAMES.index(name) + 1, name
        assert servo.baudrate == 500_000, name
        assert servo.get(Register.LOCK) == 1, name  # EEPROM locked again
        assert not servo.torque


_DXL_ARM = """armctl: 1
name: one_dxl
base: base
tool: tip
joints:
  - name: j1
    type: revolute
    parent: base
    child: l1
    axis: [0, 0, 1]
    limits: {lower: -1, upper: 1}
frames:
  - {name: tip, parent: l1, origin: {xyz: [0.1, 0, 0]}}
bus:
  port: PORT
  protocol: dynamixel
  baudrate: 1000000
  servos:
    j1: {id: 5, model: MODEL}
"""


def _dxl_setup(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, present: str,
               wanted: str) -> tuple[int, SimServo]:
    # ROBOTIS e-Manual, X-series control tables: ID default 1, Baud Rate default 1 (57600 bps)
    sim = SimulatedBus([SimServoSpec(1, present)], Protocol.DYNAMIXEL, 57_600)
    monkeypatch.setattr(motors_cli, "wait_enter", lambda prompt: None)
    sim.start()
    try:
        cfg = tmp_path / "dxl.yaml"
        cfg.write_text(_DXL_ARM.replace("PORT", sim.port).replace("MODEL", wanted))
        return main(["setup-motors", str(cfg), "--json"]), sim.servos[0]
    finally:
        sim.stop()


def test_setup_motors_on_dynamixel_from_the_factory_rate(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    code, servo = _dxl_setup(tmp_path, monkeypatch, "xl330-m288", "xl330-m288")
    assert code == 0
    out = _json(capsys)
    assert out["servos"] == [{"joint": "j1", "from_id": 1, "from_baudrate": 57_600, "id": 5,
                              "baudrate": 1_000_000}]
    assert (servo.id, servo.baudrate) == (5, 1_000_000)


def test_setup_motors_refuses_a_servo_of_another_model(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    code, servo = _dxl_setup(tmp_path, monkeypatch, "xl430-w250", "xl330-m288")
    assert code == 4
    err = capsys.readouterr().err
    assert "xl430-w250" in err and "xl330-m288" in err
    assert (servo.id, servo.baudrate) == (1, 57_600)  # nothing written


def test_setup_motors_refuses_two_servos_and_writes_nothing(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    sim = SimulatedBus([SimServoSpec(1, "sts3215"), SimServoSpec(7, "sts3215")], Protocol.FEETECH)
    monkeypatch.setattr(motors_cli, "wait_enter", lambda prompt: None)
    sim.start()
    try:
        trace = sim.start_trace()
        cfg = _config(tmp_path, sim.port, 500_000)
        assert main(["setup-motors", str(cfg)]) == 2
        err = capsys.readouterr().err
        assert "2 servos answer" in err and "disconnect all but" in err
        assert "nothing was written" in err
        writes = [p for d, p in trace if d == "rx" and p[4] in (0x03, 0x04, 0x83)]
        assert writes == []
        assert [s.id for s in sim.servos] == [1, 7]
        assert all(s.baudrate == 1_000_000 for s in sim.servos)
    finally:
        sim.stop()


def test_setup_motors_refuses_the_built_in_simulator(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["setup-motors", str(SO_SIM)]) == 2
    assert "--port" in capsys.readouterr().err
