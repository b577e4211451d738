"""IK solvers by name. Each entry is loaded only when it is first used."""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from armctl.errors import UnknownNameError
from armctl.ik.goals import Goal, GoalLike, as_goals
from armctl.ik.options import IKOptions
from armctl.ik.result import IKResult
from armctl.kinematics.model import KinematicModel

__all__ = ["Solver", "available_solvers", "get_solver", "solve"]


class Solver(Protocol):
    """The signature every registered solver implements."""

    def __call__(self, model: KinematicModel, goals: tuple[Goal, ...], q0: npt.NDArray[np.float64],
                 options: IKOptions, constraints: Sequence[Any]) -> IKResult:
        """Solve; ``q0`` is inside the limits; the result comes from :func:`result.finish`."""
        ...


#: name -> "module:function". One line per solver.
_SOLVERS: dict[str, str] = {
    "auto": "armctl.ik.auto:auto",
    "dls": "armctl.ik.numerical:dls",
    "pinv": "armctl.ik.numerical:pinv",
    "jt": "armctl.ik.numerical:jt",
    "ccd": "armctl.ik.numerical:ccd",
    "ccd-jt": "armctl.ik.numerical:ccd_jt",
    "nlp": "armctl.ik.nlp.solver:solve",
    "analytic": "armctl.ik.analytic.solver:solve",
}


def available_solvers() -> tuple[str, ...]:
    """The registered solver names."""
    return tuple(_SOLVERS)


def get_solver(name: str) -> Solver:
    """The solver registered as ``name``.

    Raises:
        UnknownNameError: Listing the registered solvers.
    """
    if name not in _SOLVERS:
        raise UnknownNameError("IK solver", name, list(_SOLVERS))
    module, func = _SOLVERS[name].split(":")
    fn: Callable[..., IKResult] = getattr(importlib.import_module(module), func)
    return fn


def solve(
    model: KinematicModel,
    goal: GoalLike,
    q0: npt.ArrayLike | None = None,
    solver: str = "auto",
    *,
    options: IKOptions | None = None,
    constraints: Sequence[Any] = (),
) -> IKResult:
    """Solve inverse kinematics.

    Args:
        model: The arm.
        goal: A goal, several goals, or a ``(4, 4)`` tool pose.
        q0: Starting configuration (clipped into the limits); the middle of the ranges when
            ``None``.
        solver: Registered solver name (see :func:`available_solvers`).
        options: Budgets and seed.
        constraints: Extra constraints (only solvers that support them accept any).

    Returns:
        The result; ``result.success`` says whether every goal was reached inside the limits.
    """
    goals = as_goals(goal)
    for g in goals:
        model.frame_index(g.frame)  # unknown frames fail before any work
    start = model.middle() if q0 is None else model.clip(q0)
    fn = get_solver(solver)
    return fn(model, goals, start, options or IKOptions(), tuple(constraints))
