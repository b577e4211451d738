"""A joint that something blocks stops pushing once the move has failed.

Pressing on an obstacle at the full goal error draws the servo's stall current and heats it
until its overheating alarm; after a failed move the blocked joint holds where it stopped.
"""

from __future__ import annotations

import numpy as np
import pytest
from armctl_testpaths import REPO

from armctl.config.motion import ExitPolicy
from armctl.robot import MotionStopped, Robot, StopReason
from armctl.servo import ArmBus, Obstacle, Register

pytestmark = pytest.mark.timeout(60)

SO_SIM = REPO / "tests" / "servo" / "data" / "so_sim.yaml"


def _present_and_goal(bus: ArmBus, servo_id: int) -> tuple[int, int]:
    assert bus.simulator is not None
    servo = bus.simulator.servo(servo_id)
    spec = servo.table.spec(Register.PRESENT_POSITION)
    data = servo.read(spec.address, spec.size)
    assert data is not None
    present = servo.get(Register.PRESENT_POSITION)
    return present, servo.get(Register.GOAL_POSITION)


@pytest.mark.parametrize("speed", [0.2, 1.0])  # blocked at the end (not reached) or on the way
def test_a_blocked_joint_holds_where_it_stopped(speed: float) -> None:
    with Robot.open(SO_SIM, exit_policy=ExitPolicy.HOLD) as robot:
        bus: ArmBus = robot.bus  # type: ignore[assignment]
        wrist = bus.mapping.joint("wrist_flex")
        assert bus.simulator is not None
        bus.simulator.inject(Obstacle(wrist.servo_id, round(wrist.to_ticks(0.1))))
        goal = np.array([0.0, 0.0, 0.0, 0.6, 0.0, 0.0])
        with pytest.raises(MotionStopped) as info:
            robot.move_joints(goal, speed=speed)
        exc = info.value
        assert exc.reason in (StopReason.NOT_REACHED, StopReason.TRACKING)
        assert exc.joint == "wrist_flex"
        present, held_goal = _present_and_goal(bus, wrist.servo_id)
        # the goal register is where the joint stopped (a few ticks), not 0.6 rad beyond it
        assert abs(held_goal - present) <= 8, (present, held_goal)
        held = np.asarray(exc.held)
        assert abs(held[3] - 0.1) < 0.02  # the reported hold is the stop, not the old goal
        # the other joints still hold their goals
        assert np.allclose(held[[0, 1, 2, 4]], goal[[0, 1, 2, 4]], atol=0.02)
