"""The arms LeRobot users own follow their own default-speed plans on their simulated buses.

The simulated servos lag a streamed goal as real ones do at factory gains (XL430-W250 and
XL330 on the Koch, STS3215 on the SO-101 leader): the bundled default speed must keep that lag
inside the tracking limit, for large moves from the middle of the range.
"""

from __future__ import annotations

import numpy as np
import pytest
from collision_free import free_goal

from armctl.arm import load_arm
from armctl.config.motion import ExitPolicy
from armctl.ik import PositionGoal
from armctl.robot import Robot

pytestmark = pytest.mark.timeout(120)


@pytest.mark.parametrize("name", ["koch_follower", "koch_leader", "so101_leader"])
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_default_speed_moves_arrive(name: str, seed: int) -> None:
    arm = load_arm(name)
    rng = np.random.default_rng(seed)

    def draw() -> np.ndarray:
        q = arm.middle() + 0.8 * (arm.sample(rng) - arm.middle())
        return np.clip(q, arm.lower + 0.05, arm.upper - 0.05)

    with Robot.open(arm, exit_policy=ExitPolicy.HOLD) as robot:
        assert robot.collisions is not None
        # the first random goal that the arm reaches without hitting the table or itself
        q_goal = free_goal(robot.collisions, robot.plan_start(), draw)
        robot.move_joints(q_goal)
        measured = robot.joints()
    assert np.max(np.abs(measured - q_goal)) < 0.01  # the arrival tolerance
    assert np.linalg.norm(arm.fk(measured)[:3, 3] - arm.fk(q_goal)[:3, 3]) < 2e-3


def test_walked_through_koch_pose_arrives_at_default_speed() -> None:
    """The tool 15 cm in front of the base, 5 cm up: a pan of about 115 degrees."""
    arm = load_arm("koch_follower")
    target = np.array([0.15, 0.0, 0.05])
    with Robot.open(arm, exit_policy=ExitPolicy.HOLD) as robot:
        report = robot.move_to_pose(PositionGoal(target))
        measured = robot.joints()
    assert np.linalg.norm(arm.fk(measured)[:3, 3] - target) < 2e-3
    assert report.position_error < 2e-3
