"""The bus commands, on the simulated bus."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from armctl.cli import main
from armctl.config.bus import Protocol
from armctl.servo import Calibration, Register, ServoBus, SimServoSpec, SimulatedBus

pytestmark = pytest.mark.timeout(30)
DATA = Path(__file__).parent / "data"


def _json(capsys: pytest.CaptureFixture[str]) -> dict:
    return json.loads(capsys.readouterr().out)


def test_status_once_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["status", str(DATA / "dxl_sim.yaml"), "--once", "--json"]) == 0
    out = _json(capsys)
    assert out["ok"] and [j["joint"] for j in out["joints"]] == ["j1", "j2", "j3", "j4"]
    j2 = out["joints"][1]
    assert j2["id"] == 12 and j2["position"] == pytest.approx(0.2, abs=2e-3)
    assert j2["voltage"] == pytest.approx(11.1) and j2["errors"] == []


def test_status_table_and_torque(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["status", str(DATA / "so_sim.yaml"), "--once", "--deg"]) == 0
    text = capsys.readouterr().out
    assert "shoulder_pan" in text and "angle [deg]" in text
    assert main(["torque", str(DATA / "so_sim.yaml"), "on", "gripper", "--json"]) == 0
    assert _json(capsys)["torque"] == {"gripper": True}
    assert main(["torque", str(DATA / "so_sim.yaml"), "on", "nope"]) == 2
    assert "unknown servo joint 'nope'" in capsys.readouterr().err


def test_scan_finds_servos(capsys: pytest.CaptureFixture[str]) -> None:
    sim = SimulatedBus([SimServoSpec(3, "sts3215"), SimServoSpec(7, "sts3215")],
                       Protocol.FEETECH)
    with sim:
        assert main(["scan", "--port", sim.port, "--protocol", "feetech", "--json"]) == 0
    out = _json(capsys)
    assert [(s["id"], s["model"], s["baudrate"]) for s in out["servos"]] == [
        (3, "sts3215", 1_000_000), (7, "sts3215", 1_000_000)]


def test_missing_port_is_exit_code_4(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["scan", "--port", "/dev/armctl-no-such-port", "--protocol", "feetech"]) == 4
    assert "no such port" in capsys.readouterr().err


def test_calibrate_without_motion_is_refused(capsys: pytest.CaptureFixture[str],
                                             monkeypatch: pytest.MonkeyPatch,
                                             tmp_path: Path) -> None:
    import armctl.cli._calibrate_wizard as wizard

    monkeypatch.setattr(wizard, "wait_enter", lambda prompt, step=None, period=0.0: (
        step() if step else None))
    code = main(["calibrate", str(DATA / "so_sim.yaml"), "-o", str(tmp_path / "c.yaml")])
    assert code == 2
    assert "moved only 0 ticks" in capsys.readouterr().err
    assert not (tmp_path / "c.yaml").exists()


def test_sim_standalone_serves_other_programs() -> None:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "armctl", "sim", str(DATA / "so_sim.yaml"),
                             "--json"], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            text=True, env=env)
    try:
        assert proc.stdout is not None and proc.stdin is not None
        head = ""
        while not head.rstrip().endswith("}"):
            head += proc.stdout.readline()
        info = json.loads(head)
        port = info["port"]
        with ServoBus(port, Protocol.FEETECH, info["baudrate"], models={3: "sts3215"},
                      latency_ms=16.0) as bus:
            assert bus.ping(3).model == "sts3215"
            proc.stdin.write("set elbow_flex 0.6\n")
            proc.stdin.flush()
            assert proc.stdout.readline().strip() == "ok"
            ticks = bus.read(3, Register.PRESENT_POSITION)
        assert ticks == round(2048 + (0.6 - 0.1) * 4096 / (2 * 3.141592653589793))
        proc.stdin.write("quit\n")
        proc.stdin.flush()
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def _start_sim(config: Path) -> tuple[subprocess.Popen[str], dict]:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "armctl", "sim", str(config), "--json"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
    assert proc.stdout is not None
    head = ""
    while not head.rstrip().endswith("}"):
        head += proc.stdout.readline()
    return proc, json.loads(head)


def test_calibrate_against_standalone_sim(tmp_path: Path) -> None:
    """The teaching flow: 'armctl sim' in one terminal, 'armctl calibrate --port' in another."""
    config = tmp_path / "arm.yaml"
    config.write_text((DATA / "so_sim.yaml").read_text())
    sim, info = _start_sim(config)
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    cal = subprocess.Popen([sys.executable, "-m", "armctl", "calibrate", str(config), "--port",
                            info["port"], "--json"], stdin=subprocess.PIPE,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    assert sim.stdin is not None and sim.stdout is not None and cal.stdin is not None

    def hand(sid: int, ticks: int) -> None:
        sim.stdin.write(f"ticks {sid} {ticks % 4096}\n")  # type: ignore[union-attr]
        sim.stdin.flush()  # type: ignore[union-attr]
        assert sim.stdout.readline().strip() == "ok"  # type: ignore[union-attr]

    try:
        ref = {1: 3900, 2: 1000, 3: 2048, 4: 2500, 5: 2048, 6: 1000}
        for sid, t in ref.items():
            hand(sid, t)
        assert cal.stdout is not None
        assert "reference pose" in cal.stdout.readline()  # torque is off, waiting for Enter
        cal.stdin.write("\n")
        cal.stdin.flush()
        assert "full range" in cal.stdout.readline()  # sampling until the next Enter
        for sid, r in ref.items():
            for t in (r - 800, r, r + 800, r):
                hand(sid, t)
                time.sleep(0.03)
        cal.stdin.write("\n")
        cal.stdin.flush()
        out, err = cal.communicate(timeout=20)
        assert cal.returncode == 0, err
        result = json.loads(out)
        pan = result["joints"]["shoulder_pan"]
        assert pan["wrap_detected"] and pan["max_tick"] - pan["min_tick"] == 1600
        assert not result["joints"]["elbow_flex"]["wrap_detected"]
        written = Calibration.load(tmp_path / "arm.calibration.yaml")
        assert written.hash == result["hash"]
    finally:
        for p in (cal, sim):
            if p.poll() is None:
                p.kill()
                p.wait()


def test_scan_all_baud_rates_finds_the_servo_at_its_rate(
        capsys: pytest.CaptureFixture[str]) -> None:
    sim = SimulatedBus([SimServoSpec(4, "sts3215")], Protocol.FEETECH, 250_000)
    with sim:
        assert main(["scan", "--port", sim.port, "--protocol", "feetech", "--baud", "all",
                     "--json"]) == 0
    out = _json(capsys)
    assert [(s["id"], s["baudrate"]) for s in out["servos"]] == [(4, 250_000)]


def test_status_live_table_stops_on_ctrl_c(capsys: pytest.CaptureFixture[str],
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    import armctl.cli.bus as cli_bus

    calls = []

    def fake_sleep(seconds: float) -> None:
        calls.append(seconds)
        if len(calls) == 2:
            raise KeyboardInterrupt

    monkeypatch.setattr(cli_bus.time, "sleep", fake_sleep)
    assert main(["status", str(DATA / "so_sim.yaml"), "--interval", "0.5"]) == 130
    out, err = capsys.readouterr()
    assert "armctl: interrupted by SIGINT" in err and "Traceback" not in err
    frames = out.split("\x1b[H\x1b[2J")[1:]  # each refresh clears the screen first
    assert len(frames) == 2 and "Ctrl-C" in out and calls == [0.5, 0.5]
    assert all("shoulder_pan" in f and "effective" in f for f in frames)


def test_torque_suggests_the_nearest_joint(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["torque", str(DATA / "so_sim.yaml"), "off", "elbw"]) == 2
    err = capsys.readouterr().err
    assert "unknown servo joint 'elbw'" in err and "did you mean 'elbow_flex'?" in err
    assert "'shoulder_pan'" in err  # the valid names are listed


def test_scan_without_answers_exits_4(capsys: pytest.CaptureFixture[str]) -> None:
    sim = SimulatedBus([SimServoSpec(3, "sts3215")], Protocol.FEETECH)
    with sim:
        code = main(["scan", "--port", sim.port, "--protocol", "feetech", "--baud", "500000"])
    assert code == 4
    err = capsys.readouterr().err
    assert f"no servos answered on {sim.port} at 500000 bit/s (feetech)" in err
    assert "(check power, wiring, baud rate, protocol)" in err


def test_scan_reads_the_firmware_version(capsys: pytest.CaptureFixture[str]) -> None:
    sim = SimulatedBus([SimServoSpec(3, "sts3215")], Protocol.FEETECH)
    with sim:
        servo = sim.servo(3)
        expected = f"{servo.get(Register.FIRMWARE)}.{servo.get(Register.FIRMWARE_MINOR)}"
        assert main(["scan", "--port", sim.port, "--protocol", "feetech", "--json"]) == 0
        assert _json(capsys)["servos"][0]["firmware"] == expected
        assert main(["scan", "--port", sim.port, "--protocol", "feetech"]) == 0
    text = capsys.readouterr().out
    assert "firmware" in text and expected in text


def test_unknown_servo_model_names_file_key_and_line(capsys: pytest.CaptureFixture[str],
                                                     tmp_path: Path) -> None:
    text = (DATA / "so_sim.yaml").read_text()
    lines = text.splitlines()
    row = next(i for i, t in enumerate(lines) if t.strip().startswith("elbow_flex: {id: 3"))
    lines[row] = lines[row].replace("sts3215", "sts3251")
    cfg = tmp_path / "arm.yaml"
    cfg.write_text("\n".join(lines) + "\n")
    assert main(["status", str(cfg), "--once"]) == 2
    err = capsys.readouterr().err
    assert f"{cfg}:{row + 1}: bus.servos.elbow_flex.model: unknown servo model 'sts3251'" in err
    assert "did you mean 'sts3215'?" in err


def test_servo_model_of_the_wrong_family_is_a_config_error(
        capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    cfg = tmp_path / "arm.yaml"
    cfg.write_text((DATA / "so_sim.yaml").read_text().replace(
        "wrist_flex: {id: 4, model: sts3215}", "wrist_flex: {id: 4, model: xl430-w250}"))
    assert main(["status", str(cfg), "--once"]) == 2
    err = capsys.readouterr().err
    assert "bus.servos.wrist_flex.model: 'xl430-w250' is a dynamixel servo" in err
