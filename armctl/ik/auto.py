"""``auto``: the default solver, chosen for the arm and the goal.

1. Damped least squares (Levenberg-Marquardt) with random restarts: the numerical method that
   measured best on every arm and goal type (docs/ik-methods.md), and the fastest.
2. When that fails and the goal is one whose frame is moved by exactly as many joints as the
   goal constrains (a 6-joint arm and a pose, a 5-joint arm and a position + direction goal,
   ...), the closed-form solver registered as ``"analytic"`` is tried, if it has a
   decomposition for the arm (remembered per arm, frame and goal type): it enumerates every
   solution, so it settles goals near the limits or singularities that the restarts missed.

The better of the two answers is returned; ``success`` is decided by
:func:`armctl.ik.result.finish` as always.
"""

from __future__ import annotations

import importlib
import time
import weakref
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from armctl.ik.goals import Goal
from armctl.ik.numerical import check_no_constraints, run_method
from armctl.ik.options import IKOptions
from armctl.ik.result import IKResult, finish
from armctl.kinematics.model import KinematicModel

__all__ = ["auto"]

Array = npt.NDArray[np.float64]

#: per model: (frame, goal type) -> whether the analytic solver has a closed form for it
_CLOSED_FORM: weakref.WeakKeyDictionary[KinematicModel, dict[tuple[str | None, type], bool]] = (
    weakref.WeakKeyDictionary())


def _analytic(model: KinematicModel, goals: tuple[Goal, ...],
              options: IKOptions) -> Callable[..., IKResult] | None:
    """The analytic solver when it should be tried for these goals, else None."""
    from armctl.ik.registry import _SOLVERS, get_solver

    if len(goals) != 1 or options.nullspace is not None or "analytic" not in _SOLVERS:
        return None
    goal = goals[0]
    if len(model.chain(goal.frame)) != goal.dof:
        return None
    if _CLOSED_FORM.setdefault(model, {}).get((goal.frame, type(goal))) is False:
        return None
    return get_solver("analytic")


def _no_closed_form() -> tuple[type[BaseException], ...]:
    """The exception the analytic package raises for an arm without a closed form."""
    try:
        pkg = importlib.import_module("armctl.ik.analytic")
    except ImportError:
        return ()
    err = getattr(pkg, "NoDecompositionError", None)
    return (err,) if isinstance(err, type) and issubclass(err, BaseException) else ()


def auto(model: KinematicModel, goals: tuple[Goal, ...], q0: Array, options: IKOptions,
         constraints: Sequence[Any]) -> IKResult:
    """The best default: DLS with restarts, then the closed form where it applies."""
    started = time.perf_counter()
    check_no_constraints("auto", constraints)
    res = run_method("dls", model, goals, q0, options, (), started=started, label="auto")
    if res.success:
        return res
    analytic = _analytic(model, goals, options)
    if analytic is None:
        return res
    goal = goals[0]
    try:
        closed = analytic(model, goals, q0, options, ())
    except _no_closed_form():
        _CLOSED_FORM[model][(goal.frame, type(goal))] = False
        return res
    _CLOSED_FORM[model][(goal.frame, type(goal))] = True
    if not closed.success:
        return res
    return finish(model, goals, closed.q, solver="auto", status=closed.status,
                  iterations=res.iterations, restarts=res.restarts, started=started,
                  message="closed form after the numerical search failed")
