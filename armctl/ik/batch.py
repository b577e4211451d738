"""Solve many IK problems of the same shape in one compiled call.

:func:`solve_batch` takes ``N`` goal sets that share their structure (the same goal types,
frames, weights and tolerances; different targets) and runs one numerical method over all of them
inside one compiled loop. Whether each answer succeeded is decided afterwards from the forward
kinematics of the returned ``q`` and the joint limits, vectorised over the batch, with the same
criteria as :func:`armctl.ik.result.finish`. Each problem runs as one call would (the same
method, start, budgets and seed, so the same answer); with ``auto`` the problems the search did
not solve then get the closed form where one applies, as a call does. With a collision checker
(``options.avoid``) the
answers are checked together (:meth:`armctl.collision.CollisionModel.free_batch`) and each one
in contact is solved again on its own by :func:`armctl.ik.numerical.run_method`, which restarts
until an answer is free (or reports ``COLLIDES``).
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from itertools import pairwise
from typing import Any

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.ik import _engine as E
from armctl.ik._pack import goal_row, model_arrays, pack_goals, seed_state, wrap_continuous
from armctl.ik._residual import goal_errors_many
from armctl.ik.auto import closed_form
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


class _PoseSets(Sequence[tuple[Goal, ...]]):
    """The goal sets of an ``(N, 4, 4)`` pose array checked as a whole.

    See :func:`_clean_poses`; each set's :class:`PoseGoal` is built when it is asked for.
    """

    def __init__(self, poses: Array, tolerance: Tolerance) -> None:
        self.poses = poses
        self.tolerance = tolerance
        self.built: dict[int, tuple[Goal, ...]] = {}

    def __len__(self) -> int:
        return int(self.poses.shape[0])

    def __getitem__(self, i: Any) -> Any:
        if not isinstance(i, int):
            return [self[k] for k in range(len(self))[i]]
        got = self.built.get(i)
        if got is None:
            got = self.built[i] = (PoseGoal(self.poses[i], tolerance=self.tolerance),)
        return got


#: Largest |R R^T - I| entry of the poses that :func:`_clean_poses` packs itself: well below
#: the limit under which a pose goal keeps its rotation as given (1e-12), so that round-off in
#: the two computations cannot decide differently
_CLEAN = 1e-13


def _clean_poses(arr: Array) -> Array | None:
    """The packed targets ``(N, 1, 18)`` of poses that a :class:`PoseGoal` takes as they are.

    Every pose finite, with the last row ``0 0 0 1`` and a rotation within :data:`_CLEAN` of
    orthonormal with ``det > 0``: the targets :meth:`PoseGoal.packed` gives, computed for all
    at once. ``None`` when any pose is not like that (each then gets its :class:`PoseGoal`,
    which repairs or refuses it).
    """
    if not (np.isfinite(arr).all() and (arr[:, 3, :] == (0.0, 0.0, 0.0, 1.0)).all()):
        return None
    rot = arr[:, :3, :3]
    off = np.abs(rot @ rot.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
    if not ((off <= _CLEAN).all() and (np.linalg.det(rot) > 0.0).all()):
        return None
    gd = np.zeros((arr.shape[0], 1, 18))
    gd[:, 0, 0:3] = arr[:, :3, 3]
    gd[:, 0, 3:12] = rot.reshape(-1, 9)
    gd[:, 0, 17] = 1.0
    return gd


def _goal_sets(goals: npt.ArrayLike | Sequence[GoalLike],
               tolerance: Tolerance | None) -> tuple[Sequence[tuple[Goal, ...]], Array | None]:
    """The goal sets, and their packed targets when a pose array gave them (else ``None``)."""
    arr = None
    if not (isinstance(goals, Sequence) and goals and isinstance(goals[0], (Goal, list, tuple))):
        arr = np.asarray(goals, dtype=float)
    if arr is not None:
        if arr.ndim != 3 or arr.shape[1:] != (4, 4):
            raise InputError(f"batch goals must be (N, 4, 4) poses or N goal sets; got an array "
                             f"of shape {arr.shape}")
        tol = tolerance or Tolerance()
        gd = _clean_poses(arr) if arr.shape[0] else None
        if gd is not None:
            return _PoseSets(arr, tol), gd
        return [(PoseGoal(p, tolerance=tol),) for p in arr], None
    return [as_goals(g, tolerance) for g in goals], None  # type: ignore[union-attr]


#: Problems per thread below which ``workers=None`` uses one thread
_PER_THREAD = 128


def _threads(workers: int | None, n: int) -> int:
    """How many threads share ``n`` problems."""
    if workers is None:
        return max(1, min(os.cpu_count() or 1, n // _PER_THREAD))
    if workers < 1:
        raise InputError(f"workers must be at least 1, got {workers}")
    return min(workers, max(n, 1))


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
    solver: str = DEFAULT,
    *,
    options: IKOptions | None = None,
    tolerance: Tolerance | None = None,
    workers: int | None = None,
) -> IKBatchResult:
    """Solve ``N`` IK problems in one compiled call.

    Args:
        model: The arm.
        goals: ``(N, 4, 4)`` tool poses, or ``N`` goal sets (each a goal or a sequence of goals)
            with the same types, frames, weights and tolerances.
        q0: Start ``(dof,)`` for all, ``(N, dof)`` per problem, or ``None`` for the middle of
            the ranges; clipped into the limits.
        solver: ``auto`` (the default, as for one call: ``dls``, then the closed form for
            the problems it did not solve, where one applies), ``dls``, ``pinv``, ``jt``,
            ``ccd`` or ``ccd-jt``. Problem ``i`` gets the answer of
            ``solve(model, goals[i], q0[i], solver, options=options)``, the time limit aside.
        options: Budgets (``time_limit`` applies to each problem), seed (each problem's
            generator starts as a call's does), null-space criteria, collision checker
            (``avoid``: success also requires an answer free of contact).
        tolerance: Tolerance of goals built from pose arrays.
        workers: Threads that share the problems (each problem's answer does not depend on
            it); ``None``: one per CPU for batches of at least 256 problems, else one.

    Returns:
        The results as arrays.

    Raises:
        InputError: For goal sets of different structure, an unknown solver or bad shapes.
    """
    model.require_one_dof("batch inverse kinematics")
    started = time.perf_counter()
    options = options or IKOptions()
    if not solver_info(solver).capabilities.batch:
        raise InputError(f"solve_batch supports the solvers "
                         f"{', '.join(i.name for i in solver_infos() if i.capabilities.batch)}; "
                         f"got {solver!r}")
    method_name = "dls" if solver == DEFAULT else solver  # the default's first method
    sets, gd = _goal_sets(goals, tolerance)
    if not sets:
        raise InputError("solve_batch needs at least one goal set")
    first = sets[0]
    check_request(solver, first)
    if gd is None:  # (a pose array's sets share their structure)
        key = [(type(g), g.frame, g.weight, g.tolerance) for g in first]
        for i, gs in enumerate(sets):
            if [(type(g), g.frame, g.weight, g.tolerance) for g in gs] != key:
                raise InputError(f"batch goal set {i} differs in structure from set 0 (goal "
                                 "types, frames, weights and tolerances must match)")
        gd = np.ascontiguousarray([[goal_row(g) for g in gs] for gs in sets], dtype=float)
    ga = pack_goals(model, first)
    n = len(sets)
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
    # every problem starts its generator as a call with these options would (fresh entropy
    # for each when the random seed is None), so that problem i gets the answer of the call
    # solve(model, sets[i], starts[i], solver, options=options)
    seeds = (np.full(n, int(seed_state(options.seed)[0]), dtype=np.uint64)
             if options.seed is not None else
             np.array([int(seed_state(None)[0]) for _ in range(n)], dtype=np.uint64))
    q_out = np.full((n, model.dof), np.nan)  # a row stays NaN if no attempt had a finite error
    info = np.zeros((n, 4), dtype=np.int64)
    run = (method, method_params(model, method, options), options.max_iterations,
           options.restarts + 1, float(options.time_limit))
    ns = ns_arrays(model, options.nullspace)
    threads = _threads(workers, n)
    if threads == 1:
        E.solve_batch(starts, ma.kernel, replace(ga, gd=gd).kernel, run, ns, seeds, q_out, info)
    else:  # the compiled loop runs without the GIL: contiguous shares of the problems
        cuts = np.linspace(0, n, threads + 1).astype(int).tolist()
        with ThreadPoolExecutor(threads) as pool:
            for job in [pool.submit(E.solve_batch, starts[a:b], ma.kernel,
                                    replace(ga, gd=gd[a:b]).kernel, run, ns, seeds[a:b],
                                    q_out[a:b], info[a:b])
                        for a, b in pairwise(cuts)]:
                job.result()
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
    if options.avoid is None and solver == DEFAULT:
        # what a call to ``auto`` does after its numerical search failed: the closed form,
        # where one applies (the search itself ran above, as the call would run it)
        for k in np.flatnonzero(~success).tolist():
            res = closed_form(model, sets[k], starts[k], options)
            if res is not None and res.success:
                q[k], success[k], again[k] = res.q, True, res.status
                dp[k], dr[k], inside[k], met[k] = (res.position_error, res.rotation_error,
                                                   res.within_limits, True)
                failed[k] = False
    elif options.avoid is not None:
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
