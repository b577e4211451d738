"""Inverse kinematics: goals, solvers chosen by name, and their common result."""

from armctl.ik.goals import (
    DirectionGoal,
    Goal,
    GoalLike,
    OrientationGoal,
    PoseGoal,
    PositionGoal,
    Tolerance,
    as_goals,
)
from armctl.ik.options import IKOptions
from armctl.ik.registry import available_solvers, get_solver, solve
from armctl.ik.result import GoalError, IKResult, IKStatus, evaluate, finish

__all__ = [
    "DirectionGoal",
    "Goal",
    "GoalError",
    "GoalLike",
    "IKOptions",
    "IKResult",
    "IKStatus",
    "OrientationGoal",
    "PoseGoal",
    "PositionGoal",
    "Tolerance",
    "as_goals",
    "available_solvers",
    "evaluate",
    "finish",
    "get_solver",
    "solve",
]
