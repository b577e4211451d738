"""Errors of the IK solvers."""

from __future__ import annotations

from typing import Any

from armctl.errors import NoSolutionError
from armctl.ik.result import IKResult

__all__ = ["IKFailedError"]


class IKFailedError(NoSolutionError):
    """An IK goal was not reached; the closest configuration found is attached.

    Args:
        result: The solver's result (``success`` False).
        text: The message: what failed, the closest pose and the remaining error.
        details: Machine-readable data for ``--json`` output (closest q, pose, errors, status).
    """

    def __init__(self, result: IKResult, text: str, details: dict[str, Any] | None = None):
        self.result = result
        self.details = details or {}
        super().__init__(text)
