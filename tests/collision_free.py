"""Collision-free goals for tests about something else (arrival, limits, alarms, clamping).

Every plan a :class:`~armctl.robot.Robot` makes or runs is checked for contacts between its
links, the table and the obstacles. A test about another property draws its random goals with
these helpers: it keeps drawing from the same generator until a goal is free and the straight
joint-space line to it from the start is free (joint moves follow that line), so the test
still runs on random goals and still proves what it is about.

(A plain module rather than conftest.py, as :mod:`armctl_testpaths`.)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

import numpy as np
import numpy.typing as npt

from armctl.collision.errors import CollisionError
from armctl.collision.model import CollisionModel
from armctl.ik import Goal
from armctl.robot import Robot
from armctl.typing import Array

__all__ = ["free_goal", "free_pose_goal"]

G = TypeVar("G", bound=Goal)

#: How many draws a helper makes before it gives up (the test then fails, naming the cause).
TRIES = 200


def free_goal(checker: CollisionModel, start: npt.ArrayLike, draw: Callable[[], Array],
              tries: int = TRIES) -> Array:
    """The first drawn configuration that is free and reachable from ``start`` in a line.

    Args:
        checker: The collision model the robot checks its plans against (``robot.collisions``).
        start: Where the move starts [rad]/[m].
        draw: Gives a candidate goal (e.g. a random configuration from a seeded generator).
        tries: How many candidates to draw at most.

    Raises:
        AssertionError: No candidate was free.
    """
    q0 = np.asarray(start, dtype=float)
    for _ in range(tries):
        q = np.asarray(draw(), dtype=float)
        if checker.free(q) and checker.segment_free(q0, q):
            return q
    raise AssertionError(f"no collision-free goal from {q0} in {tries} draws")


def free_pose_goal(robot: Robot, draw: Callable[[], Array], goal_of: Callable[[Array], G],
                   tries: int = TRIES) -> tuple[Array, G]:
    """A drawn configuration, and the goal made of it, that the robot can move to without contact.

    The goal is planned as :meth:`Robot.move_to_pose` plans it (IK from the present joints, a
    joint move to the answer), which may reach it in another configuration than the one drawn:
    a candidate counts only when both that configuration and the planned move are free.

    Args:
        robot: The robot (its collision model and its present joints).
        draw: Gives a candidate configuration.
        goal_of: Makes the goal of a configuration (e.g. its tool position).
        tries: How many candidates to draw at most.

    Raises:
        AssertionError: No candidate was free.
    """
    checker = robot.collisions
    assert checker is not None, "the robot checks no collisions"
    start = robot.plan_start()
    for _ in range(tries):
        q = np.asarray(draw(), dtype=float)
        if not (checker.free(q) and checker.segment_free(start, q)):
            continue
        goal = goal_of(q)
        try:
            robot.plan_pose(goal)  # plans and checks; moves nothing
        except CollisionError:
            continue
        return q, goal
    raise AssertionError(f"no collision-free pose goal from {start} in {tries} draws")
