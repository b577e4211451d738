"""What ``Robot.execute`` refuses before anything is written, and the end of a motion.

A plan made with other limits is checked against the effective ones (never clipped into them),
a servo in the alarm lock-out refuses the motion, a bus error while the servos settle is a
controlled stop, and the tolerances for a reading outside the limits follow the joint type.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import REPO

from armctl.arm import load_arm
from armctl.config.motion import ExitPolicy
from armctl.errors import InputError, JointLimitError
from armctl.motion import MotionLimits, plan_joint_move
from armctl.robot import CycleInfo, Executor, MotionStopped, Robot, StopReason
from armctl.servo import Alarm, ArmBus, HardwareAlarm, Obstacle, Register
from armctl.servo.errors import ServoAlarmError, port_io_error

pytestmark = pytest.mark.timeout(60)

SO_SIM = REPO / "tests" / "servo" / "data" / "so_sim.yaml"
#: Feetech instructions that change a servo: WRITE, REG_WRITE, SYNC_WRITE.
WRITES = (0x03, 0x04, 0x83)


def _writes(trace: list[tuple[str, bytes]]) -> int:
    """How many write instructions the simulated servos received."""
    return sum(1 for direction, pkt in trace if direction == "rx" and pkt[4] in WRITES)


def _narrow_register(bus: ArmBus, joint: str, value: float) -> None:
    """Set a servo's Max Angle Limit to the tick of ``value`` (the joint's upper side)."""
    j = bus.mapping.joint(joint)
    assert bus.simulator is not None and j.direction > 0
    bus.simulator.servo(j.servo_id).set(Register.MAX_POSITION_LIMIT, round(j.to_ticks(value)))


# ---- a plan made with other limits ----------------------------------------------------------
def test_a_plan_made_with_the_config_limits_is_refused_before_anything_moves() -> None:
    arm = load_arm(SO_SIM)
    with ArmBus.from_spec(arm.spec) as bus:
        _narrow_register(bus, "elbow_flex", 0.3)
        robot = Robot(arm, bus, exit_policy=ExitPolicy.HOLD)
        assert robot.arm.upper[2] < 0.3
        # the public planner, with the config's limits: inside them, beyond the register
        plan = plan_joint_move(robot.plan_start(), [0, 0, 0.5, 0, 0, 0],
                               MotionLimits.from_model(arm), 1.0)
        sim = bus.simulator
        assert sim is not None
        trace = sim.start_trace()
        with pytest.raises(JointLimitError) as info:
            robot.execute(plan)
        assert _writes(trace) == 0 and not any(s.torque for s in sim.servos)
    text = str(info.value)
    assert "elbow_flex" in text and "plan it with this robot" in text
    assert "Max Angle Limit" in text and info.value.details["limit_source"] == "servo_register"


def test_arrival_is_judged_at_the_plans_end_not_at_a_clipped_command() -> None:
    """The executor alone (no Robot checks): a goal it can only clip to never 'arrives'."""
    arm = load_arm(SO_SIM)
    with ArmBus.from_spec(arm.spec) as bus:
        config = MotionLimits.from_model(arm)
        upper = config.upper.copy()
        upper[2] = 0.3
        narrow = dataclasses.replace(config, upper=upper)
        executor = Executor(bus, arm, narrow)
        plan = plan_joint_move(np.zeros(arm.dof), [0, 0, 0.4, 0, 0, 0], config, 1.0)
        with pytest.raises(MotionStopped) as info:
            executor.run(plan)
    exc = info.value
    assert exc.reason is StopReason.NOT_REACHED and exc.joint == "elbow_flex"
    assert f"the goal is {math.degrees(0.4):.2f} deg" in str(exc)  # not the clipped 0.3


# ---- the alarm lock-out ---------------------------------------------------------------------
def test_a_motion_is_refused_while_a_servo_is_alarmed() -> None:
    with Robot.open(SO_SIM, exit_policy=ExitPolicy.HOLD) as robot:
        sim = robot.bus.simulator  # type: ignore[attr-defined]
        assert sim is not None
        sim.inject(HardwareAlarm(3, Alarm.OVERLOAD))
        robot.bus.read_state()  # the alarm is seen: servo 3 is locked out ...
        sim.clear_faults()  # ... also once it no longer reports it, until the user clears it
        plan = robot.plan_joints([0.2, 0.1, 0.1, 0, 0, 0.01], 1.0)
        trace = sim.start_trace()
        with pytest.raises(ServoAlarmError) as info:
            robot.execute(plan)
        assert _writes(trace) == 0  # no stop streamed to the others: nothing at all
    text = str(info.value)
    assert info.value.servo_id == 3 and "elbow_flex" in text and "overload" in text
    assert "--clear-alarms" in text and "clear_alarms" in text


# ---- a bus error while the servos settle ------------------------------------------------------
def test_a_bus_error_while_settling_is_a_controlled_stop(monkeypatch: pytest.MonkeyPatch
                                                         ) -> None:
    with Robot.open(SO_SIM, exit_policy=ExitPolicy.HOLD) as robot:
        bus: ArmBus = robot.bus  # type: ignore[assignment]
        wrist = bus.mapping.joint("wrist_flex")
        assert bus.simulator is not None  # it cannot arrive: the servos keep settling
        bus.simulator.inject(Obstacle(wrist.servo_id, round(wrist.to_ticks(0.1))))
        goal = np.array([0.0, 0.0, 0.0, 0.15, 0.0, 0.0])
        ended: list[bool] = []
        write = bus.write_joints

        def failing_write(q: object, **kwargs: object) -> None:
            if ended:  # after the last cycle: the port fails
                raise port_io_error(bus.spec.port, OSError(5, "Input/output error"))
            write(q, **kwargs)  # type: ignore[arg-type]

        def last_cycle(cyc: CycleInfo) -> None:
            if cyc.t >= cyc.duration:
                ended.append(True)

        monkeypatch.setattr(bus, "write_joints", failing_write)
        with pytest.raises(MotionStopped) as info:
            robot.move_joints(goal, speed=1.0, on_cycle=last_cycle)
    exc = info.value
    assert exc.reason is StopReason.BUS_IO and exc.exit_code == 5
    assert "nothing more could be sent" in str(exc)
    held = np.asarray(exc.held)
    assert held.shape == (goal.size,) and np.allclose(held, goal)  # the whole arm, arm order
    assert exc.stopped_at is not None  # the report says where the arm is


# ---- tolerances per joint type ----------------------------------------------------------------
def test_a_prismatic_joint_millimetres_outside_is_not_held() -> None:
    arm = load_arm(SO_SIM)  # the gripper is prismatic, 0 to 30 mm
    with ArmBus.from_spec(arm.spec) as bus:
        sim = bus.simulator
        assert sim is not None
        robot = Robot(arm, bus, exit_policy=ExitPolicy.HOLD)
        sim.set_joint("gripper", -0.005)  # 5 mm below its lower limit
        with pytest.raises(JointLimitError, match=r"gripper.*present position"):
            robot.hold()
        assert not any(s.torque for s in sim.servos)  # nothing was written
        sim.set_joint("gripper", -0.0005)  # half a millimetre: noise, held at the limit
        robot.hold()
        assert robot.executor.last_command is not None
        assert robot.executor.last_command[5] == pytest.approx(0.0, abs=1e-12)
        # a plan whose start the gripper has left by 5 mm is not run
        plan = robot.plan_joints([0.1, 0, 0, 0, 0, 0.01], 1.0)
        bus.set_torque(False, ["gripper"])
        sim.set_joint("gripper", 0.005)
        with pytest.raises(InputError, match=r"plan starts .*5\.00 mm.* 'gripper'"):
            robot.execute(plan)


def test_a_joint_resting_at_its_limit_register_is_held_with_a_small_gear_ratio(
        tmp_path: Path) -> None:
    """Gear ratio 0.5: the 8-tick margin is 0.0245 rad of joint travel, more than 0.02 rad."""
    config = tmp_path / "so_geared.yaml"
    text = SO_SIM.read_text(encoding="utf-8")
    assert text.count("wrist_flex: {id: 4, model: sts3215}") == 1
    config.write_text(text.replace("wrist_flex: {id: 4, model: sts3215}",
                                   "wrist_flex: {id: 4, model: sts3215, gear_ratio: 0.5}"),
                      encoding="utf-8")
    arm = load_arm(config)
    with ArmBus.from_spec(arm.spec) as bus:
        sim = bus.simulator
        assert sim is not None
        _narrow_register(bus, "wrist_flex", 1.0)
        robot = Robot(arm, bus, exit_policy=ExitPolicy.HOLD)
        margin = 8 / (0.5 * 4096 / (2 * math.pi))  # 8 ticks through the gear ratio
        assert robot.arm.upper[3] == pytest.approx(1.0 - margin, abs=math.pi / 1024)  # a tick
        sim.set_joint("wrist_flex", 1.0)  # resting against the register's stop
        robot.hold()
        assert robot.executor.last_command is not None
        assert robot.executor.last_command[3] == pytest.approx(robot.arm.upper[3])
        bus.set_torque(False)
        sim.set_joint("wrist_flex", 1.05)  # further out than margin and noise
        with pytest.raises(JointLimitError, match="wrist_flex"):
            robot.hold()
        assert robot.effective.joint("wrist_flex").margin == pytest.approx(margin)

