"""Errors of the analytic IK solvers."""

from __future__ import annotations

from armctl.errors import InputError

__all__ = ["NoDecompositionError"]


class NoDecompositionError(InputError):
    """The chain (or the goal type) has no closed-form decomposition here.

    Args:
        problem: What is missing, naming the arm.
        fix: What to do instead.

    ``details``: ``problem`` and ``fix``.
    """

    def __init__(self, problem: str, fix: str):
        super().__init__(f"{problem}; {fix}", {"problem": problem, "fix": fix})
        self.problem = problem
        self.fix = fix
