"""The exit policy on the command line: never after a dry run, and a park pose checked first.

A dry run (and ``play --preview``, which is one) writes nothing to the servos, whatever
``--exit-policy`` says. ``--exit-policy park`` is refused before the bus opens for an arm
without a park pose or with one outside the config's limits, and right after it opens (before
anything moves) for one outside the effective limits.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from armctl_testpaths import REPO

from armctl.cli import main
from armctl.servo import Register
from armctl.servo.sim.bus import SimulatedBus
from armctl.servo_tables import table_for

pytestmark = [pytest.mark.timeout(60), pytest.mark.usefixtures("simulated_time")]

SO_SIM = REPO / "tests" / "servo" / "data" / "so_sim.yaml"
STS = table_for("sts3215")
#: Addresses whose writes move or release a servo: goal position and torque enable.
COMMANDS = {STS.spec(Register.GOAL_POSITION).address, STS.spec(Register.TORQUE_ENABLE).address}
#: Feetech WRITE, REG_WRITE and SYNC_WRITE: the address is their first parameter.
WRITES = (0x03, 0x04, 0x83)


class Started:
    """Every simulated bus started from now on, each with a trace of what it received."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch, narrow: tuple[int, int] | None = None):
        self.sims: list[SimulatedBus] = []
        self.traces: list[list[tuple[str, bytes]]] = []
        original = SimulatedBus.start

        def start(sim: SimulatedBus) -> str:
            port = original(sim)
            if narrow is not None:  # a servo's Max Angle Limit register, set by its owner
                sim.servo(narrow[0]).set(Register.MAX_POSITION_LIMIT, narrow[1])
            self.sims.append(sim)
            self.traces.append(sim.start_trace())
            return port

        monkeypatch.setattr(SimulatedBus, "start", start)

    def commands(self) -> list[int]:
        """Addresses of the goal and torque writes received by the (one) simulated bus."""
        (trace,) = self.traces
        return [pkt[5] for direction, pkt in trace
                if direction == "rx" and pkt[4] in WRITES and pkt[5] in COMMANDS]


@pytest.mark.parametrize("policy", ["park", "release"])
def test_a_dry_run_writes_nothing_whatever_the_exit_policy(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], policy: str) -> None:
    started = Started(monkeypatch)
    code = main(["move-joints", "so101", "0", "0.5", "0", "0", "0", "0", "--dry-run",
                 "--exit-policy", policy])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert started.commands() == []  # no goal, no torque on (park) or off (release)
    assert "dry run: nothing moved" in out
    assert f"--exit-policy {policy} not applied" in err
    (sim,) = started.sims
    assert not any(s.torque for s in sim.servos)
    assert all(s.get(Register.GOAL_POSITION) == 0 for s in sim.servos)


def test_play_preview_is_a_dry_run(monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    keyframes = tmp_path / "wave.yaml"
    keyframes.write_text("armctl_keyframes: 1\narm: so101\nunits: {angle: deg}\n"
                         "joints: [shoulder_pan]\nkeyframes:\n  - {q: [10]}\n  - {q: [-10]}\n",
                         encoding="utf-8")
    started = Started(monkeypatch)
    code = main(["play", str(keyframes), "so101", "--preview", str(tmp_path / "plan.png"),
                 "--exit-policy", "park"])
    err = capsys.readouterr().err
    assert code == 0, err
    assert started.commands() == []
    assert "--exit-policy park not applied" in err


def _with_park(tmp_path: Path, park: str) -> Path:
    """A copy of the simulated test arm with a 'park' pose (a flow mapping of joint values)."""
    config = tmp_path / "so_sim.yaml"
    config.write_text(SO_SIM.read_text(encoding="utf-8") + f"poses:\n  park: {park}\n",
                      encoding="utf-8")
    return config


PARK_OUTSIDE_CONFIG = ("{shoulder_pan: 0, shoulder_lift: 0, elbow_flex: 1.65, wrist_flex: 0, "
                       "wrist_roll: 0, gripper: 0}")
PARK_BEYOND_REGISTER = ("{shoulder_pan: 0, shoulder_lift: 0, elbow_flex: 0.5, wrist_flex: 0, "
                        "wrist_roll: 0, gripper: 0}")


@pytest.mark.parametrize(("park", "expected"), [
    (None, "has no 'park' pose"),
    (PARK_OUTSIDE_CONFIG, "elbow_flex"),
], ids=["no park pose", "outside the config"])
def test_park_is_checked_before_the_bus_opens(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        park: str | None, expected: str) -> None:
    config = SO_SIM if park is None else _with_park(tmp_path, park)
    started = Started(monkeypatch)
    code = main(["move-joints", str(config), "0.1", "0", "0", "0", "0", "0",
                 "--exit-policy", "park"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert expected in err and "Traceback" not in err
    assert started.sims == []  # the bus was not opened


def test_park_beyond_the_effective_limits_is_refused_before_anything_moves(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    config = _with_park(tmp_path, PARK_BEYOND_REGISTER)
    # elbow_flex (servo 3, offset 0.1 rad) may go to 0.3 rad by its own Max Angle Limit
    from armctl.config import load_spec
    from armctl.servo import JointMapping

    elbow = JointMapping.from_spec(load_spec(config)).joint("elbow_flex")
    started = Started(monkeypatch, narrow=(3, round(elbow.to_ticks(0.3))))
    code = main(["move-joints", str(config), "0.1", "0", "0", "0", "0", "0",
                 "--exit-policy", "park"])
    err = capsys.readouterr().err
    assert started.commands() == []  # the move did not start
    assert code == 2, err
    assert "'park' pose of --exit-policy park" in err and "Max Angle Limit" in err
    (sim,) = started.sims
    assert not any(s.torque for s in sim.servos)
