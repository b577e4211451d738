"""``Robot.move_to_pose(on_plan=...)``: the plan is shown before anything moves, or skipped."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.config.motion import ExitPolicy
from armctl.ik import PositionGoal
from armctl.robot import Robot


@pytest.fixture
def robot() -> Iterator[Robot]:
    """The bundled SO-101 on its simulated bus, holding its start pose."""
    with Robot.open(load_arm("so101"), speed=0.7, exit_policy=ExitPolicy.HOLD) as r:
        yield r


def _goal(robot: Robot) -> PositionGoal:
    """A reachable tool position a little away from the present one."""
    q = robot.joints()
    q[:3] += [0.2, -0.15, 0.2]
    return PositionGoal(robot.arm.fk(q)[:3, 3])


def test_on_plan_false_moves_nothing(robot: Robot) -> None:
    goal = _goal(robot)
    before = robot.joints()
    seen: list[Any] = []
    report = robot.move_to_pose(goal, on_plan=lambda plan, ik: seen.append((plan, ik)) or False)
    (plan, ik), = seen
    assert report.plan is plan and report.ik is ik and ik is not None
    assert report.result is None and report.reached is None  # as a dry run
    assert np.allclose(robot.joints(), before, atol=1e-3)


def test_on_plan_true_runs_the_plan_it_was_shown(robot: Robot) -> None:
    goal = _goal(robot)
    seen: list[Any] = []
    report = robot.move_to_pose(goal, on_plan=lambda plan, ik: seen.append(plan) or True)
    assert seen == [report.plan] and report.result is not None
    assert report.position_error < 2e-3
    assert np.linalg.norm(robot.pose()[:3, 3] - goal.position) < 2e-3


def test_a_straight_line_is_shown_without_an_ik_result(robot: Robot) -> None:
    seen: list[Any] = []
    report = robot.move_to_pose(_goal(robot), linear=True,
                                on_plan=lambda plan, ik: seen.append(ik) or False)
    assert seen == [None] and report.result is None and report.plan.duration > 0
