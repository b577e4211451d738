"""``--port PORT`` and ``--sim`` on the motion commands.

``--port`` is checked against a running ``armctl sim`` in its own process (the config's own port
does not exist, so only the override can reach the servos), and the servos' positions are read
from the simulator itself. ``--sim`` is checked on configs whose port does not exist and on URDF
files without a ``bus:`` section.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from armctl_testpaths import CONFIGS, DATA
from sim_process import SO_JOINTS, SimProcess

from armctl.cli import main
from armctl.servo.sim.bus import SimulatedBus

pytestmark = pytest.mark.timeout(90)

#: One STS3215 tick (4096 per turn) [rad], and a little for the servo's dead band.
TICK = 2 * np.pi / 4096
NO_PORT = "/dev/armctl-test-no-such-port"


def config_with_port(tmp_path: Path, name: str, port: str) -> Path:
    """A copy of a bundled config whose bus port is ``port``."""
    text = (CONFIGS / f"{name}.yaml").read_text(encoding="utf-8")
    assert text.count("port: sim") == 1
    path = tmp_path / f"{name}.yaml"
    path.write_text(text.replace("port: sim", f"port: {port}"), encoding="utf-8")
    return path


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, Any, str]:
    """``armctl ARGV --json``: exit code, the JSON printed, stderr."""
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.strip() else None, err


@pytest.fixture
def sim_process() -> Iterator[SimProcess]:
    s = SimProcess()
    yield s
    s.close()


@pytest.mark.realtime  # the servos run in another process, on the wall clock
def test_port_drives_a_running_armctl_sim(sim_process: SimProcess, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    config = config_with_port(tmp_path, "so101", NO_PORT)
    goal = np.array([0.3, -0.2, 0.25, 0.1, 0.0, 0.2])
    before = sim_process.joints()
    assert np.max(np.abs(before - goal)) > 0.15
    code, data, err = run(capsys, "move-joints", str(config), *map(str, goal), "--port",
                          sim_process.port)
    assert code == 0, err
    assert data["moved"] is True
    assert np.allclose(sim_process.joints(), goal, atol=3 * TICK)
    # The config's own port does not exist: without --port nothing can reach the servos.
    code, data, err = run(capsys, "move-joints", str(config), *map(str, before))
    assert code == 4, err
    assert NO_PORT in data["error"]["message"]
    assert np.allclose(sim_process.joints(), goal, atol=3 * TICK)


@pytest.mark.usefixtures("simulated_time")
def test_sim_replaces_a_port_that_does_not_exist(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    config = config_with_port(tmp_path, "so101", NO_PORT)
    goal = [0.2, 0.1, -0.1, 0.0, 0.3, 0.0]
    code, data, err = run(capsys, "move-joints", str(config), *map(str, goal), "--sim")
    assert code == 0, err
    final = [data["final_joints"][n] for n in SO_JOINTS]
    assert np.allclose(final, goal, atol=3 * TICK)


def started_buses(monkeypatch: pytest.MonkeyPatch) -> list[SimulatedBus]:
    """Every simulated bus started from now on."""
    sims: list[SimulatedBus] = []
    original = SimulatedBus.start

    def start(sim: SimulatedBus) -> str:
        sims.append(sim)
        return original(sim)

    monkeypatch.setattr(SimulatedBus, "start", start)
    return sims


@pytest.mark.usefixtures("simulated_time")
def test_sim_builds_servos_for_a_urdf_without_a_bus(monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    urdf = DATA / "urdf" / "ur5e.urdf"
    assert "<robot" in urdf.read_text(encoding="utf-8")
    sims = started_buses(monkeypatch)
    goal = [0.3, -0.8, 0.9, -0.4, 0.5, -0.2]
    code, data, err = run(capsys, "move-joints", str(urdf), *map(str, goal), "--sim")
    assert code == 0, err
    names = list(data["final_joints"])
    assert len(names) == 6
    assert np.allclose([data["final_joints"][n] for n in names], goal, atol=3 * TICK)
    (sim,) = sims
    assert sorted(s.id for s in sim.servos) == [1, 2, 3, 4, 5, 6]


@pytest.mark.usefixtures("simulated_time")
def test_sim_drives_a_prismatic_urdf_joint(capsys: pytest.CaptureFixture[str]) -> None:
    urdf = DATA / "urdf" / "panda.urdf"
    code, data, err = run(capsys, "info", str(urdf))
    assert code == 0, err
    actuated = data["joints"]
    assert len(actuated) == data["dof"]
    goal = []
    for j in actuated:
        lo, hi = j["lower"], j["upper"]
        goal.append(lo + 0.6 * (hi - lo) if j["type"] == "prismatic" else min(max(0.2, lo), hi))
    prismatic = [i for i, j in enumerate(actuated) if j["type"] == "prismatic"]
    assert prismatic
    code, data, err = run(capsys, "move-joints", str(urdf), *map(str, goal), "--sim")
    assert code == 0, err
    final = [data["final_joints"][j["name"]] for j in actuated]
    for i in prismatic:
        assert abs(final[i] - goal[i]) < 1e-4  # metres: 0.1 mm
    assert np.allclose(final, goal, atol=3 * TICK)


def test_port_on_a_config_without_a_bus_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    urdf = DATA / "urdf" / "ur5e.urdf"
    code, data, err = run(capsys, "move-joints", str(urdf), *["0"] * 6, "--port", "/dev/ttyX")
    assert code == 2, err
    message = data["error"]["message"]
    assert "no 'bus:' section" in message and "--sim" in message and "ur5e" in message


def test_port_and_sim_exclude_each_other(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-joints", "so101", *["0"] * 6, "--sim", "--port", "/dev/ttyX"])
    assert code == 2
    assert "not allowed with argument" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [
    ["move-to-pose", "so101", "--xyz", "0.2", "0", "0.2"],
    ["move-joints", "so101", *["0"] * 6],
    ["home", "so101"], ["park", "so101"],
    ["play", "k.yaml", "so101"],
    ["teach", "so101", "-o", "k.yaml"],
    ["gripper", "so101", "open"],
])
def test_every_motion_verb_takes_port_and_sim(argv: list[str]) -> None:
    from armctl.cli import build_parser

    parser = build_parser()
    for extra in (["--sim"], ["--port", "/dev/ttyX"]):
        args = parser.parse_args([*argv, *extra])
        assert args.sim is (extra == ["--sim"])
        assert args.port == (None if extra == ["--sim"] else "/dev/ttyX")


@pytest.mark.usefixtures("simulated_time")
def test_play_and_gripper_run_on_sim(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    config = config_with_port(tmp_path, "so101", NO_PORT)
    keyframes = tmp_path / "wave.yaml"
    keyframes.write_text("armctl_keyframes: 1\narm: so101\nunits: {angle: deg}\n"
                         "joints: [shoulder_pan]\nkeyframes:\n  - {q: [10]}\n  - {q: [-10]}\n",
                         encoding="utf-8")
    code, data, err = run(capsys, "play", str(keyframes), str(config), "--sim")
    assert code == 0, err
    assert abs(data["final_joints"]["shoulder_pan"] - np.radians(-10)) < 3 * TICK
    code, data, err = run(capsys, "gripper", str(config), "open", "--sim")
    assert code == 0, err
    code, data, err = run(capsys, "play", str(keyframes), str(config))  # the port is missing
    assert code == 4, err
