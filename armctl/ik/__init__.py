"""Inverse kinematics: goals, solvers chosen by name, and their common result.

Every public name of :mod:`armctl.ik.goals` (each goal type, :class:`GoalKind`,
:class:`Tolerance`, ...) is exported here as it is defined there, so a new goal type needs no
line in this file.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from armctl.ik import goals as _goals
from armctl.ik.goals import *  # noqa: F403
from armctl.ik.goals import Goal, GoalLike, Tolerance, as_goals

if TYPE_CHECKING:
    from armctl.ik.batch import IKBatchResult, solve_batch
    from armctl.ik.nullspace import KeepOut, NullSpace
    from armctl.ik.options import CCDWeights, IKOptions
    from armctl.ik.registry import (
        Capabilities,
        SolverInfo,
        available_solvers,
        get_solver,
        solve,
        solver_info,
        solver_infos,
    )
    from armctl.ik.result import (
        ConstraintViolation,
        GoalResidual,
        IKResult,
        IKStatus,
        evaluate,
        finish,
    )

#: The names imported on first use (the solvers import numba): ``import armctl.ik`` for the
#: goal types alone stays light.
_LAZY = {
    "IKBatchResult": "batch", "solve_batch": "batch",
    "KeepOut": "nullspace", "NullSpace": "nullspace",
    "CCDWeights": "options", "IKOptions": "options",
    "Capabilities": "registry", "SolverInfo": "registry", "available_solvers": "registry",
    "get_solver": "registry", "solve": "registry", "solver_info": "registry",
    "solver_infos": "registry",
    "ConstraintViolation": "result", "GoalResidual": "result", "IKResult": "result",
    "IKStatus": "result", "evaluate": "result", "finish": "result",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


__all__ = [
    "CCDWeights",
    "Capabilities",
    "ConstraintViolation",
    "Goal",
    "GoalLike",
    "GoalResidual",
    "IKBatchResult",
    "IKOptions",
    "IKResult",
    "IKStatus",
    "KeepOut",
    "NullSpace",
    "SolverInfo",
    "Tolerance",
    "as_goals",
    "available_solvers",
    "evaluate",
    "finish",
    "get_solver",
    "solve",
    "solve_batch",
    "solver_info",
    "solver_infos",
]
__all__ += [name for name in _goals.__all__ if name not in __all__]
