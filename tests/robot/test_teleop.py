"""Teleoperation on two simulated buses, in simulated time: a hand-guided leader, a follower."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.clock import default_clock
from armctl.config.motion import ExitPolicy
from armctl.errors import ConfigError, InputError, UnknownNameError
from armctl.motion import load_keyframes
from armctl.robot import Robot
from armctl.robot.teleop import (
    JointScale,
    Teleop,
    TeleopCycle,
    TeleopOptions,
    TeleopRecorder,
    load_joint_scales,
    parse_joint_scale,
)
from armctl.servo.sim.bus import SimulatedBus

pytestmark = pytest.mark.timeout(60)

PAIRS = [("so101_leader", "so101"), ("koch_leader", "koch_follower")]


@contextmanager
def pair(leader: str, follower: str) -> Iterator[tuple[Robot, Robot]]:
    """A leader (torque off, not held) and a follower (holding), on their own simulated buses."""
    with Robot.open(leader, hold=False, exit_policy=ExitPolicy.HOLD) as lead, \
            Robot.open(follower, exit_policy=ExitPolicy.HOLD) as fol:
        yield lead, fol


def sim(robot: Robot) -> SimulatedBus:
    s = getattr(robot.bus, "simulator", None)
    assert s is not None
    return s


def guide(lead: Robot, values: dict[str, float]) -> None:
    """Move the leader by hand (its torque is off)."""
    for name, v in values.items():
        sim(lead).set_joint(name, v)


def follower_joints(fol: Robot) -> dict[str, float]:
    return dict(zip(fol.bus.joint_names, fol.bus.read_joints(), strict=True))


@pytest.mark.parametrize(("leader", "follower"), PAIRS)
def test_follower_moves_to_the_leader_then_tracks_it(leader: str, follower: str) -> None:
    with pair(leader, follower) as (lead, fol):
        tele = Teleop(lead, fol, TeleopOptions(rate_hz=100.0, duration=3.0))
        assert set(tele.joints) == set(fol.bus.joint_names)
        lead.bus.set_torque(False)
        start = {"shoulder_pan": 0.4, "shoulder_lift": -0.3, "elbow_flex": 0.5}
        guide(lead, start)
        plan = tele.start()
        assert plan is not None and plan.duration > 0.2  # a planned, modest-speed move
        got = follower_joints(fol)
        for name, v in start.items():
            assert got[name] == pytest.approx(v, abs=0.01)
        # the leader is swept by hand (0.3 rad, 0.5 Hz: up to 0.94 rad/s); the commands follow
        # within two cycles of motion, the measured follower within its servos' own lag
        i = fol.bus.joint_names.index("shoulder_pan")
        cmd_lag: list[float] = []
        meas_lag: list[float] = []

        def cycle(c: TeleopCycle) -> None:
            q = 0.4 + 0.3 * np.sin(2 * np.pi * 0.5 * c.t)
            if c.t > 0.5:
                cmd_lag.append(abs(float(c.command[i]) - float(c.leader[lead_i])))
                meas_lag.append(abs(float(fol.bus.read_joints()[i]) - float(q)))
            sim(lead).set_joint("shoulder_pan", float(q))

        lead_i = lead.bus.joint_names.index("shoulder_pan")
        stats = tele.run(cycle)
        assert stats.cycles >= 299
        assert stats.dropped == 0
        assert not stats.clamped
        assert max(cmd_lag) < 0.94 * 2 / 100 + 1e-3, max(cmd_lag)
        assert max(meas_lag) < 0.15, max(meas_lag)
        assert float(np.median(meas_lag)) < 0.1


def test_target_outside_the_limits_is_clamped_and_reported(
        caplog: pytest.LogCaptureFixture) -> None:
    with pair("so101_leader", "so101") as (lead, fol):
        tele = Teleop(lead, fol, TeleopOptions(duration=1.0))
        lead.bus.set_torque(False)
        # the shoulder leans back, so that the elbow at its upper limit folds the forearm over
        # the base, not into the table
        guide(lead, {"shoulder_lift": -1.3})
        tele.start()
        j = fol.bus.joint_names.index("elbow_flex")
        # the leader's elbow is pushed past the follower's effective upper limit, via the scale
        tele2 = Teleop(lead, fol, TeleopOptions(duration=1.0, scales={
            "elbow_flex": JointScale(1.0, float(tele.upper[j]) + 0.3)}))
        caplog.set_level(logging.INFO, "armctl.robot.teleop")
        tele2.start()
        sent: list[float] = []
        stats = tele2.run(lambda c: sent.append(float(c.command[j])))
        assert stats.clamped.get("elbow_flex", 0) >= stats.cycles - 1
        assert max(sent) <= tele2.upper[j] + 1e-12  # never beyond the limit
        assert sent[-1] == pytest.approx(tele2.upper[j], abs=1e-6)
        warnings = [r for r in caplog.records if "elbow_flex" in r.getMessage()
                    and "clamped" in r.getMessage()]
        assert len(warnings) == 1  # logged once per joint, counted every cycle


def test_a_leader_jump_is_rate_limited() -> None:
    with pair("so101_leader", "so101") as (lead, fol):
        tele = Teleop(lead, fol, TeleopOptions(rate_hz=100.0, duration=1.5))
        lead.bus.set_torque(False)
        tele.start()
        j = fol.bus.joint_names.index("shoulder_pan")
        vmax = float(tele.velocity[j])
        amax = float(tele.acceleration[j])
        q0 = float(tele.target(tele.read_leader())[j])
        sim(lead).set_joint("shoulder_pan", q0 + 1.0)  # a 1 rad jump in one cycle
        cmds: list[float] = []
        targets: list[float] = []

        def cycle(c: TeleopCycle) -> None:
            cmds.append(float(c.command[j]))
            targets.append(float(c.target[j]))

        stats = tele.run(cycle)
        steps = np.diff([q0, *cmds]) * 100.0  # commanded velocity [rad/s]
        assert stats.rate_limited.get("shoulder_pan", 0) > 10
        assert np.max(np.abs(steps)) <= vmax + 1e-9
        assert np.max(np.abs(np.diff(steps))) * 100.0 <= amax * 1.0001
        assert cmds[0] - q0 < 0.05  # no raw jump
        assert targets[-1] == pytest.approx(q0 + 1.0, abs=0.002)  # one leader tick
        assert cmds[-1] == pytest.approx(targets[-1], abs=1e-9)  # and it gets there


def test_a_pair_without_common_joints_is_a_clear_error() -> None:
    with Robot.open("so101_leader", hold=False) as lead, \
            Robot.open("omx", exit_policy=ExitPolicy.HOLD) as fol:
        common = set(lead.bus.joint_names) & set(fol.bus.joint_names)
        if common:  # the arms share joint names: make a follower without them
            pytest.fail(f"test premise: so101_leader and omx share {common}")
        with pytest.raises(InputError, match=r"share no joint.*so101_leader -> so101"):
            Teleop(lead, fol)


def test_scales_name_shared_joints_and_parse() -> None:
    assert parse_joint_scale("gripper=1.5") == ("gripper", JointScale(1.5, 0.0))
    assert parse_joint_scale("wrist_roll=-1:0.1") == ("wrist_roll", JointScale(-1.0, 0.1))
    for bad in ("gripper", "gripper=x", "=1", "g=1:2:3", "g=nan"):
        with pytest.raises(InputError):
            parse_joint_scale(bad)
    with pair("so101_leader", "so101") as (lead, fol), \
            pytest.raises(UnknownNameError, match="gripperr"):
        Teleop(lead, fol, TeleopOptions(scales={"gripperr": JointScale(2.0)}))


def test_scale_file_errors_name_file_and_key(tmp_path: Path) -> None:
    good = tmp_path / "map.yaml"
    good.write_text("gripper: {scale: 1.5}\nwrist_roll: {offset: 0.1}\n")
    assert load_joint_scales(good) == {"gripper": JointScale(1.5, 0.0),
                                       "wrist_roll": JointScale(1.0, 0.1)}
    bad = tmp_path / "bad.yaml"
    bad.write_text("gripper: {scale: fast}\n")
    with pytest.raises(ConfigError, match=r"bad\.yaml.*gripper"):
        load_joint_scales(bad)


def test_scale_and_offset_apply() -> None:
    with pair("so101_leader", "so101") as (lead, fol):
        tele = Teleop(lead, fol, TeleopOptions(scales={"wrist_roll": JointScale(-0.5, 0.2)}))
        lead.bus.set_torque(False)
        guide(lead, {"wrist_roll": 0.6})
        t = tele.target(tele.read_leader())
        j = fol.bus.joint_names.index("wrist_roll")
        assert t[j] == pytest.approx(-0.5 * 0.6 + 0.2, abs=0.003)  # one tick of the leader


def test_stop_request_decelerates_and_holds() -> None:
    with pair("so101_leader", "so101") as (lead, fol):
        tele = Teleop(lead, fol, TeleopOptions(duration=5.0))
        lead.bus.set_torque(False)
        tele.start()
        j = fol.bus.joint_names.index("shoulder_pan")
        q0 = float(tele.target(tele.read_leader())[j])
        sim(lead).set_joint("shoulder_pan", q0 + 1.5)
        clock = default_clock()

        def cycle(c: TeleopCycle) -> None:
            if c.t >= 0.2:
                tele.stop.request("test stop")

        t_start = clock.now()
        stats = tele.run(cycle)
        assert stats.stopped_by == "test stop"
        assert clock.now() - t_start < 2.0
        held = float(fol.bus.read_joints()[j])
        # moving at speed when stopped: it decelerated past the stop point, short of the goal
        assert q0 + 0.1 < held < q0 + 1.5 - 0.1
        assert all(s.torque for s in sim(fol).servos)  # holds with torque on
        later = float(fol.bus.read_joints()[j])
        assert later == pytest.approx(held, abs=0.01)


def test_recording_keyframes_and_a_trajectory_plays_back(tmp_path: Path) -> None:
    keys = tmp_path / "keys.yaml"
    traj = tmp_path / "traj.yaml"
    with pair("so101_leader", "so101") as (lead, fol):
        lead.bus.set_torque(False)
        rec = TeleopRecorder(fol, keys)
        rec_t = TeleopRecorder(fol, traj, period=0.05)
        poses = [{"shoulder_pan": 0.3, "elbow_flex": 0.4}, {"shoulder_pan": -0.2,
                                                            "elbow_flex": 0.1}]
        tele = Teleop(lead, fol, TeleopOptions(duration=2.0), rec)
        tele.start()

        def cycle(c: TeleopCycle) -> None:
            if abs(c.t - 0.01) < 1e-6:
                guide(lead, poses[0])
            if abs(c.t - 0.8) < 1e-6:
                rec.mark("a")
                guide(lead, poses[1])
            if abs(c.t - 1.9) < 1e-6:
                rec.mark("b")

        tele.run(cycle)
        with pytest.raises(InputError, match="exists already"):
            TeleopRecorder(fol, keys)
        tele_t = Teleop(lead, fol, TeleopOptions(duration=1.5), rec_t)
        tele_t.start()
        tele_t.run(lambda c: guide(lead, {"wrist_flex": 0.25 * (1 - np.cos(np.pi * min(c.t, 1)))}))
        end_wrist = float(fol.bus.read_joints()[fol.bus.joint_names.index("wrist_flex")])

    arm = load_arm("so101")
    prog = load_keyframes(keys, arm)
    assert [k.name for k in prog.keyframes] == ["a", "b"]
    timed = load_keyframes(traj, arm)
    assert timed.timed and len(timed.keyframes) >= 19
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD) as robot:
        for prog_, want in ((prog, poses[1]), (timed, None)):
            robot.play(prog_)
            got = follower_joints(robot)
            if want is not None:
                for name, v in want.items():
                    assert got[name] == pytest.approx(v, abs=0.02)
            else:
                assert got["wrist_flex"] == pytest.approx(end_wrist, abs=0.03)


def test_docs_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                           capsys: pytest.CaptureFixture[str]) -> None:
    import re

    doc = Path(__file__).parent.parent.parent / "docs" / "motion.md"
    found = re.search(r"^## Teleoperation\n.*?^```python\n(.*?)^```",
                      doc.read_text(encoding="utf-8"), re.S | re.M)
    assert found, "no python block under '## Teleoperation' in docs/motion.md"
    monkeypatch.chdir(tmp_path)
    scope: dict[str, object] = {}
    exec(compile(found.group(1), str(doc), "exec"), scope)
    stats = scope["stats"]
    assert stats.cycles >= 500  # type: ignore[attr-defined]
    assert capsys.readouterr().out.startswith("100.")  # the achieved rate was printed
    prog = load_keyframes(tmp_path / "teleop.yaml", load_arm("so101"))
    assert prog.timed and len(prog.keyframes) >= 100


def test_a_lost_leader_stops_the_follower_under_control() -> None:
    from armctl.errors import BusError
    from armctl.servo.sim.faults import MissingServo

    with pair("so101_leader", "so101") as (lead, fol):
        tele = Teleop(lead, fol, TeleopOptions(duration=5.0))
        lead.bus.set_torque(False)
        tele.start()
        j = fol.bus.joint_names.index("shoulder_pan")
        q0 = float(tele.target(tele.read_leader())[j])
        sim(lead).set_joint("shoulder_pan", q0 + 1.5)
        cmds: list[float] = []

        def cycle(c: TeleopCycle) -> None:
            cmds.append(float(c.command[j]))
            if len(cmds) == 20:  # moving at speed: the leader's cable comes loose
                sim(lead).inject(MissingServo(1))

        with pytest.raises(BusError):
            tele.run(cycle)
        assert tele.stop.reason.startswith("the leader's bus failed")
        held = float(fol.bus.read_joints()[j])
        # it decelerated beyond the last command (no hold at once), short of the leader's goal
        assert cmds[-1] + 0.05 < held < q0 + 1.5
        assert all(s.torque for s in sim(fol).servos)


def test_a_follower_joint_without_a_leader_joint_holds(tmp_path: Path) -> None:
    from armctl_testpaths import CONFIGS

    text = (CONFIGS / "so101_leader.yaml").read_text(encoding="utf-8")
    line = "    gripper: {id: 6, model: sts3215}         # 1/147\n"
    assert text.count(line) == 1
    no_grip = tmp_path / "leader_no_gripper.yaml"
    no_grip.write_text(text.replace(line, ""), encoding="utf-8")
    with Robot.open(no_grip, hold=False, exit_policy=ExitPolicy.HOLD) as lead, \
            Robot.open("so101", exit_policy=ExitPolicy.HOLD) as fol:
        tele = Teleop(lead, fol, TeleopOptions(duration=0.5))
        assert tele.unpaired == ("gripper",)
        assert "gripper" not in tele.joints
        g = fol.bus.joint_names.index("gripper")
        before = float(fol.bus.read_joints()[g])
        lead.bus.set_torque(False)
        guide(lead, {"shoulder_pan": 0.3})
        tele.start()
        sent: list[float] = []
        tele.run(lambda c: sent.append(float(c.command[g])))
        assert max(abs(v - before) for v in sent) < 1e-9  # held, never moved
        pan = fol.bus.joint_names.index("shoulder_pan")
        assert float(fol.bus.read_joints()[pan]) == pytest.approx(0.3, abs=0.01)


def test_a_second_stop_request_holds_at_once() -> None:
    with pair("so101_leader", "so101") as (lead, fol):
        tele = Teleop(lead, fol, TeleopOptions(duration=5.0))
        lead.bus.set_torque(False)
        tele.start()
        j = fol.bus.joint_names.index("shoulder_pan")
        q0 = float(tele.target(tele.read_leader())[j])
        sim(lead).set_joint("shoulder_pan", q0 + 1.5)
        cmds: list[float] = []

        def cycle(c: TeleopCycle) -> None:
            cmds.append(float(c.command[j]))
            if c.t >= 0.2:
                tele.stop.request("first")
                tele.stop.request("second")

        tele.run(cycle)
        goal = fol.executor.last_command
        assert goal is not None
        # held at the reading when the second request came: behind the last command, not
        # decelerated past it as a controlled stop would be
        assert float(goal[j]) <= cmds[-1] + 1e-9
        assert all(s.torque for s in sim(fol).servos)


def test_a_sampled_recording_keeps_the_grippers_moves(tmp_path: Path) -> None:
    """Gripper changes become the program's gripper events; a still gripper adds no stops."""
    traj = tmp_path / "traj.yaml"
    with pair("so101_leader", "so101") as (lead, fol):
        lead.bus.set_torque(False)
        rec = TeleopRecorder(fol, traj, period=0.05)
        tele = Teleop(lead, fol, TeleopOptions(duration=1.5), rec)
        tele.start()
        tele.run(lambda c: guide(lead, {"gripper": 0.45 if c.t > 0.5 else 0.0}))
    timed = load_keyframes(traj, load_arm("so101"))
    grips = [k.gripper for k in timed.keyframes if k.gripper is not None]
    assert len(timed.keyframes) >= 25
    assert 2 <= len(grips) < len(timed.keyframes) // 2  # the start value and the change
    assert grips[-1] == pytest.approx(0.45, abs=0.04)  # within one event step (2 % of range)
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD) as robot:
        robot.play(timed)
        assert follower_joints(robot)["gripper"] == pytest.approx(grips[-1], abs=0.02)


def test_an_existing_recording_is_refused_naming_only_force(tmp_path: Path) -> None:
    out = tmp_path / "rec.yaml"
    out.write_text("keep me\n")
    with pair("so101_leader", "so101") as (_, fol), \
            pytest.raises(InputError, match="exists already") as info:
        TeleopRecorder(fol, out)
    assert "--force" in str(info.value) and "--append" not in str(info.value)
    assert out.read_text() == "keep me\n"
