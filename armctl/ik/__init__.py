"""Inverse kinematics: goals, solvers chosen by name, and their common result."""

from armctl.ik.batch import IKBatchResult, solve_batch
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
from armctl.ik.nullspace import KeepOut, NullSpace
from armctl.ik.options import IKOptions
from armctl.ik.registry import available_solvers, get_solver, solve
from armctl.ik.result import GoalError, IKResult, IKStatus, evaluate, finish

__all__ = [
    "DirectionGoal",
    "Goal",
    "GoalError",
    "GoalLike",
    "IKBatchResult",
    "IKOptions",
    "IKResult",
    "IKStatus",
    "KeepOut",
    "NullSpace",
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
    "solve_batch",
]
