"""IK solvers by name, with what each can do as data. Each solver is loaded on first use.

The command line builds its ``--solver`` choices, help and checks from :func:`solver_infos`, and
``auto`` asks :class:`Capabilities` which solver to try, instead of testing names.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError, UnknownNameError
from armctl.ik.errors import UnsupportedGoalError
from armctl.ik.goals import Goal, GoalKind, GoalLike, as_goals
from armctl.ik.options import IKOptions
from armctl.ik.result import IKResult
from armctl.kinematics.model import KinematicModel

if TYPE_CHECKING:
    from armctl.collision.model import CollisionModel

__all__ = [
    "DEFAULT",
    "Capabilities",
    "Solver",
    "SolverInfo",
    "UnsupportedGoalError",
    "available_solvers",
    "check_request",
    "get_solver",
    "solve",
    "solver_for",
    "solver_info",
    "solver_infos",
]


class Solver(Protocol):
    """The signature every registered solver implements."""

    def __call__(self, model: KinematicModel, goals: tuple[Goal, ...], q0: npt.NDArray[np.float64],
                 options: IKOptions, constraints: Sequence[Any]) -> IKResult:
        """Solve; ``q0`` is inside the limits; the result comes from :func:`result.finish`."""
        ...


@dataclass(frozen=True)
class Capabilities:
    """What a solver can do.

    Attributes:
        goal_kinds: The goal kinds it solves; ``None`` for every kind (any goal type with a
            residual kernel and an NLP residual, new ones included).
        several_goals: Several goals (frames) at once.
        hard_constraints: Takes constraints (:mod:`armctl.ik.nlp`), hard or weighted.
        all_solutions: Closed form: lists every solution of a goal
            (:func:`armctl.ik.analytic.ik_all`).
        batch: Usable by :func:`armctl.ik.solve_batch`.
        nullspace: Honours ``options.nullspace`` (others ignore it).
        time_limit: Honours ``options.time_limit`` (a closed form needs no budget).
        compiled: Its first call loads compiled kernels, which a throwaway call can do before a
            timed one.
    """

    goal_kinds: frozenset[GoalKind] | None = None
    several_goals: bool = True
    hard_constraints: bool = False
    all_solutions: bool = False
    batch: bool = False
    nullspace: bool = False
    time_limit: bool = True
    compiled: bool = True

    def solves(self, kind: GoalKind) -> bool:
        """Whether it solves goals of ``kind``."""
        return self.goal_kinds is None or kind in self.goal_kinds


@dataclass(frozen=True)
class SolverInfo:
    """One registered solver.

    Attributes:
        name: The name users give (``solver="dls"``, ``--solver dls``).
        entry: ``"module:function"`` of the :class:`Solver`, imported on first use.
        summary: One line for help texts.
        capabilities: What it can do.
    """

    name: str
    entry: str
    summary: str
    capabilities: Capabilities


_CLASSIC = frozenset({GoalKind.POSITION, GoalKind.ORIENTATION, GoalKind.DIRECTION,
                      GoalKind.POSE})

#: The registered solvers, in the order help texts list them.
_REGISTRY: tuple[SolverInfo, ...] = (
    SolverInfo("auto", "armctl.ik.auto:auto",
               "DLS with restarts, then the closed form where one applies",
               Capabilities(batch=True, nullspace=True)),
    SolverInfo("dls", "armctl.ik.numerical:dls", "damped least squares (Levenberg-Marquardt)",
               Capabilities(batch=True, nullspace=True)),
    SolverInfo("pinv", "armctl.ik.numerical:pinv", "Moore-Penrose pseudoinverse steps",
               Capabilities(batch=True, nullspace=True)),
    SolverInfo("jt", "armctl.ik.numerical:jt", "Jacobian transpose with the optimal step",
               Capabilities(batch=True)),
    SolverInfo("ccd", "armctl.ik.numerical:ccd", "cyclic coordinate descent, closed-form angles",
               Capabilities(goal_kinds=_CLASSIC, batch=True)),
    SolverInfo("ccd-jt", "armctl.ik.numerical:ccd_jt", "CCD sweeps with Jacobian-transpose steps",
               Capabilities(goal_kinds=_CLASSIC, batch=True)),
    SolverInfo("nlp", "armctl.ik.nlp.solver:solve",
               "non-linear programming (CasADi): constraints and keep-out zones",
               Capabilities(hard_constraints=True, compiled=False)),
    SolverInfo("analytic", "armctl.ik.analytic.solver:solve",
               "closed form: the valid solution nearest the start (--all lists every one)",
               Capabilities(goal_kinds=frozenset({GoalKind.POSE, GoalKind.DIRECTION,
                                                  GoalKind.POSITION}),
                            several_goals=False, all_solutions=True, time_limit=False)),
)
_SOLVERS: dict[str, SolverInfo] = {info.name: info for info in _REGISTRY}
#: The default solver, which picks a method for the goal (and is left out of suggestions).
DEFAULT = "auto"
_LOADED: dict[str, Solver] = {}


def available_solvers() -> tuple[str, ...]:
    """The registered solver names."""
    return tuple(_SOLVERS)


def solver_infos() -> tuple[SolverInfo, ...]:
    """Every registered solver, in registration order."""
    return _REGISTRY


def solver_info(name: str) -> SolverInfo:
    """The registered solver ``name``.

    Raises:
        UnknownNameError: Listing the registered solvers.
    """
    info = _SOLVERS.get(name)
    if info is None:
        raise UnknownNameError("IK solver", name, list(_SOLVERS))
    return info


def get_solver(name: str) -> Solver:
    """The solver registered as ``name``.

    Raises:
        UnknownNameError: Listing the registered solvers.
    """
    fn = _LOADED.get(name)
    if fn is None:
        module, func = solver_info(name).entry.split(":")
        fn = _LOADED[name] = getattr(importlib.import_module(module), func)
    return fn


def _able(goals: Sequence[Goal], constraints: bool) -> list[SolverInfo]:
    """The solvers (the default left out) that can take these goals and constraints."""
    out = []
    for info in _REGISTRY:
        c = info.capabilities
        if (info.name != DEFAULT and all(c.solves(g.kind) for g in goals)
                and (c.several_goals or len(goals) <= 1)
                and (c.hard_constraints or not constraints)):
            out.append(info)
    return out


def _use(goals: Sequence[Goal], constraints: bool, what: str = "") -> str:
    """``"use dls or nlp"`` (plus ``what``): the solvers that can take the request."""
    names = [i.name for i in _able(goals, constraints)]
    if not names:
        return "no registered solver takes this combination"
    listed = names[0] if len(names) == 1 else f"{', '.join(names[:-1])} or {names[-1]}"
    return f"use {listed}{what}"


def check_request(name: str, goals: Sequence[Goal], constraints: Sequence[Any] = ()) -> None:
    """Refuse goals or constraints that solver ``name`` cannot take, naming those that can.

    Raises:
        UnknownNameError: For a solver that is not registered.
        UnsupportedGoalError: For a goal kind, several goals or constraints it does not take.
    """
    caps = solver_info(name).capabilities
    has = bool(constraints)
    for goal in goals:
        if not caps.solves(goal.kind):
            raise UnsupportedGoalError(
                f"solver {name!r} cannot solve {goal.label} goals; {_use(goals, has)}", name)
    if len(goals) > 1 and not caps.several_goals:
        raise UnsupportedGoalError(
            f"solver {name!r} takes one goal at a time, got {len(goals)}; "
            f"{_use(goals, has, ' for several frames at once')}", name)
    if has and not caps.hard_constraints:
        raise UnsupportedGoalError(
            f"solver {name!r} does not accept constraints ({len(constraints)} given); "
            f"{_use(goals, True, ' for constrained IK')}", name)


def solver_for(name: str, goals: Sequence[Goal], constraints: Sequence[Any] = ()) -> str:
    """The solver to run for a request.

    ``name`` itself, except that the default (``auto``) with constraints becomes the first
    registered solver that takes them (``nlp``).

    Raises:
        UnknownNameError: For a solver that is not registered.
    """
    solver_info(name)
    if name == DEFAULT and constraints:
        able = _able(goals, True)
        if able:
            return able[0].name
    return name


def solve(
    model: KinematicModel,
    goal: GoalLike,
    q0: npt.ArrayLike | None = None,
    solver: str = "auto",
    *,
    options: IKOptions | None = None,
    constraints: Sequence[Any] = (),
    avoid: CollisionModel | None = None,
) -> IKResult:
    """Solve inverse kinematics.

    Args:
        model: The arm.
        goal: A goal, several goals, or a ``(4, 4)`` tool pose.
        q0: Starting configuration (clipped into the limits); the middle of the ranges when
            ``None``.
        solver: Registered solver name (see :func:`available_solvers`).
        options: Budgets and seed.
        constraints: Extra constraints (only solvers whose capabilities say so accept any).
        avoid: A collision checker; replaces ``options.avoid`` (see :class:`IKOptions`).

    Returns:
        The result; ``result.success`` says whether every goal was reached inside the limits
        (and, with a checker, free of contact).

    Raises:
        UnsupportedGoalError: For goals or constraints the solver cannot take (naming those that
            can).
        InputError: For an arm with universal or ball joints and a solver or a collision
            checker that takes 1-DOF joints only (:mod:`armctl.ik.tangent` runs the numerical
            methods, with null-space criteria for ``pinv``, ``dls`` and ``auto``;
            :mod:`armctl.ik.nlp` runs ``nlp`` with its constraints).
    """
    if model.multi_dof_joints:
        return _solve_multi_dof(model, goal, q0, solver, options, constraints, avoid)
    if avoid is None and not constraints and isinstance(goal, Goal):
        short = _SHORT[solver]
        if short is not None:  # one goal, a numerical method: the same checks, done once
            res = short(model, goal, q0, options)
            if res is not None:
                return res
    goals = as_goals(goal)
    for g in goals:
        model.frame_index(g.frame)  # unknown frames fail before any work
    fn = get_solver(solver)
    check_request(solver, goals, constraints)
    start = model.middle() if q0 is None else model.clip(q0)
    opts = options or _DEFAULT_OPTIONS
    if avoid is not None:
        opts = _with_checker(model, opts, avoid)
    return fn(model, goals, start, opts, tuple(constraints))


_DEFAULT_OPTIONS = IKOptions()  # frozen: one instance serves every call without options


def _with_checker(model: KinematicModel, opts: IKOptions, avoid: CollisionModel) -> IKOptions:
    """``opts`` with the collision checker ``avoid``, refused when built for another arm."""
    if tuple(avoid.model.joint_names) != tuple(model.joint_names):
        raise InputError(f"avoid: the collision checker was built for arm "
                         f"{avoid.model.name!r}, whose joints differ from those of "
                         f"{model.name!r}; use CollisionModel.of(arm) of the arm solved")
    return replace(opts, avoid=avoid)


def _solve_multi_dof(model: KinematicModel, goal: GoalLike, q0: npt.ArrayLike | None,
                     solver: str, options: IKOptions | None, constraints: Sequence[Any],
                     avoid: CollisionModel | None) -> IKResult:
    """IK on an arm with universal or ball joints: the tangent-space methods, ``nlp``, or a refusal.

    Raises:
        InputError: For ``analytic`` (or any solver that steps 1-DOF joints only), naming the
            multi-DOF joints and what to use instead.
        UnsupportedGoalError: For constraints given to a method that takes none (naming
            ``nlp``).
    """
    from armctl.ik.tangent import TANGENT_METHODS, solve_tangent

    opts = options or _DEFAULT_OPTIONS
    joints = ", ".join(repr(n) for n in model.multi_dof_joints)
    solver_info(solver)  # an unknown name lists the registered solvers
    if solver not in TANGENT_METHODS and solver != "nlp":
        raise InputError(
            f"arm {model.name!r} has the multi-DOF joint(s) {joints}: the solver {solver!r} "
            f"supports 1-DOF joints only. Use nlp or one of {', '.join(sorted(TANGENT_METHODS))}.")
    if avoid is not None:
        opts = _with_checker(model, opts, avoid)
    goals = as_goals(goal)
    for g in goals:
        model.frame_index(g.frame)
    check_request(solver, goals, constraints)
    start = model.neutral() if q0 is None else model.clip(q0)
    if solver == "nlp":
        return get_solver(solver)(model, goals, start, opts, tuple(constraints))
    return solve_tangent(model, goals, start, opts, solver)


def _short_path(solver: str) -> Any:
    """The short path of a solver for one goal (see :class:`_ShortPaths`).

    Loaded as :func:`get_solver` loads solvers, by name (the solvers import this module).
    """
    if solver == DEFAULT:
        return importlib.import_module("armctl.ik.auto").auto_goal
    solve_goal = importlib.import_module("armctl.ik.numerical").solve_goal

    def short(model: KinematicModel, goal: Goal, q0: Any, options: IKOptions | None) -> Any:
        return solve_goal(solver, model, goal, q0, options, solver)

    return short


class _ShortPaths(dict[str, Any]):
    """Solver name -> its short path for one goal without constraints, loaded on first use.

    ``auto`` and the numerical methods solve one goal with one compiled call that also checks
    the answer (:func:`armctl.ik.numerical.solve_goal`); the others have none (``None``).
    """

    def __missing__(self, solver: str) -> Any:
        if solver not in _SOLVERS:
            return None  # the full path names the registered solvers
        fn = _short_path(solver) if solver in _NUMERICAL else None
        self[solver] = fn
        return fn


#: The solvers with a short path: ``auto`` and the numerical methods.
_NUMERICAL = frozenset({"auto", "dls", "pinv", "jt", "ccd", "ccd-jt"})


_SHORT = _ShortPaths()
