"""Arrival on servos with a motor model: a move ends when every joint has come to rest at the goal.

A servo's position loop closes in on its goal after the last streamed sample; the executor holds
the goal until every joint is within its tolerance and at rest, and reports the pose it rests at.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest
from collision_free import free_pose_goal

from armctl.arm import load_arm
from armctl.config.motion import ExitPolicy
from armctl.ik import PositionGoal
from armctl.robot import CycleInfo, MotionStopped, Robot, StopReason
from armctl.servo import Register

TICK = 2 * math.pi / 4096  # one encoder tick of the arms' joints [rad]


def _ticks(robot: Robot) -> np.ndarray:
    """One encoder tick per bus joint, in joint units."""
    return np.array([2 * math.pi / (j.ticks_per_rev * j.gear_ratio)
                     for j in robot.bus.mapping.joints])


@pytest.mark.parametrize("seed", [3, 17, 30])
@pytest.mark.parametrize("name", ["so101", "panda"])  # STS3215 and XM430-W350 servos
def test_the_report_is_the_pose_the_arm_comes_to_rest_at(name: str, seed: int) -> None:
    arm = load_arm(name)
    rng = np.random.default_rng(seed)
    home = arm.named_pose("home")
    with Robot.open(arm, speed=0.7, exit_policy=ExitPolicy.HOLD) as robot:
        # the first random goal near the home pose that the arm reaches without contact (the
        # middle of the ranges does not do on every arm: the panda's wrist capsules overlap there)
        _, goal = free_pose_goal(robot, lambda: home + 0.25 * (arm.sample(rng) - home),
                                 lambda q: PositionGoal(arm.fk(q)[:3, 3]))
        target = goal.position
        report = robot.move_to_pose(goal)
        robot.clock.sleep_until(robot.clock.now() + 0.5)  # long after any settling
        rest = robot.joints()
        ex = robot.executor
        tick = _ticks(robot)
    assert report.result is not None
    assert report.position_error < 2e-3
    assert np.linalg.norm(arm.fk(rest)[:3, 3] - target) < 2e-3
    # the joints reported are those the arm stays at: at most the last encoder tick of a creep
    # too slow for the servo's velocity reading remains
    moved = np.abs(rest[ex.idx] - report.result.final[ex.idx])[ex.must_arrive]
    assert np.all(moved <= tick[ex.must_arrive] * 1.01), moved / tick[ex.must_arrive]
    # and on these moves not even that: a joint creeping at one count of Present Velocity
    # (0.229 rpm on the XM430) is not taken for one at rest
    assert np.linalg.norm(arm.fk(rest)[:3, 3] - report.reached[:3, 3]) < 0.3e-3
    assert report.result.stats.settle_time >= ex.settle_dwell - 1e-9


def _sluggish_wrist(robot: Robot) -> None:
    """The wrist_flex servo with 12 for its factory P gain of 32: it lags its goal."""
    sim = robot.bus.simulator
    assert sim is not None
    servo = sim.servo(robot.bus.mapping.joint("wrist_flex").servo_id)
    assert servo.get(Register.P_GAIN) == 32  # the STS3215's factory value
    servo.set(Register.P_GAIN, 12)


@pytest.mark.parametrize("velocity", [True, False], ids=["velocity", "positions-only"])
def test_arrival_waits_for_a_joint_still_closing_in_within_its_tolerance(
        velocity: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    goal = 0.6
    with Robot.open("so101", speed=1.0, exit_policy=ExitPolicy.HOLD) as robot:
        _sluggish_wrist(robot)
        if not velocity:  # a bus whose state carries no velocity: judged by its readings
            read = robot.bus.read_state

            def no_velocity() -> Any:
                s = read()
                return SimpleNamespace(position=s.position, errors=s.errors, load=s.load)

            monkeypatch.setattr(robot.bus, "read_state", no_velocity)
        cycles: list[CycleInfo] = []
        report = robot.move_joints([0, 0, 0, goal, 0, 0], on_cycle=cycles.append)
        monkeypatch.undo()
        robot.clock.sleep_until(robot.clock.now() + 0.5)
        rest = robot.joints()[3]
        tolerance = float(robot.executor.arrival_tolerance[3])
    assert report.result is not None
    at_end = cycles[-1].measured[3]  # the reading of the plan's last sample
    # the joint is within its tolerance at the end of the plan, yet still well short: judged
    # there, the move would report where the joint was passing through
    assert 3e-3 < abs(at_end - goal) < tolerance
    final = report.result.final[3]
    assert abs(final - goal) < 2.5e-3
    assert abs(rest - final) <= TICK * 1.01
    assert report.result.stats.settle_time > 0.08  # the time the servo took to close in


def test_a_joint_that_never_comes_to_rest_fails_arrival_naming_it() -> None:
    goal = 0.6
    with Robot.open("so101", speed=1.0, exit_policy=ExitPolicy.HOLD) as robot:
        sim = robot.bus.simulator
        assert sim is not None
        # something shakes the wrist: 0.2 N m at 4 Hz, a few mrad of swing within tolerance
        sim.servo(4).set_load(lambda angle, speed, t: 0.2 * math.sin(2 * math.pi * 4 * t))
        with pytest.raises(MotionStopped) as info:
            robot.move_joints([0, 0, 0, goal, 0, 0])
        held = robot.executor.last_command
    exc = info.value
    assert exc.reason is StopReason.NOT_REACHED and exc.exit_code == 5
    assert exc.joint == "wrist_flex" and exc.servo_id == 4
    text = str(exc)
    assert "joint 'wrist_flex' (servo 4) did not come to rest at its goal" in text
    off = float(text.split("(it is ")[1].split(" deg off)")[0])
    assert 0.0 < off <= 0.58  # within the 0.57 deg tolerance: not at rest is the failure
    speed = float(text.split("still moving at ")[1].split(" deg/s")[0])
    assert speed > math.degrees(0.03)
    waited = float(text.split(" s after the end of the motion")[0].rsplit(" ", 1)[1])
    assert waited == pytest.approx(1.0, abs=0.05)
    assert "hunts around its goal" in text and "Torque stays on" in text
    assert held is not None and held[3] == pytest.approx(goal, abs=1e-9)  # the goal held
    assert exc.held[3] == pytest.approx(goal, abs=1e-9)


def test_a_gripper_that_keeps_moving_does_not_hold_up_arrival() -> None:
    """A gripper is exempt from arrival: held on an object it may yield and never be still."""
    with Robot.open("so101", speed=1.0, exit_policy=ExitPolicy.HOLD) as robot:
        sim = robot.bus.simulator
        assert sim is not None
        gripper = robot.bus.mapping.joint("gripper").servo_id
        sim.servo(gripper).set_load(lambda angle, speed, t: 0.2 * math.sin(2 * math.pi * 4 * t))
        report = robot.move_joints([0, 0, 0, 0.3, 0, 0.2])
        speed = abs(robot.bus.read_state().velocity[5])
    assert report.result is not None
    assert report.result.stats.settle_time < 0.5  # not the 1 s timeout
    assert speed > 0.03  # the gripper was still moving when the move ended
