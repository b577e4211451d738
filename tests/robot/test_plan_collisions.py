"""Every plan a robot makes or runs is checked for contacts before anything moves."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from armctl.collision import CollisionError, ContactKind
from armctl.config.motion import ExitPolicy
from armctl.config.scene import Obstacle, SceneSpec, TableSpec
from armctl.config.schema import Box, Origin
from armctl.errors import InputError
from armctl.ik import PositionGoal
from armctl.motion import Keyframe, KeyframeProgram, plan_joint_move
from armctl.motion.detour import DetourOptions, Planner
from armctl.robot import Robot

pytestmark = pytest.mark.timeout(120)

WALL = Obstacle("wall", Box((0.12, 0.02, 0.15), Origin((0.22, 0.0, 0.075))))
SCENE = SceneSpec(TableSpec(0.0), (WALL,))


@pytest.fixture
def robot() -> Iterator[Robot]:
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD, scene=SCENE) as r:
        yield r


def _sides(r: Robot) -> tuple[np.ndarray, np.ndarray]:
    arm = r.arm
    left = arm.ik(PositionGoal(np.array([0.2, 0.12, 0.06])), q0=np.zeros(arm.dof)).q
    right = arm.ik(PositionGoal(np.array([0.2, -0.12, 0.06])), q0=np.zeros(arm.dof)).q
    return np.asarray(left), np.asarray(right)


def test_a_pose_below_the_table_is_refused_and_nothing_moves() -> None:
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD) as robot:  # the default scene
        before = robot.joints()
        with pytest.raises(CollisionError) as err:
            robot.move_to_pose(xyz=[0.2, 0.0, -0.15])
        after = robot.joints()
    c = err.value.contact
    assert c.kind is ContactKind.SCENE and c.b == "table"
    # every IK answer of the goal is in the table: refused before any plan, with the depth
    assert "IK answer" in str(err.value)
    assert c.time is None and c.distance < -0.05
    d = err.value.details
    assert d["pair"][1] == "table" and set(d["q"]) == set(robot.arm.joint_names)
    assert np.allclose(after, before, atol=1e-3)


def test_a_move_through_the_wall_is_refused_with_the_first_contact(robot: Robot) -> None:
    left, right = _sides(robot)
    robot.move_joints(left)
    with pytest.raises(CollisionError) as err:
        robot.move_joints(right)
    c = err.value.contact
    assert "wall" in (c.a, c.b)
    # the reported configuration is where the pair first comes within the padding
    model = robot.collisions
    assert model is not None
    assert model.slacks(c.q)[c.pair_index] == pytest.approx(0.0, abs=2e-4)
    assert np.allclose(robot.joints(), left, atol=0.02)


def test_a_plan_made_elsewhere_is_refused_by_execute(robot: Robot) -> None:
    left, right = _sides(robot)
    robot.move_joints(left)
    plan = plan_joint_move(robot.plan_start(), right, robot.limits)  # no collision check
    with pytest.raises(CollisionError):
        robot.execute(plan)
    assert np.allclose(robot.joints(), left, atol=0.02)


def test_keyframe_playback_through_the_wall_is_refused(robot: Robot) -> None:
    left, right = _sides(robot)
    robot.move_joints(left)
    prog = KeyframeProgram("so101", robot.arm.joint_names,
                           (Keyframe(tuple(left)), Keyframe(tuple(right))))
    with pytest.raises(CollisionError):
        robot.play(prog)


@pytest.mark.parametrize("planner", [Planner.OMPL, Planner.BUILTIN])
def test_a_detour_goes_around_the_wall(robot: Robot, planner: Planner) -> None:
    left, right = _sides(robot)
    robot.move_joints(left)
    report = robot.move_joints(right, detour=DetourOptions(planner=planner, time_budget=5.0))
    assert np.allclose(robot.joints()[:5], right[:5], atol=0.02)
    # the executed plan, sampled densely, keeps every pair out of contact
    plan = report.plan
    ts = np.linspace(0.0, plan.duration, 2000)
    q, _, _ = plan.trajectory.sample_many(ts)
    model = robot.collisions
    assert model is not None and bool(model.free_batch(q).all())


def test_a_straight_line_is_never_replaced_by_a_detour(robot: Robot) -> None:
    with pytest.raises(InputError, match="never replaced by a detour"):
        robot.move_to_pose(xyz=[0.2, -0.12, 0.06], linear=True, detour=DetourOptions())


def test_an_arm_resting_in_contact_may_move_out_but_not_deeper() -> None:
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD, hold=False) as r:
        model = r.collisions
        assert model is not None
        sim = r.bus.simulator  # type: ignore[attr-defined]
        # put down by hand with the gripper on the table (torque off)
        down = r.arm.ik(PositionGoal(np.array([0.25, 0.0, 0.005])), q0=np.zeros(r.arm.dof)).q
        for name, v in zip(r.arm.joint_names, down, strict=True):
            sim.set_joint(name, float(v))
        start = r.plan_start()
        assert not model.free(start)
        up = r.arm.ik(PositionGoal(np.array([0.25, 0.0, 0.12])), q0=start).q
        deeper = r.arm.ik(PositionGoal(np.array([0.25, 0.0, -0.03])), q0=start).q
        with pytest.raises(CollisionError):
            r.plan_joints(deeper)
        r.move_joints(up)
        assert model.free(r.joints())


def test_a_refusal_from_a_start_in_contact_says_the_arm_starts_in_contact() -> None:
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD, hold=False) as r:
        sim = r.bus.simulator  # type: ignore[attr-defined]
        down = r.arm.ik(PositionGoal(np.array([0.25, 0.0, 0.005])), q0=np.zeros(r.arm.dof)).q
        for name, v in zip(r.arm.joint_names, down, strict=True):
            sim.set_joint(name, float(v))
        deeper = r.arm.ik(PositionGoal(np.array([0.25, 0.0, -0.03])), q0=r.plan_start()).q
        with pytest.raises(CollisionError, match="The arm starts in contact"):
            r.plan_joints(deeper)
