"""End to end on the simulated bus: moves reach their goals, faults and Ctrl-C stop safely."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator

import numpy as np
import pytest
from collision_free import free_pose_goal

from armctl.arm import Arm, load_arm
from armctl.config.motion import ExitPolicy
from armctl.errors import NoSolutionError
from armctl.ik import PoseGoal, PositionGoal
from armctl.motion import PathError
from armctl.robot import CycleInfo, MotionStopped, Robot, StopReason
from armctl.servo.sim.faults import Alarm, HardwareAlarm, MissingServo


@pytest.fixture(scope="module")
def so101() -> Arm:
    return load_arm("so101")


@pytest.fixture
def robot(so101: Arm) -> Iterator[Robot]:
    """The bundled SO-101 on its simulated bus, holding its start pose."""
    with Robot.open(so101, speed=0.7, exit_policy=ExitPolicy.HOLD) as r:
        yield r


SIM_ARMS = ("so101", "omx", "wx250s", "ur5e", "panda", "torso")


@pytest.mark.parametrize("name", SIM_ARMS)
def test_move_to_pose_reaches_the_goal_by_fk_of_read_back_joints(name: str) -> None:
    arm = load_arm(name)
    rng = np.random.default_rng(7)
    home = arm.named_pose("home")
    with Robot.open(arm, speed=0.7, exit_policy=ExitPolicy.HOLD) as robot:
        # a reachable goal: the tool position of a configuration a quarter of the way from home
        # to a random one, the first one the arm reaches without contact (the middle of the
        # ranges does not do on every arm: the panda's wrist capsules overlap there)
        _, goal = free_pose_goal(robot, lambda: home + 0.25 * (arm.sample(rng) - home),
                                 lambda q: PositionGoal(arm.fk(q)[:3, 3]))
        target = goal.position
        report = robot.move_to_pose(goal)
        measured = robot.joints()
    reached = arm.fk(measured)[:3, 3]
    assert np.linalg.norm(reached - target) < 2e-3  # servo resolution and settling
    assert report.position_error < 2e-3  # measured once the servos have come to rest
    assert np.allclose(report.reached, arm.fk(report.result.final))


def test_full_pose_on_a_six_joint_arm() -> None:
    arm = load_arm("wx250s")
    q_goal = arm.middle() + np.array([0.3, -0.2, 0.3, 0.4, 0.3, -0.5] + [0.0] * (arm.dof - 6))
    goal = arm.fk(q_goal)
    with Robot.open(arm, exit_policy=ExitPolicy.HOLD) as robot:
        report = robot.move_to_pose(PoseGoal(goal), speed=0.7)
    assert report.position_error < 3e-3 and report.rotation_error < 0.01


def test_unreachable_goal_moves_nothing(robot: Robot) -> None:
    before = robot.joints()
    with pytest.raises(NoSolutionError, match="nothing was moved") as info:
        robot.move_to_pose(PositionGoal([1.5, 0.0, 0.2]))
    assert info.value.exit_code == 3
    robot.clock.sleep_until(robot.clock.now() + 0.1)  # time for anything sent to show
    assert np.allclose(robot.joints(), before, atol=1e-9)


def test_straight_line_stays_on_the_line(robot: Robot) -> None:
    arm = robot.arm
    robot.move_joints([0.0, -0.8, 0.8, 0.6, 0.0, 0.0])
    p0 = robot.pose()[:3, 3]
    p1 = p0 + np.array([0.0, 0.08, -0.04])
    plan, _ = robot.plan_pose(PositionGoal(p1), linear=True, speed=0.8)
    ts = np.linspace(0, plan.duration, 300)
    q_cmd, _, _ = plan.trajectory.sample_many(ts)
    pts = arm.fk_batch(q_cmd)[:, :3, 3]
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    off = (pts - p0) - ((pts - p0) @ d)[:, None] * d
    assert np.max(np.linalg.norm(off, axis=1)) < 1e-3  # planned path within 1 mm
    res = robot.execute(plan, record=True)
    full = np.tile(res.final, (len(res.log_meas), 1))
    full[:, robot.executor.idx] = res.log_meas
    meas = arm.fk_batch(full)[:, :3, 3]
    off = (meas - p0) - ((meas - p0) @ d)[:, None] * d
    assert np.max(np.linalg.norm(off, axis=1)) < 4e-3  # measured, with servo lag
    assert np.linalg.norm(arm.fk(res.final)[:3, 3] - p1) < 2e-3


def test_unfollowable_line_is_refused_before_motion(robot: Robot) -> None:
    before = robot.joints()
    # straight through the arm's base: the line leaves the workspace
    p0 = robot.pose()[:3, 3]
    with pytest.raises(PathError) as info:
        robot.plan_pose(PositionGoal([-p0[0], p0[1], p0[2]]), linear=True)
    assert 0.0 <= info.value.fraction < 1.0
    assert f"{info.value.fraction:.0%}" in str(info.value)
    assert np.allclose(robot.joints(), before, atol=1e-9)


def _commands_in(robot: Robot, plan, trigger):
    seen: list[CycleInfo] = []

    def cb(info: CycleInfo) -> None:
        seen.append(info)
        trigger(info)

    with pytest.raises(MotionStopped) as info:
        robot.execute(plan, cb)
    return info.value, seen


def test_sigint_mid_move_decelerates_and_holds_with_torque_on(robot: Robot) -> None:
    plan = robot.plan_joints([1.2, -1.0, 1.0, 0.8, 1.0, 0.0], speed=0.6)
    sent = []

    def interrupt(info: CycleInfo) -> None:
        if info.t >= 0.4 * plan.duration and not sent:
            sent.append(info.t)
            os.kill(os.getpid(), signal.SIGINT)

    exc, seen = _commands_in(robot, plan, interrupt)
    assert exc.reason is StopReason.USER and exc.exit_code == 5
    cmds = np.array([c.command for c in seen])
    dt = 1.0 / robot.motion.rate_hz
    vel = np.diff(cmds, axis=0) / dt
    acc = np.diff(vel, axis=0) / dt
    lim = robot.limits
    assert np.all(np.abs(vel) <= lim.velocity * 1.01)
    assert np.all(np.abs(acc) <= lim.acceleration * 1.05)
    assert np.max(np.abs(vel[-1])) < 0.02  # at rest at the end of the stop (one cycle)
    assert not np.allclose(cmds[-1], plan.goal[robot.executor.idx], atol=0.05)  # stopped early
    held = robot.joints()
    robot.clock.sleep_until(robot.clock.now() + 0.3)
    assert np.allclose(robot.joints(), held, atol=2e-3)  # positions stop changing
    assert all(robot.bus.torque().values())  # torque stays on


def test_servo_alarm_mid_motion_stops_and_names_the_servo(robot: Robot) -> None:
    sim = robot.bus.simulator
    plan = robot.plan_joints([0.8, -0.6, 0.9, 0.5, 0.0, 0.0])

    def fault(info: CycleInfo) -> None:
        if info.t >= 0.3 and not sim.faults:
            sim.inject(HardwareAlarm(3, Alarm.OVERLOAD))

    exc, _ = _commands_in(robot, plan, fault)
    assert exc.reason is StopReason.SERVO_ERROR
    assert exc.servo_id == 3 and exc.joint == "elbow_flex"
    assert "servo 3" in str(exc) and "overload" in str(exc)


def test_lost_servo_mid_motion_stops_and_names_the_servo(robot: Robot) -> None:
    sim = robot.bus.simulator
    plan = robot.plan_joints([0.8, -0.6, 0.9, 0.5, 0.0, 0.0])

    def unplug(info: CycleInfo) -> None:
        if info.t >= 0.3 and not sim.faults:
            sim.inject(MissingServo(2))

    exc, _ = _commands_in(robot, plan, unplug)
    assert exc.reason is StopReason.LOST_SERVO
    assert exc.servo_id == 2 and "servo 2" in str(exc) and "shoulder_lift" in str(exc)
    sim.clear_faults()


def test_excessive_tracking_error_stops(so101) -> None:
    with Robot.open(so101, exit_policy=ExitPolicy.HOLD) as robot:
        robot.executor.max_tracking_error = 0.002  # tighter than the servos can follow
        plan = robot.plan_joints([0.8, -0.6, 0.9, 0.5, 0.0, 0.0], speed=1.0)
        with pytest.raises(MotionStopped) as info:
            robot.execute(plan)
    assert info.value.reason is StopReason.TRACKING
    assert info.value.joint in so101.joint_names and "from its command" in str(info.value)


def test_second_ctrl_c_holds_and_never_applies_the_exit_policy(so101) -> None:
    with Robot.open(so101, speed=0.7, exit_policy=ExitPolicy.RELEASE) as robot:
        robot.move_joints([0.0, -0.3, 0.3, 0.0, 0.0, 0.0])
        plan = robot.plan_joints([0.6, -0.8, 0.8, 0.4, 0.0, 0.0])
        fired = []

        def twice(info: CycleInfo) -> None:
            if info.t >= 0.3 and len(fired) < 2:
                fired.append(info.t)
                os.kill(os.getpid(), signal.SIGINT)

        with pytest.raises(MotionStopped, match="held it at once"):
            robot.execute(plan, twice)
        assert all(robot.bus.torque().values())  # holding: a stop never releases the arm


def test_context_manager_applies_park_policy(so101) -> None:
    with Robot.open(so101, speed=0.7, exit_policy=ExitPolicy.PARK) as robot:
        bus = robot.bus
        sim = bus.simulator
        seen = {}
        orig_close = bus.close

        def close() -> None:
            seen.update(sim.joint_positions())
            orig_close()

        bus.close = close
    park = so101.named_pose("park")
    got = np.array([seen[n] for n in so101.joint_names])
    assert np.allclose(got, park, atol=0.02)


def test_start_outside_the_limits_is_refused_or_clipped(robot: Robot) -> None:
    from armctl.errors import JointLimitError

    sim = robot.bus.simulator
    hi = robot.arm.upper[2]
    robot.bus.set_torque(False, ["elbow_flex"])
    sim.set_joint("elbow_flex", hi + 0.01)  # pushed just past its stop: planned from the limit
    robot.hold()
    assert robot.plan_start()[2] == hi
    robot.bus.set_torque(False, ["elbow_flex"])
    sim.set_joint("elbow_flex", hi + 0.1)
    with pytest.raises(JointLimitError, match=r"elbow_flex.*present position"):
        robot.plan_joints(np.zeros(robot.arm.dof))
