"""Solve many IK problems of the same shape in one compiled call.

:func:`solve_batch` takes ``N`` goal sets that share their structure (the same goal types,
frames, weights and tolerances; different targets) and runs one numerical method over all of them
inside one compiled loop. Whether each answer succeeded is decided afterwards from the forward
kinematics of the returned ``q`` and the joint limits, vectorised over the batch, with the same
criteria as :func:`armctl.ik.result.finish`. With a collision checker (``options.avoid``) the
answers are checked together (:meth:`armctl.collision.CollisionModel.free_batch`) and each one
in contact is solved again on its own by :func:`armctl.ik.numerical.run_method`, which restarts
until an answer is free (or reports ``COLLIDES``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.ik import _engine as E
from armctl.ik._pack import goal_row, model_arrays, pack_goals, seed_state, wrap_continuous
from armctl.ik._residual import goal_errors_many
from armctl.ik.goals import Goal, GoalLike, PoseGoal, Tolerance, as_goals
from armctl.ik.nullspace import ns_arrays
from armctl.ik.numerical import _METHODS, method_params, run_method
from armctl.ik.options import IKOptions
from armctl.ik.registry import DEFAULT, check_request, solver_info, solver_infos
from armctl.ik.result import IKStatus
from armctl.ik.singular import goal_rank, stuck_at_singularity
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["IKBatchResult", "batch_errors", "solve_batch"]


_STATUS = {E.CONVERGED: IKStatus.CONVERGED, E.MAX_ITERATIONS: IKStatus.MAX_ITERATIONS,
           E.TIME_LIMIT: IKStatus.TIME_LIMIT}


@dataclass(frozen=True)
class IKBatchResult:
    """The outcome of :func:`solve_batch`; row ``i`` belongs to goal set ``i``.

    Attributes:
        q: Joint vectors ``(N, dof)``: solutions, or the closest found.
        success: ``(N,)``: every goal met within tolerance (by FK) and ``q`` inside the limits.
        status: Per problem, as :func:`armctl.ik.result.finish` decides it: converged, max
            iterations, unreachable, time limit, singular, collides (with ``options.avoid``)
            or failed (the start returned).
        iterations: ``(N,)`` iterations, summed over restarts.
        restarts: ``(N,)`` restarts used.
        position_error: ``(N,)`` largest position error over the goals [m].
        rotation_error: ``(N,)`` largest rotation error over the goals [rad].
        within_limits: ``(N,)``.
        solver: The method used.
        time: Wall time of the whole batch [s].
    """

    q: Array
    success: npt.NDArray[np.bool_]
    status: tuple[IKStatus, ...]
    iterations: npt.NDArray[np.int64]
    restarts: npt.NDArray[np.int64]
    position_error: Array
    rotation_error: Array
    within_limits: npt.NDArray[np.bool_]
    solver: str
    time: float

    def __len__(self) -> int:
        return int(self.q.shape[0])


def _goal_sets(goals: npt.ArrayLike | Sequence[GoalLike],
               tolerance: Tolerance | None) -> list[tuple[Goal, ...]]:
    arr = None
    if not (isinstance(goals, Sequence) and goals and isinstance(goals[0], (Goal, list, tuple))):
        arr = np.asarray(goals, dtype=float)
    if arr is not None:
        if arr.ndim != 3 or arr.shape[1:] != (4, 4):
            raise InputError(f"batch goals must be (N, 4, 4) poses or N goal sets; got an array "
                             f"of shape {arr.shape}")
        tol = tolerance or Tolerance()
        return [(PoseGoal(p, tolerance=tol),) for p in arr]
    return [as_goals(g, tolerance) for g in goals]  # type: ignore[union-attr]


def batch_errors(model: KinematicModel, goals: Sequence[Goal], gd: Array,
                 q: Array) -> tuple[Array, Array, npt.NDArray[np.bool_]]:
    """Per-problem largest position [m] and rotation [rad] errors, and whether all goals are met.

    Args:
        model: The arm.
        goals: The goal structure (types, frames, tolerances) shared by the batch.
        gd: ``(N, G, 18)`` packed targets.
        q: ``(N, dof)`` joint vectors.
    """
    n = q.shape[0]
    dp_max = np.zeros(n)
    dr_max = np.zeros(n)
    met = np.ones(n, dtype=bool)
    errs = np.empty((n, 2))
    for g, goal in enumerate(goals):
        poses = np.ascontiguousarray(model.fk_batch(q, goal.frame))
        goal_errors_many(int(goal.kind), np.ascontiguousarray(gd[:, g]), poses, errs)
        dp, dr = errs[:, 0].copy(), errs[:, 1].copy()
        dp_max = np.maximum(dp_max, dp)
        dr_max = np.maximum(dr_max, dr)
        met &= (dp <= goal.tolerance.position) & (dr <= goal.tolerance.rotation)
    return dp_max, dr_max, met


def solve_batch(
    model: KinematicModel,
    goals: npt.ArrayLike | Sequence[GoalLike],
    q0: npt.ArrayLike | None = None,
    solver: str = "dls",
    *,
    options: IKOptions | None = None,
    tolerance: Tolerance | None = None,
) -> IKBatchResult:
    """Solve ``N`` IK problems in one compiled call.

    Args:
        model: The arm.
        goals: ``(N, 4, 4)`` tool poses, or ``N`` goal sets (each a goal or a sequence of goals)
            with the same types, frames, weights and tolerances.
        q0: Start ``(dof,)`` for all, ``(N, dof)`` per problem, or ``None`` for the middle of
            the ranges; clipped into the limits.
        solver: ``dls`` (also for ``auto``), ``pinv``, ``jt``, ``ccd`` or ``ccd-jt``.
        options: Budgets (``time_limit`` applies to each problem), seed (problem ``i`` uses a
            generator derived from ``seed`` and ``i``), null-space criteria, collision checker
            (``avoid``: success also requires an answer free of contact).
        tolerance: Tolerance of goals built from pose arrays.

    Returns:
        The results as arrays.

    Raises:
        InputError: For goal sets of different structure, an unknown solver or bad shapes.
    """
    started = time.perf_counter()
    options = options or IKOptions()
    if not solver_info(solver).capabilities.batch:
        raise InputError(f"solve_batch supports the solvers "
                         f"{', '.join(i.name for i in solver_infos() if i.capabilities.batch)}; "
                         f"got {solver!r}")
    method_name = "dls" if solver == DEFAULT else solver  # the default's first method
    sets = _goal_sets(goals, tolerance)
    if not sets:
        raise InputError("solve_batch needs at least one goal set")
    first = sets[0]
    check_request(solver, first)
    key = [(type(g), g.frame, g.weight, g.tolerance) for g in first]
    for i, gs in enumerate(sets):
        if [(type(g), g.frame, g.weight, g.tolerance) for g in gs] != key:
            raise InputError(f"batch goal set {i} differs in structure from set 0 (goal types, "
                             "frames, weights and tolerances must match)")
    ga = pack_goals(model, first)
    n = len(sets)
    gd = np.ascontiguousarray([[goal_row(g) for g in gs] for gs in sets], dtype=float)
    if q0 is None:
        starts = np.tile(model.middle(), (n, 1))
    else:
        arr = np.asarray(q0, dtype=float)
        starts = np.tile(model.as_q(arr), (n, 1)) if arr.ndim == 1 else model.as_batch(arr, "q0")
        if starts.shape[0] != n:
            raise InputError(f"q0 has {starts.shape[0]} rows for {n} goal sets")
        starts = np.clip(starts, model.lower, model.upper)
    starts = np.ascontiguousarray(starts)
    ma = model_arrays(model)
    method = _METHODS[method_name]
    base = int(seed_state(options.seed)[0])
    seeds = np.array([(base + 0xD1B54A32D192ED03 * (i + 1)) & (2**64 - 1) for i in range(n)],
                     dtype=np.uint64)
    q_out = np.full((n, model.dof), np.nan)  # a row stays NaN if no attempt had a finite error
    info = np.zeros((n, 4), dtype=np.int64)
    run = (method, method_params(model, method, options), options.max_iterations,
           options.restarts + 1, float(options.time_limit))
    E.solve_batch(starts, ma.kernel, replace(ga, gd=gd).kernel, run,
                  ns_arrays(model, options.nullspace), seeds, q_out, info)
    q = np.array([wrap_continuous(row, ma.continuous) for row in q_out]) if ma.continuous.any() \
        else q_out
    failed = ~np.all(np.isfinite(q), axis=1)
    if failed.any():  # as finish does: the start instead of non-finite joint values
        q = np.where(failed[:, None], starts, q)
    dp, dr, met = batch_errors(model, first, gd, q)
    failed |= ~(np.isfinite(dp) & np.isfinite(dr))
    inside = np.all((q >= model.lower - 1e-9) & (q <= model.upper + 1e-9), axis=1)
    success = met & inside
    again: dict[int, IKStatus] = {}
    if options.avoid is not None:
        for k in np.flatnonzero(success & ~options.avoid.free_batch(q)).tolist():
            res = run_method(method_name, model, sets[k], starts[k],
                             replace(options, seed=int(seeds[k])), ())
            q[k], success[k], again[k] = res.q, res.success, res.status
            dp[k], dr[k], inside[k] = res.position_error, res.rotation_error, res.within_limits
            info[k, 1] += res.iterations
            info[k, 2] += res.restarts + 1
    status = []
    rank: int | None = None  # the goals' usual rank (goal_rank), shared by the batch
    for i in range(n):
        if i in again:
            status.append(again[i])
            continue
        if success[i]:
            status.append(IKStatus.CONVERGED)
            continue
        if failed[i]:
            status.append(IKStatus.FAILED)
            continue
        if info[i, 0] == E.MAX_ITERATIONS and info[i, 3] >= info[i, 2]:
            st = IKStatus.UNREACHABLE
        else:
            st = _STATUS[int(info[i, 0])]
            st = IKStatus.MAX_ITERATIONS if st is IKStatus.CONVERGED else st
        if st is not IKStatus.TIME_LIMIT and not met[i]:
            rank = goal_rank(model, first) if rank is None else rank
            if stuck_at_singularity(model, sets[i], q[i], rank) is not None:
                st = IKStatus.SINGULAR
        status.append(st)
    q.setflags(write=False)
    return IKBatchResult(q, success, tuple(status), info[:, 1].copy(),
                         np.maximum(info[:, 2] - 1, 0), dp, dr, inside, method_name,
                         time.perf_counter() - started)
