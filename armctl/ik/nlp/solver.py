"""``solver="nlp"``: IK as non-linear programming, with restarts within a time budget.

Attempts, until one meets every goal and hard constraint (checked by forward kinematics) or the
budget (``options.time_limit``, ``options.restarts``) is used up:

1. from the start ``q0`` (the previous solution when streaming a moving target);
2. from the answer of a numerical solver (``options.seed_solver``, ``"dls"`` by default) when it
   is registered: it ignores the constraints but lands in the right basin for the goals (these
   first two attempts always run, the time budget applies to the rest);
3. from random configurations inside the limits (seeded by ``options.seed``); with
   ``Method.AUTO`` and no hard constraints, after eight SQP restarts every other one runs IPOPT.

With hard constraints each attempt is one IPOPT solve with CasADi's exact Hessian and IPOPT's
own defaults, and without the regularisation unless ``options.preferred`` asks for it
(:mod:`armctl.ik.nlp.problem`).

An attempt that ends close to the goals but short of their tolerance (the regularisation pulls
a little) is polished once with the regularisation centred on its own answer. The best attempt
(least hard-constraint violation, then least goal error) is returned when none succeeds, with
status ``INFEASIBLE`` when the hard constraints could not be met together.

On an arm with universal or ball joints the same runs over ``q`` of ``model.nq`` entries (a
ball joint's quaternion as four variables with its unit norm, swing cone and twist range as
rows, see :mod:`armctl.ik.nlp.problem`), seeded by the tangent-space methods
(:mod:`armctl.ik.tangent`); success is decided the same way, by forward kinematics and the
model's own limit check.

With a collision checker (``options.avoid``) the scene's obstacles become hard keep-out
constraints (:func:`armctl.ik.nlp.scene.scene_keep_out`, the checker's own shapes), and an
attempt counts as a success only when the checker finds its answer free (contacts between the
arm's own links are not constraints: such an answer is set aside and the next start tried);
when every answer that met the goals collides, the shallowest is returned as ``COLLIDES``.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from armctl.config.schema import JointType
from armctl.errors import ArmctlError, InputError
from armctl.ik.goals import Goal
from armctl.ik.nlp.constraints import Constraint
from armctl.ik.nlp.options import Method, NLPOptions
from armctl.ik.nlp.problem import Problem, get_problem
from armctl.ik.options import IKOptions
from armctl.ik.result import IKResult, IKStatus, evaluate, finish
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["check_constraints", "solve"]


#: Attempts in a row that end locally infeasible before the solve gives up as infeasible.
_INFEASIBLE_STREAK = 4
#: Attempts found locally infeasible by the solver that make a failed solve ``INFEASIBLE``.
_INFEASIBLE_VERDICT = 2
#: Warm re-solves of an answer that ends within 1000 tolerances of the goals.
_POLISHES = 4
#: Random restarts by SQP alone before AUTO alternates them with IPOPT.
_SQP_ONLY_RESTARTS = 8


def check_constraints(model: KinematicModel, constraints: Sequence[Any]) -> tuple[Constraint, ...]:
    """The constraints, checked to be NLP constraint objects on frames the arm has.

    Raises:
        InputError: For anything that is not a :class:`Constraint`.
        UnknownNameError: For an unknown frame.
    """
    out = []
    for c in constraints:
        if not isinstance(c, Constraint):
            raise InputError(f"the nlp solver takes constraint objects from armctl.ik.nlp "
                             f"(OnPlane, InHalfSpace, ...); got {type(c).__name__}")
        if not c.on_links:
            model.frame_index(c.frame)
        out.append(c)
    return tuple(out)


def _check_method(model: KinematicModel, options: NLPOptions) -> None:
    """Refuse ``Method.SQP`` on an arm with ball joints, whose unit-norm rows it does not solve.

    CasADi's ``sqpmethod`` with the Gauss-Newton Hessian crawled on such arms (on the arm of
    ``tests/data/ball_arm.yaml``: 2 of 30 random pose goals within the budget, IPOPT 30 of 30).

    Raises:
        InputError: Naming the ball joints and the methods to use.
    """
    balls = [n for n, t in zip(model.joint_names, model.joint_types, strict=True)
             if t is JointType.BALL]
    if options.method is Method.SQP and balls:
        raise InputError(
            f"NLPOptions(method=Method.SQP) does not solve arm {model.name!r}: its ball "
            f"joint(s) {', '.join(repr(n) for n in balls)} add unit-norm, cone and twist rows "
            "that sqpmethod does not converge on; use Method.AUTO (the default) or "
            "Method.IPOPT")


def _merit(model: KinematicModel, goals: tuple[Goal, ...], hard: Sequence[Constraint],
           q: Array) -> tuple[float, float, bool]:
    """(hard violation beyond tolerance, scaled goal error, every goal and hard constraint met)."""
    errs = evaluate(model, goals, q)
    goal_err = max(max(e.position / g.tolerance.position, e.rotation / g.tolerance.rotation)
                   for e, g in zip(errs, goals, strict=True))
    excess = sum(max(0.0, c.violation(model, q) - c.tolerance) for c in hard)
    met = all(e.reached for e in errs) and excess == 0.0
    return excess, goal_err, met


def _seeds(model: KinematicModel, goals: tuple[Goal, ...], q0: Array, options: NLPOptions,
           overrun: list[float]) -> Iterator[tuple[str, Array]]:
    """Starts: ``q0``, the answer of the solver that seeds NLP, then random ones.

    ``overrun`` collects that solver's time beyond its own budget (its one-time
    compilation), which is not charged to the solve.
    """
    yield "start", q0
    if options.seed_solver:
        from armctl.ik.registry import get_solver, solver_infos

        # a registered solver without constraints (not an NLP itself) that solves these goals
        seeder = next((i.capabilities for i in solver_infos() if i.name == options.seed_solver),
                      None)
        if (seeder is not None and not seeder.hard_constraints
                and all(seeder.solves(g.kind) for g in goals)):
            budget = IKOptions(time_limit=max(options.time_limit / 20, 1e-3), restarts=0,
                               seed=options.seed)
            t0 = time.perf_counter()
            try:
                if model.multi_dof_joints:  # the tangent-space methods step ball joints
                    from armctl.ik.tangent import TANGENT_METHODS, solve_tangent

                    res = (solve_tangent(model, goals, q0, budget, options.seed_solver)
                           if options.seed_solver in TANGENT_METHODS else None)
                else:
                    res = get_solver(options.seed_solver)(model, goals, q0, budget, ())
            except ArmctlError:
                res = None
            overrun.append(max(0.0, time.perf_counter() - t0 - 2 * budget.time_limit))
            if res is not None:
                yield options.seed_solver, np.array(res.q)
    rng = np.random.default_rng(options.seed)
    while True:
        yield "random", model.sample(rng)


def solve(model: KinematicModel, goals: tuple[Goal, ...], q0: Array,
          options: IKOptions, constraints: Sequence[Any]) -> IKResult:
    """Solve IK as a non-linear program (the registry's ``"nlp"`` entry).

    Args:
        model: The arm.
        goals: The goals (one per frame; several end effectors at once).
        q0: Start inside the limits ``(nq,)`` (a ball joint's unit quaternion in place); also
            the regularisation centre unless ``options.preferred`` is given.
        options: :class:`NLPOptions` (plain :class:`IKOptions` get NLP defaults).
        constraints: :mod:`armctl.ik.nlp.constraints` objects, hard or weighted.

    Returns:
        The result; ``success`` requires every goal and every hard constraint to hold by FK.
    """
    started = time.perf_counter()
    opts = NLPOptions.from_options(options)
    _check_method(model, opts)
    cons = check_constraints(model, constraints)
    avoid = opts.avoid
    if avoid is not None:
        from armctl.ik.nlp.scene import scene_keep_out

        cons = (*cons, *scene_keep_out(avoid))
    hard = [c for c in cons if c.hard]
    problem = get_problem(model, goals, cons, opts)
    pref = opts.preferred_array(model.nq)
    if pref is not None and model.nq != model.nv:
        pref = model.as_q(pref, "the preferred posture")  # a ball joint's quaternion of unit norm
    q_ref = np.array(q0, dtype=float) if pref is None else pref
    # with hard constraints (IPOPT, exact Hessian) the regularisation is left out unless a
    # preferred posture asks for it: IPOPT's path from the start ends at a nearby answer anyway,
    # and the tiny weight on the continuum of answers a goal leaves free made it crawl there
    plain = problem.exact_hessian and pref is None
    params = problem.params(goals, cons, q_ref, 0.0 if plain else opts.regularization,
                            opts.damping)
    twin: Problem | None = None  # IPOPT for the same problem, for AUTO's later restarts
    randoms = 0
    # the budget starts after the (cached) build: a first solve's CasADi set-up is not charged
    deadline = time.perf_counter() + opts.time_limit
    overrun: list[float] = []
    best: tuple[float, float] | None = None
    best_q = np.array(q0, dtype=float)
    iterations, attempts, streak, flagged, collided = 0, 0, 0, 0, 0
    status = IKStatus.MAX_ITERATIONS
    for origin, seed in _seeds(model, goals, q0, opts, overrun):
        if attempts > opts.restarts:
            break
        if origin == "random" and time.perf_counter() >= deadline + sum(overrun):
            status = IKStatus.TIME_LIMIT
            break
        attempts += 1
        current = problem
        if origin == "random":
            randoms += 1
            if (opts.method is Method.AUTO and not hard and randoms > _SQP_ONLY_RESTARTS
                    and randoms % 2 == 0):
                # a goal whose basin SQP rarely finds from random starts: alternate with IPOPT
                twin = twin or get_problem(model, goals, cons, replace(opts, method=Method.IPOPT))
                current = twin
        # the warm-start tuning suits a start near the answer: without hard constraints the
        # given start and its seeding solver's (with them, IPOPT's own start is the better one)
        warm = origin != "random" and not hard
        q, its, infeasible, merit = _attempt(current, model, goals, hard, seed, params, warm)
        iterations += its
        streak = streak + 1 if infeasible else 0
        flagged += infeasible
        if merit[2] and avoid is not None:
            contact = avoid.contact(model.wrap_toward(q, q0))
            if contact is not None:  # met everything but collides: rank it behind free ones
                merit = (merit[0] + contact.depth, merit[1], False)
                collided += 1
        if best is None or merit[:2] < best:
            best, best_q = merit[:2], q
        if merit[2]:
            status = IKStatus.CONVERGED
            break
        if hard and streak >= _INFEASIBLE_STREAK:
            break
    if (status is not IKStatus.CONVERGED and best is not None and best[0] > 0
            and flagged >= _INFEASIBLE_VERDICT):
        # every attempt broke a hard constraint, and the solver found them locally
        # infeasible from several starts
        status = IKStatus.INFEASIBLE
    best_q = model.wrap_toward(best_q, q0)  # the same pose, rotary joints nearest the start
    message = f"{problem.method.value}, {attempts} attempt(s)"
    if collided and status is not IKStatus.CONVERGED:
        message += f", {collided} of them met the goals in contact"
    return finish(model, goals, best_q, solver="nlp", status=status, iterations=iterations,
                  restarts=max(attempts - 1, 0), started=started, constraints=cons,
                  message=message, start=q0, search=True, avoid=avoid)


def _attempt(problem: Problem, model: KinematicModel, goals: tuple[Goal, ...],
             hard: Sequence[Constraint], seed: Array, params: Array,
             warm: bool) -> tuple[Array, int, bool, tuple[float, float, bool]]:
    """One solve plus up to ``_POLISHES`` polishes; returns (q, iterations, infeasible, merit).

    A polish re-solves from the answer with the regularisation centred on it: it removes the
    regularisation's pull, and continues a slow convergence near a singular configuration.
    """
    att = problem.run(seed, params, warm)
    its = att.iterations
    q = att.q
    merit = _merit(model, goals, hard, q)
    for _ in range(_POLISHES):
        if merit[2] or merit[0] > 0.0 or merit[1] > 1e3:
            break
        # close but short: the regularisation pulled; centre it on the answer and re-solve
        att2 = problem.run(q, problem.recentred(params, q), True)
        its += att2.iterations
        merit2 = _merit(model, goals, hard, att2.q)
        if not merit2[:2] < merit[:2]:
            break
        q, merit = att2.q, merit2
    return q, its, att.locally_infeasible, merit
