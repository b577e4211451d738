"""Jogging on the simulated bus in simulated time: steps, refusals, stops and keyframes.

Poses are checked with plain rotation matrices and FK of the joints read back, never against
the jogger's own numbers.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from armctl.collision import CollisionError
from armctl.config.motion import ExitPolicy
from armctl.config.scene import Obstacle, SceneSpec, TableSpec
from armctl.config.schema import Box, Origin
from armctl.errors import InputError, JointLimitError
from armctl.ik import PoseGoal, Tolerance
from armctl.motion import load_keyframes
from armctl.robot import Robot
from armctl.robot.executor import CycleInfo
from armctl.robot.jog import AXES, Jogger, JogMode, JogResult, JogSteps
from armctl.robot.teach import TeachSession

pytestmark = pytest.mark.timeout(120)

TICK = 2 * math.pi / 4096  # STS3215 resolution [rad]
#: A block beside the SO-101's gripper at its home pose (tool point at about x 0.39, z 0.23 m),
#: 17 mm clear of it on the -y side.
BLOCK = Obstacle("block", Box((0.06, 0.02, 0.08), Origin((0.39, -0.045, 0.226))))


@pytest.fixture
def robot() -> Iterator[Robot]:
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD) as r:
        yield r


def rot(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' formula, written out here."""
    a = axis / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def angle_between(a: np.ndarray, b: np.ndarray) -> float:
    return math.acos(max(-1.0, min(1.0, (float(np.trace(a.T @ b)) - 1) / 2)))


def test_joint_steps_add_up_exactly_and_move_only_that_joint(robot: Robot) -> None:
    jog = Jogger(robot, JogSteps((math.radians(1), math.radians(5)), (0.001, 0.005)))
    before = robot.joints()
    jog.select(1)  # shoulder_lift
    jog.bigger_step()
    outcomes = [jog.jog(-1) for _ in range(3)]
    assert [o.result for o in outcomes] == [JogResult.MOVED] * 3
    assert outcomes[-1].report is not None
    goal = outcomes[-1].report.plan.goal
    expected = before.copy()
    expected[1] -= 3 * math.radians(5)
    # the steps add up to exactly three steps (the servo's settling does not accumulate)
    assert np.allclose(goal, expected, atol=1e-9)
    assert np.allclose(robot.joints(), expected, atol=2 * TICK)
    assert jog.steps_run == 3 and jog.refusals == 0


def test_step_and_speed_keys_stay_in_their_ranges(robot: Robot) -> None:
    jog = Jogger(robot, speed=0.3)
    assert jog.step_of("shoulder_pan") == (pytest.approx(math.radians(1)), False)
    for _ in range(5):
        jog.bigger_step()
    assert jog.step_of("shoulder_pan")[0] == pytest.approx(math.radians(10))
    jog.set_mode(JogMode.TOOL)
    assert jog.step_of("z") == (pytest.approx(0.020), True)
    assert jog.step_of("rz") == (pytest.approx(math.radians(10)), False)
    for _ in range(9):
        jog.faster()
    assert jog.speed == 1.0
    for _ in range(9):
        jog.slower()
    assert jog.speed == pytest.approx(0.05)
    with pytest.raises(InputError, match="no axis 7"):
        jog.select(6)
    jog.set_mode(JogMode.JOINT)
    with pytest.raises(InputError, match="no joint 6"):
        jog.select(5)  # the gripper is not jogged as a joint: o and c open and close it


@pytest.mark.parametrize(("rotary", "linear", "words"), [
    ((), (0.001,), "at least one rotary"),
    ((0.1,), (-0.001,), "more than 0"),
    ((math.radians(90),), (0.001,), "more than 45 deg"),
    ((0.1,), (0.5,), "more than 100 mm"),
    ((0.1, 0.2), (0.001,), "as many"),
])
def test_bad_step_sizes_are_refused(rotary: tuple[float, ...], linear: tuple[float, ...],
                                    words: str) -> None:
    with pytest.raises(InputError, match=words):
        JogSteps(rotary, linear)


def test_a_step_beyond_the_limit_is_refused_naming_the_joint_and_limit(robot: Robot) -> None:
    jog = Jogger(robot, JogSteps((math.radians(10),), (0.01,)), speed=1.0)
    jog.select(4)  # wrist_roll, upper limit 2.84121 rad (162.8 deg) in the config
    upper = float(robot.arm.upper[4])
    results = [jog.jog(1).result for _ in range(20)]
    refused = results.index(JogResult.REFUSED)
    assert all(r is JogResult.MOVED for r in results[:refused])
    held = robot.joints()
    assert upper - math.radians(10) <= held[4] <= upper + 2 * TICK
    outcome = jog.jog(1)
    assert outcome.result is JogResult.REFUSED
    assert isinstance(outcome.error, JointLimitError) and outcome.error.joint == "wrist_roll"
    assert "wrist_roll" in outcome.message and "upper limit" in outcome.message
    assert f"{math.degrees(upper):.1f} deg" in outcome.message
    assert "(config)" in outcome.message  # where the limit comes from
    assert np.allclose(robot.joints(), held, atol=1e-12)  # nothing moved


def test_steps_into_a_scene_box_are_refused_naming_the_pair() -> None:
    scene = SceneSpec(TableSpec(0.0), (BLOCK,))
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD, scene=scene) as robot:
        jog = Jogger(robot, JogSteps((math.radians(10),), (0.02,)), speed=0.5)
        before = robot.joints()
        jog.set_mode(JogMode.BASE)
        jog.select(AXES.index("y"))
        outcome = jog.jog(-1)  # 20 mm toward the block
        assert outcome.result is JogResult.REFUSED
        assert isinstance(outcome.error, CollisionError)
        assert "block" in (outcome.error.contact.a, outcome.error.contact.b)
        assert "block" in outcome.message and "padding" in outcome.message
        assert np.allclose(robot.joints(), before, atol=1e-12)
        # the other way is free: the same step moves the tool 20 mm along +y
        p0 = robot.pose()[:3, 3]
        assert jog.jog(1).result is JogResult.MOVED
        assert np.allclose(robot.pose()[:3, 3] - p0, [0, 0.02, 0], atol=1e-3)
        # a joint step that swings the gripper into the block is refused too
        jog.set_mode(JogMode.JOINT)
        jog.select(0)
        swings = [jog.jog(1) for _ in range(4)]
        refused = [o for o in swings if o.result is JogResult.REFUSED]
        assert refused and isinstance(refused[0].error, CollisionError)
        assert "block" in refused[0].message


def test_a_5_dof_arm_refuses_rotations_it_cannot_make(robot: Robot) -> None:
    jog = Jogger(robot, JogSteps((math.radians(5),), (0.005,)), speed=0.5)
    assert jog.few_joints
    jog.set_mode(JogMode.TOOL)
    jog.select(AXES.index("rx"))  # about the tool's own x: not with these five joints here
    before = robot.joints()
    pose = robot.pose()
    outcome = jog.jog(1)
    assert outcome.result is JogResult.REFUSED
    assert "5 joints cannot turn the tool about tool x here" in outcome.message
    assert "tool frame's x axis while keeping the tool point in place" in outcome.detail
    assert np.allclose(robot.joints(), before, atol=1e-12)
    # independently: from many starts, no IK answer keeps the tool point and turns it 5 deg
    # about its x
    target = pose.copy()
    target[:3, :3] = pose[:3, :3] @ rot(np.array([1.0, 0, 0]), math.radians(5))
    rng = np.random.default_rng(3)
    goal = PoseGoal(target, tolerance=Tolerance(1e-3, math.radians(0.5)))
    for q0 in [before, *robot.arm.sample(rng, 20)]:
        assert not robot.arm.ik(goal, q0=q0).success
    # the axes the refusal names as possible are: each turns the tool 5 deg about that axis
    # with the tool point in place (FK of the joints read back)
    assert isinstance(outcome.error, InputError)
    can = outcome.error.details["turnable"]
    assert "rz" in can and f"here it can turn the tool about tool {' and '.join(can)}" in \
        outcome.detail
    assert f"they can about: {', '.join('tool ' + a for a in can)}" in outcome.message
    for name in can:
        jog.select(AXES.index(name))
        start = robot.pose()
        assert jog.jog(1).result is JogResult.MOVED
        after = robot.pose()
        assert np.linalg.norm(after[:3, 3] - start[:3, 3]) < 1.5e-3
        axis = np.eye(3)[AXES.index(name) - 3]
        turned = start[:3, :3] @ rot(axis, math.radians(5))
        assert angle_between(turned, after[:3, :3]) < math.radians(0.6)


def test_cartesian_steps_of_a_6_dof_arm_in_base_and_tool_frames() -> None:
    with Robot.open("ur5e", exit_policy=ExitPolicy.HOLD, sim=True) as robot:
        jog = Jogger(robot, JogSteps((math.radians(5),), (0.01,)), speed=0.5)
        assert not jog.few_joints
        t0 = robot.arm.fk(jog.stepping_from())
        jog.set_mode(JogMode.BASE)
        jog.select(AXES.index("rx"))
        out = jog.jog(1)
        assert out.result is JogResult.MOVED and out.report is not None
        t1 = robot.arm.fk(out.report.plan.waypoints[-1].q)  # the goal sent
        assert np.allclose(t1[:3, 3], t0[:3, 3], atol=1e-4)  # through the tool point
        assert angle_between(rot(np.array([1.0, 0, 0]), math.radians(5)) @ t0[:3, :3],
                             t1[:3, :3]) < math.radians(0.05)
        # not the turn about the tool's own x (the tool's x is not the base's here)
        assert angle_between(t0[:3, :3] @ rot(np.array([1.0, 0, 0]), math.radians(5)),
                             t1[:3, :3]) > math.radians(1)
        measured = robot.pose()  # the servos settle within a tick or two of the goal
        assert np.allclose(measured[:3, 3], t1[:3, 3], atol=1.5e-3)
        jog.set_mode(JogMode.TOOL)
        jog.select(AXES.index("z"))
        out = jog.jog(-1)
        assert out.result is JogResult.MOVED and out.report is not None
        t2 = robot.arm.fk(out.report.plan.waypoints[-1].q)
        assert np.allclose(t2[:3, 3] - t1[:3, 3], -0.01 * t1[:3, 2], atol=1e-4)
        assert angle_between(t1[:3, :3], t2[:3, :3]) < math.radians(0.05)  # kept


def test_stop_during_a_step_decelerates_and_holds(robot: Robot) -> None:
    jog = Jogger(robot, JogSteps((math.radians(40),), (0.05,)), speed=0.1)
    start = robot.joints()[0]
    seen: list[CycleInfo] = []

    def press_space(info: CycleInfo) -> None:
        seen.append(info)
        if info.t >= info.duration / 3 and not info.stopping:
            jog.stop("the space key")

    outcome = jog.jog(1, press_space)
    assert outcome.result is JogResult.STOPPED
    assert "stopped" in outcome.message and "the space key" in outcome.detail
    assert any(c.stopping for c in seen)
    robot.clock.sleep_until(robot.clock.now() + 0.3)
    held = robot.joints()[0]
    assert start < held < start + math.radians(40) - 0.05  # short of the goal
    robot.clock.sleep_until(robot.clock.now() + 0.3)
    assert abs(robot.joints()[0] - held) < 2 * TICK  # holds
    # the next step starts from where the arm holds, not from the abandoned goal
    jog2 = Jogger(robot, JogSteps((math.radians(1),), (0.001,)), speed=0.5)
    jog.steps = jog2.steps
    out = jog.jog(1)
    assert out.report is not None
    assert out.report.plan.goal[0] == pytest.approx(held + math.radians(1), abs=3 * TICK)


def test_gripper_and_home_and_refusals_without_a_pose(robot: Robot) -> None:
    jog = Jogger(robot, speed=1.0)
    g = robot.arm.joint_index("gripper")
    assert jog.gripper(True).result is JogResult.MOVED
    assert robot.joints()[g] == pytest.approx(float(robot.arm.upper[g]), abs=0.02)
    assert jog.gripper(False).result is JogResult.MOVED
    assert robot.joints()[g] == pytest.approx(float(robot.arm.lower[g]), abs=0.02)
    jog.select(2)
    jog.bigger_step()
    assert jog.jog(1).result is JogResult.MOVED
    assert jog.home().result is JogResult.MOVED
    home = robot.arm.named_pose("home")
    arm_joints = [robot.arm.joint_index(n) for n in jog.joints]
    assert np.allclose(robot.joints()[arm_joints], home[arm_joints], atol=2 * TICK)


def test_keyframes_are_recorded_and_replay(robot: Robot, tmp_path: Path) -> None:
    path = tmp_path / "jogged.yaml"
    session = TeachSession(robot, path)
    jog = Jogger(robot, JogSteps((math.radians(5),), (0.01,)), speed=0.8, session=session)
    expected = []
    for joint, sign in ((0, 1), (1, -1), (2, 1)):
        jog.select(joint)
        assert jog.jog(sign).result is JogResult.MOVED
        jog.record()
        expected.append(robot.joints()[:5].copy())
    jog.record()
    assert jog.undo() is not None  # the last one is gone again
    session.finish()
    program = load_keyframes(path, robot.arm)
    assert len(program.keyframes) == 3
    # the values are the steps sent (the file keeps 7 digits); the arm held them within the
    # servos' settling
    steps = np.array([[5, 0, 0], [5, -5, 0], [5, -5, 5]], dtype=float)
    for kf, s, q in zip(program.keyframes, steps, expected, strict=True):
        assert kf.q is not None
        assert np.allclose(np.degrees(kf.q[:3]), s, atol=1e-5)
        assert np.allclose(kf.q, q, atol=2 * TICK)
        assert kf.gripper == pytest.approx(0.0, abs=1e-9)
    # the program replays: back to the first keyframe and through the others
    jog.home()
    report = robot.play(program)
    assert report.result is not None
    assert np.allclose(report.result.final[:5], expected[-1], atol=0.02)


def test_record_without_a_file_is_refused(robot: Robot) -> None:
    jog = Jogger(robot)
    with pytest.raises(InputError, match="no keyframe file"):
        jog.record()
