"""Port I/O errors become bus errors: unplugged adapter, a port in use, a path that is no port."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest
import serial

from armctl.cli import main
from armctl.config import load_spec
from armctl.config.bus import Protocol
from armctl.robot import Robot
from armctl.robot.errors import MotionStopped, StopReason
from armctl.servo import ArmBus, Register, ServoBus, SimServoSpec, SimulatedBus, simulated_bus
from armctl.servo.errors import PortError, PortIOError, PortVanishedError

pytestmark = pytest.mark.timeout(60)
SO_SIM = Path(__file__).parent / "data" / "so_sim.yaml"


def _sim() -> SimulatedBus:
    sim = SimulatedBus([SimServoSpec(1, "sts3215"), SimServoSpec(2, "sts3215")],
                       Protocol.FEETECH)
    sim.start()
    return sim


def test_unplugged_port_is_reported_as_vanished() -> None:
    sim = _sim()
    bus = ServoBus(sim.port, Protocol.FEETECH, models={1: "sts3215", 2: "sts3215"},
                   latency_ms=8.0).open()
    assert bus.read(1, Register.ID) == 1
    sim.unplug()
    for call in (lambda: bus.read(1, Register.PRESENT_POSITION),
                 lambda: bus.read_feedback([1, 2]),
                 lambda: bus.sync_write(Register.GOAL_POSITION, {1: 2000, 2: 2000}),
                 lambda: bus.write(1, Register.TORQUE_ENABLE, 1),
                 lambda: bus.ping(2)):
        with pytest.raises(PortVanishedError) as info:
            call()
        assert str(info.value).startswith(f"port {sim.port} vanished (unplugged?)")
        assert info.value.exit_code == 4
    bus.close()  # closing a vanished port is quiet
    bus.close()


def test_an_io_error_on_a_port_that_still_exists_is_a_bus_error(
        monkeypatch: pytest.MonkeyPatch) -> None:
    sim = _sim()
    try:
        with ServoBus(sim.port, Protocol.FEETECH, models={1: "sts3215"}) as bus:
            def fail(*_: object) -> None:
                raise serial.SerialException(
                    "device reports readiness to read but returned no data (device "
                    "disconnected or multiple access on port?)")
            monkeypatch.setattr(serial.Serial, "write", fail)
            with pytest.raises(PortIOError) as info:
                bus.read(1, Register.ID)
            assert not isinstance(info.value, PortVanishedError)
            assert "multiple access" in str(info.value) and "other program" in str(info.value)
    finally:
        sim.stop()


def test_a_second_opener_finds_the_port_busy() -> None:
    sim = _sim()
    try:
        with ServoBus(sim.port, Protocol.FEETECH):
            with pytest.raises(PortError, match="port busy: in use by another program"):
                ServoBus(sim.port, Protocol.FEETECH).open()
            # another program that locks the port (pyserial exclusive=True) is refused too
            with pytest.raises(serial.SerialException):
                serial.Serial(sim.port, 1_000_000, exclusive=True)
        with serial.Serial(sim.port, 1_000_000, exclusive=True):  # and the other way round
            with pytest.raises(PortError, match="port busy"):
                ServoBus(sim.port, Protocol.FEETECH).open()
        with ServoBus(sim.port, Protocol.FEETECH, models={1: "sts3215"}) as bus:
            assert bus.read(1, Register.ID) == 1  # free again once closed
    finally:
        sim.stop()


@pytest.mark.parametrize("path", ["/dev/null", "regular-file", "directory"])
def test_a_path_that_is_not_a_serial_port(path: str, tmp_path: Path) -> None:
    if path == "regular-file":
        path = str(tmp_path / "port.txt")
        Path(path).write_text("not a port")
    elif path == "directory":
        path = str(tmp_path)
    with pytest.raises(PortError) as info:
        ServoBus(path, Protocol.FEETECH).open()
    text = str(info.value)
    assert "not a serial port" in text and "armctl ports" in text


def test_the_cli_says_what_to_do_for_a_path_that_is_no_port(
        capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["status", str(SO_SIM), "--port", "/dev/null", "--once"])
    err = capsys.readouterr().err
    assert code == 4 and "not a serial port" in err and "armctl ports" in err
    assert "Traceback" not in err


def test_unplugged_mid_motion_stops_with_a_bus_error_not_a_traceback() -> None:
    robot = Robot.open(SO_SIM)
    sim = robot.bus.simulator  # type: ignore[attr-defined]
    assert sim is not None
    port = sim.port
    cycles = []

    def on_cycle(info: object) -> None:
        cycles.append(info)
        if len(cycles) == 8:
            sim.unplug()
    try:
        with pytest.raises(MotionStopped) as info:
            robot.execute(robot.plan_joints(np.array([0.4, 0.3, 0.3, 0.0, 0.0, 0.01]), 1.0),
                          on_cycle=on_cycle)
        assert info.value.reason is StopReason.BUS_IO
        assert f"port {port} vanished (unplugged?)" in str(info.value)
        assert len(cycles) == 8  # the loop ended at the first failed write, no more cycles
    finally:
        robot.close()


def test_unplugged_during_a_cli_move(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                     ) -> None:
    """A standalone simulator that disappears while ``armctl move-joints`` streams to it."""
    spec = load_spec(SO_SIM)
    sim = simulated_bus(spec)
    sim.start()
    cfg = tmp_path / "arm.yaml"
    cfg.write_text(SO_SIM.read_text().replace("port: sim", f"port: {sim.port}"))
    timer = threading.Timer(0.5, sim.unplug)
    timer.start()
    try:
        # (the shoulder leans back: forward, the upper arm would fold into the base)
        code = main(["move-joints", str(cfg), "1.2", "-0.8", "0.8", "0", "0", "0.02",
                     "--speed", "0.3"])
    finally:
        timer.cancel()
        sim.stop()
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert code in (4, 5) and "vanished (unplugged?)" in err


def test_arm_bus_open_on_a_busy_port() -> None:
    spec = load_spec(SO_SIM)
    sim = simulated_bus(spec)
    sim.start()
    try:
        from dataclasses import replace

        assert spec.bus is not None
        other = replace(spec, bus=replace(spec.bus, port=sim.port))
        with ArmBus.from_spec(other) as ab:
            ab.read_joints()
            with pytest.raises(PortError, match="port busy"):
                ArmBus.from_spec(other).open()
    finally:
        sim.stop()
