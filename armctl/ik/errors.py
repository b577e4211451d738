"""Errors of the IK solvers."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from armctl.errors import InputError, NoSolutionError
from armctl.ik.result import IKResult

__all__ = ["IKFailedError", "UnsupportedGoalError"]


class IKFailedError(NoSolutionError):
    """An IK goal was not reached; the closest configuration found is attached.

    Args:
        result: The solver's result (``success`` False).
        text: The message: what failed, the closest pose and the remaining error.
        details: The closest configuration, its pose, errors and the solver's status, as data
            (the keys are the caller's; :func:`armctl.robot.unreachable.unreachable` lists
            those of a goal the arm cannot reach).
    """

    def __init__(self, result: IKResult, text: str, details: Mapping[str, Any] | None = None):
        self.result = result
        super().__init__(text, details)


class UnsupportedGoalError(InputError):
    """A solver was asked for what its capabilities exclude.

    A goal kind, several goals or constraints it does not take; the message names the solvers
    that can.

    Args:
        text: The message.
        solver: The solver's name.

    ``details``: ``solver``.
    """

    def __init__(self, text: str, solver: str):
        self.solver = solver
        super().__init__(text, {"solver": solver})
