"""Effective limits: config, calibration and servo registers, on a simulated arm calibrated
narrower than its config; and arrival: a move succeeds only when every joint got there."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import REPO

from armctl.arm import load_arm
from armctl.cli import main
from armctl.config import load_spec
from armctl.config.motion import ExitPolicy
from armctl.errors import JointLimitError
from armctl.ik import PositionGoal
from armctl.robot import MotionStopped, Robot, StopReason
from armctl.servo import ArmBus, Calibration, Calibrator, JointMapping, Obstacle, Register
from armctl.servo.effective_limits import (
    MARGIN_TICKS,
    LimitSource,
    PositionLimitRegisters,
    effective_limits,
)
from armctl.servo.sim.bus import SimulatedBus

pytestmark = pytest.mark.timeout(60)

SO_SIM = REPO / "tests" / "servo" / "data" / "so_sim.yaml"
TICK = 2 * math.pi / 4096
#: Sweep per joint during the simulated calibration, in joint units either side of zero:
#: +-652 ticks (+-1.00016 rad) for most joints, wider than the config for elbow_flex (+-1.6).
SWEEP = {"shoulder_pan": 1.0, "shoulder_lift": 1.0, "elbow_flex": 1.7, "wrist_flex": 1.0,
         "wrist_roll": 1.0}
CAL_HALF = 652 * TICK  # 1.00016 rad
MARGIN = MARGIN_TICKS * TICK


def _calibrate(config: Path) -> Calibration:
    """Calibrate the simulated arm as a user would: reference at zero, then a sweep per joint."""
    spec = load_spec(config)
    with ArmBus.from_spec(spec) as ab:
        sim = ab.simulator
        assert sim is not None
        cal = Calibrator(ab)
        cal.start()
        ref = cal.capture_reference()
        for j in ab.mapping.joints:
            r = ref[j.name]
            k = abs(j.to_ticks(1.0) - j.to_ticks(0.0))  # ticks per joint unit
            if j.name == "gripper":
                lo, hi = r, r + round(0.03 * k)  # the gripper closes at 0, opens to 30 mm
            else:
                lo, hi = r - round(SWEEP[j.name] * k), r + round(SWEEP[j.name] * k)
            path = [*range(r, lo - 1, -300), *range(lo, hi + 1, 300), hi,
                    *range(hi, r - 1, -300), r]
            for t in path:
                sim.set_joint(j.servo_id, t % 4096)
                cal.sample()
        result = cal.finish()
    return result


@pytest.fixture(scope="module")
def narrow(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A copy of the simulated SO-101-like arm, calibrated narrower than its config."""
    folder = tmp_path_factory.mktemp("narrow")
    config = folder / "so_sim.yaml"
    shutil.copy(SO_SIM, config)
    _calibrate(config).save(folder / "so_sim.calibration.yaml")
    return config


@pytest.fixture
def sims(monkeypatch: pytest.MonkeyPatch) -> list[SimulatedBus]:
    """Every simulated bus started from now on (to look at its servos afterwards)."""
    started: list[SimulatedBus] = []
    original = SimulatedBus.start

    def start(self: SimulatedBus) -> str:
        started.append(self)
        return original(self)

    monkeypatch.setattr(SimulatedBus, "start", start)
    return started


def _untouched(sim: SimulatedBus) -> None:
    """Nothing was commanded: torque off, no goal ever written, every shaft where it started."""
    for servo in sim.servos:
        assert not servo.torque, f"servo {servo.id} torque was switched on"
        assert servo.get(Register.GOAL_POSITION) == 0, f"servo {servo.id} got a goal"
        assert servo.target == servo.actual


# ---- building ---------------------------------------------------------------------------------
def test_sources_config_calibration_and_margin(narrow: Path) -> None:
    spec = load_spec(narrow)
    cal = Calibration.load(narrow.with_name("so_sim.calibration.yaml"))
    lim = effective_limits(spec, cal)
    lift = lim.joint("shoulder_lift")
    assert lift.config == (-1.7, 1.7)
    assert lift.calibration == pytest.approx((-CAL_HALF, CAL_HALF), abs=1e-9)
    assert lift.lower.source is LimitSource.CALIBRATION
    assert lift.upper.source is LimitSource.CALIBRATION
    assert lift.upper.value == pytest.approx(CAL_HALF - MARGIN, abs=1e-9)
    assert lift.lower.value == pytest.approx(-CAL_HALF + MARGIN, abs=1e-9)
    # swept wider than the config: the config's limits hold, without a margin
    elbow = lim.joint("elbow_flex")
    assert (elbow.lower.source, elbow.upper.source) == (LimitSource.CONFIG, LimitSource.CONFIG)
    assert (elbow.lower.value, elbow.upper.value) == (-1.6, 1.6)
    assert "so_sim.yaml:" in elbow.upper.origin and "limits.upper" in elbow.upper.origin
    # the prismatic gripper: the margin is 8 servo ticks through its gear ratio
    grip = lim.joint("gripper")
    k = 100.0 * 4096 / (2 * math.pi)
    assert grip.lower.value == pytest.approx(MARGIN_TICKS / k, rel=1e-6)
    assert lim.narrowed() == {n: ("calibration",) for n in
                              ("shoulder_pan", "shoulder_lift", "wrist_flex", "wrist_roll",
                               "gripper")}
    # the mapping (the last check before the wire) is never narrower than the effective limits
    mapping = JointMapping.from_spec(spec, cal)
    assert np.all(mapping.lower <= lim.lower) and np.all(lim.upper <= mapping.upper)


def test_register_limits_follow_direction_and_mode() -> None:
    spec = load_spec(SO_SIM)
    # shoulder_lift (servo 2) turns against its axis: Max Angle Limit bounds the LOWER side
    regs = {2: PositionLimitRegisters(2, 0, 2048 + 500, 0),
            1: PositionLimitRegisters(1, 0, 0, 0),  # Feetech 0/0: no limit
            4: PositionLimitRegisters(4, 2048 - 300, 4095, 0)}
    lim = effective_limits(spec, None, regs)
    lift = lim.joint("shoulder_lift")
    assert lift.lower.source is LimitSource.SERVO_REGISTER
    assert lift.lower.value == pytest.approx(-500 * TICK + MARGIN, abs=1e-9)
    assert "Max Angle Limit register (address 11) = 2548 ticks" in lift.lower.origin
    assert "Register.MAX_POSITION_LIMIT, 4095" in lift.lower.fix
    assert lift.upper.source is LimitSource.CONFIG and lift.register == (
        pytest.approx(-500 * TICK), math.inf)
    assert lim.joint("shoulder_pan").register is None  # 0/0 is "no limit"
    wrist = lim.joint("wrist_flex")
    assert wrist.lower.value == pytest.approx(-300 * TICK + MARGIN, abs=1e-9)
    assert "Min Angle Limit" in wrist.lower.origin and wrist.upper.source is LimitSource.CONFIG
    # not in position mode: the registers limit nothing
    regs[2] = PositionLimitRegisters(2, 0, 2548, 1)
    assert effective_limits(spec, None, regs).joint("shoulder_lift").register is None


def test_extended_mode_dynamixel_ignores_registers() -> None:
    spec = load_spec(REPO / "tests" / "servo" / "data" / "dxl_sim.yaml")
    regs = {11: PositionLimitRegisters(11, 1000, 3000, 4),  # j1 is multi-turn
            12: PositionLimitRegisters(12, 1000, 3000, 3)}
    lim = effective_limits(spec, None, regs)
    assert lim.joint("j1").register is None and lim.joint("j1").lower.value == -6.283
    j2 = lim.joint("j2")  # direction -1: Max Position Limit bounds the lower side
    assert j2.lower.source is LimitSource.SERVO_REGISTER
    assert "Max Position Limit register (address 48) = 3000" in j2.lower.origin


def test_sources_that_exclude_each_other_are_a_config_error() -> None:
    from armctl.errors import ConfigError

    spec = load_spec(SO_SIM)
    with pytest.raises(ConfigError, match="no allowed range left"):
        effective_limits(spec, None, {1: PositionLimitRegisters(1, 3900, 4000, 0)})


# ---- the mapping's own check names the right source ---------------------------------------------
def test_mapping_check_names_the_calibration(narrow: Path) -> None:
    spec = load_spec(narrow)
    mapping = JointMapping.from_spec(spec, Calibration.load(
        narrow.with_name("so_sim.calibration.yaml")))
    with pytest.raises(JointLimitError) as info:
        mapping.goal_ticks([0, 1.5, 0, 0, 0, 0])
    text = str(info.value)
    assert "calibrat" in text and "widen" not in text
    with pytest.raises(JointLimitError, match="widen them in the arm config"):
        mapping.goal_ticks([0, 0, 1.65, 0, 0, 0])  # elbow_flex: bounded by the config


# ---- the reproduction: dry run and real run, same verdict, nothing moved ----------------
@pytest.mark.parametrize("dry_run", [True, False])
def test_move_beyond_the_calibration_is_refused_before_anything_moves(
        narrow: Path, sims: list[SimulatedBus], dry_run: bool,
        capsys: pytest.CaptureFixture[str]) -> None:
    args = ["move-joints", str(narrow), "0", "1.5", "0", "0", "0", "0"]
    code = main([*args, "--dry-run"] if dry_run else args)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "shoulder_lift" in err and "effective upper limit" in err
    assert "calibrated range" in err and "re-run 'armctl calibrate" in err
    assert "widen" not in err and "Traceback" not in err
    assert len(sims) == 1
    _untouched(sims[0])


def test_json_error_names_the_limit_source(narrow: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["move-joints", str(narrow), "0", "1.5", "0", "0", "0", "0", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert code == 2 and not out["ok"]
    assert out["error"]["details"]["limit_source"] == "calibration"
    assert out["error"]["details"]["joint"] == "shoulder_lift"


def test_python_api_refuses_before_torque_and_ik_stays_inside(narrow: Path) -> None:
    with Robot.open(narrow, hold=False, exit_policy=ExitPolicy.HOLD) as robot:
        sim = robot.bus.simulator  # type: ignore[attr-defined]
        assert np.allclose(robot.arm.upper, robot.effective.upper)
        assert robot.config_arm.upper[1] == 1.7
        with pytest.raises(JointLimitError, match="calibrated range"):
            robot.move_joints([0, 1.5, 0, 0, 0, 0])
        _untouched(sim)
        # IK answers inside the effective limits: a tool position the config arm reaches with
        # the shoulder at -1.3 rad (leaning back: the move there keeps the links off the base)
        cfg = robot.config_arm
        target = cfg.fk(np.array([0.2, -1.3, 0.4, -0.3, 0.0, 0.01]))[:3, 3]
        plan, ik = robot.plan_pose(PositionGoal(target), speed=1.0)
        assert ik is not None and ik.success
        lo, hi = robot.effective.lower, robot.effective.upper
        assert np.all(plan.goal >= lo - 1e-9) and np.all(plan.goal <= hi + 1e-9)
        _untouched(sim)  # planning alone writes nothing
        # a small move inside the limits runs and arrives
        report = robot.move_joints([0.1, 0.2, -0.1, 0.0, 0.0, 0.01], speed=1.0)
        assert report.result is not None
        assert np.allclose(report.result.final[:5], [0.1, 0.2, -0.1, 0.0, 0.0], atol=0.01)


def test_keyframe_beyond_the_calibration_is_refused_naming_it(narrow: Path) -> None:
    from armctl.motion import Keyframe, KeyframeProgram

    names = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll",
             "gripper")
    program = KeyframeProgram("so_sim", names, (
        Keyframe(q=(0.1, 0.2, 0.0, 0.0, 0.0, 0.01), name="a"),
        Keyframe(q=(0.0, -1.2, 0.0, 0.0, 0.0, 0.01), name="reach")))
    with Robot.open(narrow, hold=False, exit_policy=ExitPolicy.HOLD) as robot:
        with pytest.raises(JointLimitError) as info:
            robot.play(program, dry_run=True)
        _untouched(robot.bus.simulator)  # type: ignore[attr-defined]
    text = str(info.value)
    assert "keyframe 1 (reach)" in text and "effective lower limit" in text
    assert "calibrated range" in text


def test_present_position_outside_the_calibration_is_not_held(narrow: Path) -> None:
    arm = load_arm(narrow)
    cal = Calibration.load(narrow.with_name("so_sim.calibration.yaml"))
    with ArmBus.from_spec(arm.spec, cal) as bus:
        assert bus.simulator is not None
        bus.simulator.set_joint("shoulder_lift", 0.9999)  # pushed to the swept end by hand
        robot = Robot(arm, bus)
        robot.hold()  # within the margin: held at the effective limit
        assert robot.executor.last_command is not None
        assert robot.executor.last_command[1] == pytest.approx(robot.effective.upper[1])
        bus.set_torque(False)
        bus.simulator.set_joint("wrist_flex", 1.3)  # beyond the sweep and the tolerance
        before = bus.simulator.positions
        with pytest.raises(JointLimitError, match=r"present position.*calibrated range"):
            robot.hold()
        assert bus.simulator.positions == before
        assert not any(s.torque for s in bus.simulator.servos)


# ---- servo registers narrower than the config (the 0.114 rad case) -----------------------------
def _short_register(bus: ArmBus, joint: str, value: float) -> int:
    """Set a servo's Max Angle Limit to the tick of ``value`` (torque off); returns the tick."""
    j = bus.mapping.joint(joint)
    tick = round(j.to_ticks(value))
    assert bus.simulator is not None
    bus.simulator.servo(j.servo_id).set(Register.MAX_POSITION_LIMIT, tick)
    return tick


def test_register_narrower_than_the_goal_is_refused_at_planning() -> None:
    arm = load_arm(SO_SIM)
    with ArmBus.from_spec(arm.spec) as bus:
        tick = _short_register(bus, "elbow_flex", 0.4 - 0.114)
        robot = Robot(arm, bus, exit_policy=ExitPolicy.HOLD)
        sim = bus.simulator
        assert sim is not None
        before = sim.positions
        with pytest.raises(JointLimitError) as info:
            robot.move_joints([0, 0, 0.4, 0, 0, 0])
        text = str(info.value)
        assert f"servo 3's own Max Angle Limit register (address 11) = {tick} ticks" in text
        assert "write_eeprom(3, [(Register.MAX_POSITION_LIMIT, 4095)])" in text
        assert sim.positions == before and not any(s.torque for s in sim.servos)
        # the dry run gives the same verdict
        with pytest.raises(JointLimitError, match="Max Angle Limit"):
            robot.move_joints([0, 0, 0.4, 0, 0, 0], dry_run=True)


# ---- arrival ---------------------------------------------------------------------------------
def test_register_changed_after_opening_fails_arrival_with_its_cause() -> None:
    arm = load_arm(SO_SIM)
    with ArmBus.from_spec(arm.spec) as bus:
        robot = Robot(arm, bus, exit_policy=ExitPolicy.HOLD)  # registers read now: no limits
        robot.hold()
        bus.set_torque(False)
        _short_register(bus, "elbow_flex", 0.4 - 0.114)  # then someone narrows the register
        bus.set_torque(True)
        with pytest.raises(MotionStopped) as info:
            robot.move_joints([0, 0, 0.4, 0, 0, 0], speed=1.0)
    exc = info.value
    assert exc.reason is StopReason.NOT_REACHED and exc.exit_code == 5
    assert exc.joint == "elbow_flex" and exc.servo_id == 3
    text = str(exc)
    short = float(text.split("stopped ")[1].split(" deg short")[0])
    assert short == pytest.approx(math.degrees(0.114), abs=0.2)
    assert "position limit registers" in text and "open it again" in text


def test_blocked_joint_fails_arrival_naming_joint_and_amount() -> None:
    arm = load_arm(SO_SIM)
    with ArmBus.from_spec(arm.spec) as bus:
        robot = Robot(arm, bus, exit_policy=ExitPolicy.HOLD)
        sim = bus.simulator
        assert sim is not None
        j = bus.mapping.joint("wrist_flex")
        at = round(j.to_ticks(0.1))
        sim.inject(Obstacle(j.servo_id, at))  # something in the way at 0.1 rad
        blocked = j.to_joint(at)
        with pytest.raises(MotionStopped) as info:
            robot.move_joints([0, 0, 0, 0.15, 0, 0], speed=1.0)
        measured = robot.joints()
    exc = info.value
    assert exc.reason is StopReason.NOT_REACHED and exc.joint == "wrist_flex"
    text = str(exc)
    assert "servo 4" in text and f"{math.degrees(0.15 - blocked):.2f} deg short" in text
    assert "blocks the joint" in text
    reading = float(text.split("present load: ")[1].split(" % of the servo's stall torque")[0])
    assert 30 < reading <= 100  # the servo's position loop pushes against the obstacle
    assert measured[3] == pytest.approx(blocked, abs=TICK)


def test_a_gripper_closing_on_an_object_is_not_a_failure() -> None:
    arm = load_arm("so101")  # its gripper joint has the gripper role
    with ArmBus.from_spec(arm.spec) as bus:
        robot = Robot(arm, bus, exit_policy=ExitPolicy.HOLD)
        assert bus.simulator is not None
        robot.move_joints([0, 0, 0, 0, 0, 0.2], speed=1.0)
        j = bus.mapping.joint("gripper")
        at = round(j.to_ticks(0.1))  # within the tracking limit of the closing command
        bus.simulator.inject(Obstacle(j.servo_id, at))  # the object between the jaws
        report = robot.move_joints([0, 0, 0, 0, 0, 0.0], speed=1.0)
        with pytest.raises(MotionStopped, match="'elbow_flex'"):  # an arm joint must arrive
            bus.simulator.inject(Obstacle(bus.mapping.joint("elbow_flex").servo_id))
            robot.move_joints([0, 0, 0.05, 0, 0, 0.0], speed=1.0)
    assert report.result is not None
    assert report.result.final[5] == pytest.approx(j.to_joint(at), abs=2 * TICK)


# ---- info and status show the limits -------------------------------------------------------
def test_info_shows_config_and_calibrated_limits(narrow: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["info", str(narrow), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    lift = next(j for j in out["joints"] if j["name"] == "shoulder_lift")
    assert lift["lower"] == -1.7 and lift["upper"] == 1.7
    assert lift["calibrated"] == pytest.approx([-CAL_HALF, CAL_HALF])
    assert lift["effective"] == pytest.approx([-CAL_HALF + MARGIN, CAL_HALF - MARGIN])
    assert lift["upper_source"] == "calibration"
    assert out["calibration"]["file"].endswith("so_sim.calibration.yaml")
    assert main(["info", str(narrow), "--deg"]) == 0
    text = capsys.readouterr().out
    assert "calibrated" in text and "57.30" in text  # 1.00016 rad in degrees


def test_status_shows_every_source(narrow: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["status", str(narrow), "--once", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    lift = out["limits"]["joints"]["shoulder_lift"]
    assert lift["config"] == [-1.7, 1.7]
    assert lift["calibration"] == pytest.approx([-CAL_HALF, CAL_HALF])
    assert lift["servo_register"] is None  # the servo's registers are at 0..4095: no limit
    assert lift["servo_register_ticks"] == [0, 4095]
    assert lift["effective"] == pytest.approx([-CAL_HALF + MARGIN, CAL_HALF - MARGIN])
    assert (lift["lower_source"], lift["upper_source"]) == ("calibration", "calibration")
    assert main(["status", str(narrow), "--once", "--deg"]) == 0
    text = capsys.readouterr().out
    assert "effective" in text and "calibration" in text and "servo registers" in text


def test_live_view_arm_uses_the_effective_limits(narrow: Path) -> None:
    from armctl.cli.render import view_arm

    arm = load_arm(narrow)
    shown = view_arm(arm, None)
    assert shown.upper[1] == pytest.approx(CAL_HALF - MARGIN)
    assert shown.lower[2] == -1.6


def test_ik_answers_inside_the_calibrated_limits(narrow: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """Without the bus, ``armctl ik`` uses the calibration as the motion commands do."""
    cfg = load_arm(narrow)
    target = cfg.fk(np.array([0.2, 1.3, -0.4, 0.3, 0.0, 0.01]))[:3, 3]
    code = main(["ik", str(narrow), "--xyz", *map(str, target), "--from", "0.2", "0.95", "-0.4",
                 "0.3", "0", "0.01", "--json"])
    out = json.loads(capsys.readouterr().out)
    if code == 0:  # a solution inside the calibrated range, or none (never one beyond it)
        q = np.array([out["joints"][n] for n in cfg.joint_names])
        assert q[1] <= CAL_HALF - MARGIN + 1e-9, q
    else:
        assert code == 3 and not out["ok"]
    # a start beyond the calibrated range is refused, naming the calibration
    code = main(["ik", str(narrow), "--xyz", *map(str, target), "--from", "0.2", "1.3", "-0.4",
                 "0.3", "0", "0.01"])
    err = capsys.readouterr().err
    assert code == 2 and "calibrat" in err
