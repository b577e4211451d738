"""``auto``: the default solver, chosen for the arm and the goal.

1. Damped least squares (Levenberg-Marquardt) with random restarts: the numerical method that
   measured best on every arm and goal type (docs/ik-methods.md), and the fastest.
2. When that fails and the goal is one whose frame is moved by exactly as many joints as the
   goal constrains (a 6-joint arm and a pose, a 5-joint arm and a position + direction goal,
   ...), a registered closed-form solver (capabilities: all solutions, the goal's kind;
   ``"analytic"``) is tried, if it has a decomposition for the arm (remembered per arm, frame
   and goal type): it enumerates every solution, so it settles goals near the limits or
   singularities that the restarts missed.

The better of the two answers is returned; ``success`` is decided by
:func:`armctl.ik.result.finish` as always. With a collision checker (``options.avoid``) both
steps keep only answers free of contact (the closed form: the nearest free solution); when
every answer collides, the one with the shallowest contact is returned as ``COLLIDES``.
"""

from __future__ import annotations

import importlib
import time
import weakref
from collections.abc import Callable, Sequence
from typing import Any

from armctl.ik.goals import Goal
from armctl.ik.numerical import check_no_constraints, run_method, solve_goal
from armctl.ik.options import IKOptions
from armctl.ik.result import IKResult, IKStatus, finish
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["auto", "auto_goal", "closed_form"]


#: per model: (frame, goal type) -> whether the analytic solver has a closed form for it
_CLOSED_FORM: weakref.WeakKeyDictionary[KinematicModel, dict[tuple[str | None, type], bool]] = (
    weakref.WeakKeyDictionary())


def _analytic(model: KinematicModel, goals: tuple[Goal, ...],
              options: IKOptions) -> Callable[..., IKResult] | None:
    """A registered closed-form solver when one should be tried for these goals, else None.

    The registry's capabilities decide: a solver that lists every solution and solves the
    goal's kind, for one goal whose frame is moved by exactly as many joints as it constrains.
    """
    from armctl.ik.registry import get_solver, solver_infos

    if len(goals) != 1 or options.nullspace is not None:
        return None
    goal = goals[0]
    closed = [info for info in solver_infos() if info.capabilities.all_solutions
              and info.capabilities.solves(goal.kind)]
    if not closed or len(model.chain(goal.frame)) != goal.dof:
        return None
    if _CLOSED_FORM.setdefault(model, {}).get((goal.frame, type(goal))) is False:
        return None
    return get_solver(closed[0].name)


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
    return _closed_form(model, goals, q0, options, res, started)


def auto_goal(model: KinematicModel, goal: Goal, q0: Any,
              options: IKOptions | None) -> IKResult | None:
    """:func:`auto` for one goal by the short path (:func:`armctl.ik.numerical.solve_goal`).

    ``q0`` as the caller gave it (``None``: the middle of the ranges); ``None`` when the
    options need the full path.
    """
    res = solve_goal("dls", model, goal, q0, options, "auto")
    if res is None or res.success:
        return res
    return _closed_form(model, (goal,), model.middle() if q0 is None else model.clip(q0),
                        options or IKOptions(), res, time.perf_counter() - res.time)


def closed_form(model: KinematicModel, goals: tuple[Goal, ...], q0: Array,
                options: IKOptions) -> IKResult | None:
    """The second step of :func:`auto` alone: the closed form's answer, or ``None``.

    ``None`` when no closed-form solver applies to the goals or the arm has no closed form;
    else its answer as :func:`auto` would return it after a failed search (labelled
    ``auto``, checked by :func:`armctl.ik.result.finish`; it may have failed too).
    """
    started = time.perf_counter()
    analytic = _analytic(model, goals, options)
    if analytic is None:
        return None
    goal = goals[0]
    try:
        closed = analytic(model, goals, q0, options, ())
    except _no_closed_form():
        _CLOSED_FORM[model][(goal.frame, type(goal))] = False
        return None
    _CLOSED_FORM[model][(goal.frame, type(goal))] = True
    return finish(model, goals, closed.q, solver="auto", status=closed.status, iterations=0,
                  restarts=0, started=started, message="closed form after the numerical "
                  "search failed", avoid=options.avoid)


def _closed_form(model: KinematicModel, goals: tuple[Goal, ...], q0: Array, options: IKOptions,
                 res: IKResult, started: float) -> IKResult:
    """The second step of :func:`auto` after the numerical search ``res`` failed."""
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
        if closed.status is IKStatus.COLLIDES and closed.contact is not None and (
                res.contact is None or res.status is not IKStatus.COLLIDES
                or closed.contact.depth < res.contact.depth):
            return finish(model, goals, closed.q, solver="auto", status=closed.status,
                          iterations=res.iterations, restarts=res.restarts, started=started,
                          message="every closed-form solution inside the limits collides; "
                                  "the one with the shallowest contact is returned",
                          avoid=options.avoid)
        return res
    return finish(model, goals, closed.q, solver="auto", status=closed.status,
                  iterations=res.iterations, restarts=res.restarts, started=started,
                  message="closed form after the numerical search failed", avoid=options.avoid)
