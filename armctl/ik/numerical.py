"""Numerical IK methods as registered solvers.

The solvers are ``pinv``, ``dls``, ``jt``, ``ccd`` and ``ccd-jt``: the numerical methods of the
lecture (L. Kavan, *Metody skeletální animace*, 2002) and damped least squares. J^T and CCD are
treated at length by C. Welman, *Inverse Kinematics and Geometric Constraints for Articulated
Figure Manipulation* (MSc thesis, 1993).

Each iteration linearises the goals with the Jacobian (the lecture's numerical IK) and takes one
step:

* ``pinv`` (the lecture's pseudoinverse): the Moore-Penrose step ``dq = J^+ e`` by SVD
  (singular values below ``1e-6 s_max`` are dropped); steps are capped at 0.5 rad per joint.
* ``dls``: damped least squares / Levenberg-Marquardt, ``dq = (J^T J + lambda I)^-1 J^T e``
  with ``lambda = mu E + 1e-9`` (``E = |e|^2 / 2``): near a goal the step becomes Gauss-Newton,
  far from it or where steps fail (near singularities, where ``J^T J`` is ill-conditioned) the
  damping grows: a step that does not lower ``E`` is rejected and ``mu`` multiplied by 8; an
  accepted step divides it by 4 (``mu`` starts at 0.03 and stays above 1e-3). An attempt that
  does not lower ``E`` by 10 % in 5 iterations stalls; after 8 attempts the test is 1 % in 10.
* ``jt`` (the lecture's Jacobian transpose): ``dq = alpha J^T e`` with the step length
  ``alpha`` that minimises the linearised error; a step that does not lower the real error is
  halved (up to 4 times) or skipped.
* ``ccd`` (the lecture's cyclic coordinate descent): one sweep turns every joint, tip to base, by
  the closed-form angle that maximises the lecture's ``k1 (1 - cos t) + k2 cos t + k3 sin t``
  (position and orientation terms); prismatic joints slide by the closed-form least-squares
  distance.
* ``ccd-jt`` (the lecture's comparison: "combine CCD with J^T"): every iteration is a CCD sweep
  followed by one optimal J^T step (kept only if it lowers the error), which spreads the
  correction over all joints.

``pinv`` and ``dls`` add null-space criteria (the lecture's redundancy step) when
``options.nullspace`` is set. All of them clamp into the joint limits after every step, except
``dls`` without null-space criteria, whose attempts first ignore the limits (clamping creates
false minima at the limits) and bring a solution into them by whole turns, or else clamp it and
go on with the limits on; all restart from uniform random configurations when an attempt stalls
or uses up its iterations, and stop at the time limit.

With a collision checker (``options.avoid``) an attempt that converges to a configuration in
contact does not end the solve: the answer is set aside and the search goes on from the next
random start (the same generator, so a seed still fixes the answer) within the same budgets.
The first free answer is returned; when every answer found collides, the one with the
shallowest contact is returned with status ``COLLIDES`` and its contact.
"""

from __future__ import annotations

import time
import weakref
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.ik import _engine as E
from armctl.ik._pack import (
    ModelArrays,
    goal_kernel,
    goal_structure,
    model_arrays,
    seed_state,
    seed_value,
    wrap_continuous,
)
from armctl.ik.goals import Goal, as_goals
from armctl.ik.nullspace import ns_arrays
from armctl.ik.options import IKOptions
from armctl.ik.registry import check_request
from armctl.ik.result import IKResult, IKStatus, converged, finish
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.collision.model import CollisionModel

__all__ = ["MethodParams", "ccd", "ccd_jt", "dls", "jt", "method_params", "pinv", "run_method",
           "solve_goal"]


_METHODS = {"pinv": E.PINV, "dls": E.DLS, "jt": E.JT, "ccd": E.CCD, "ccd-jt": E.CCD_JT}


@dataclass(frozen=True)
class MethodParams:
    """Internal constants of one method.

    Attributes:
        damping: DLS damping floor ``lambda_0``.
        window: An attempt stalls when ``E`` did not fall below ``ratio * E`` within this many
            iterations; it then restarts.
        ratio: See ``window``.
        max_step: Largest joint change per step [rad]/[m].
        rcond: Relative cut-off of singular values for the pseudoinverse.
        rotation_weight: Weight of the orientation rows of the residual against the position
            rows [m/rad]; ``None`` for the weight CCD's objective implies.
        mu0: DLS: the damping factor ``mu`` at the start of an attempt.
        mu_down: DLS: ``mu`` is multiplied by this after a step that lowers ``E`` ...
        mu_min: ... but not below this.
        mu_up: DLS: ``mu`` is multiplied by this after a step that does not lower ``E``.
        patient_after: Attempts after this many stall by ``window2`` and ``ratio2`` instead.
        window2: The stall window of the later attempts (``None``: ``window``).
        ratio2: The stall ratio of the later attempts (``None``: ``ratio``).
    """

    damping: float = 1e-9
    window: int = 10
    ratio: float = 0.99
    max_step: float = 1.0
    rcond: float = 1e-6
    rotation_weight: float | None = 1.0
    mu0: float = 1.0
    mu_down: float = 0.25
    mu_min: float = 1e-3
    mu_up: float = 8.0
    patient_after: int = 0
    window2: int | None = None
    ratio2: float | None = None


_PARAMS = {
    E.PINV: MethodParams(window=10, ratio=0.99, max_step=0.5),
    # DLS: a start that does not lower E by 10 % in 5 iterations is given up for another
    # (most goals are met from the first or second start); after 8 starts the attempts are
    # patient (1 % in 10), for goals near the limits that few starts reach. Chosen on 4000
    # random reachable pose goals from random starts on each of 7 arms (the bundled panda,
    # ur5e and wx250s, the reference robots of tools/bench_ik_call.py): 23 % less time than
    # 10 / 1 % throughout, every goal solved.
    E.DLS: MethodParams(window=5, ratio=0.9, max_step=1.0, mu0=0.03, patient_after=8,
                        window2=10, ratio2=0.99),
    E.JT: MethodParams(window=50, ratio=0.999, max_step=0.5, rotation_weight=None),
    E.CCD: MethodParams(window=20, ratio=0.999, max_step=np.pi),
    E.CCD_JT: MethodParams(window=20, ratio=0.999, max_step=0.5, rotation_weight=None),
}


_PRM_CACHE: weakref.WeakKeyDictionary[KinematicModel, dict[tuple[Any, ...], Array]] = (
    weakref.WeakKeyDictionary())


def method_params(model: KinematicModel, method: int, options: IKOptions,
                  params: MethodParams | None = None) -> Array:
    """The engine's parameter vector for a method (cached per model, method and criteria)."""
    cache = _PRM_CACHE.get(model)
    if cache is None:
        cache = _PRM_CACHE[model] = {}
    # params None (the defaults): a cheap hash
    key = (method, params, options.nullspace, options.ccd_weights, options.jt_gain)
    got = cache.get(key)
    if got is None:
        got = cache[key] = _method_params(model, params or _PARAMS[method], options)
    return got


def _method_params(model: KinematicModel, p: MethodParams, options: IKOptions) -> Array:
    prm = np.zeros(E.N_PARAMS)
    prm[E.P_LAMBDA0] = p.damping
    prm[E.P_WINDOW] = p.window
    prm[E.P_RATIO] = p.ratio
    prm[E.P_MAX_STEP] = p.max_step
    weights = options.ccd_weights
    rho2 = (0.25 * model.tree.max_reach) ** 2  # the default w2: both terms alike in size
    prm[E.P_RHO2] = (weights.orientation if weights is not None
                     and weights.orientation is not None else rho2)
    prm[E.P_CCD_W1] = weights.position if weights is not None else 1.0
    prm[E.P_JT_GAIN] = options.jt_gain if options.jt_gain is not None else 0.0
    prm[E.P_RCOND] = p.rcond
    prm[E.P_MARGIN] = 0.99
    ns = options.nullspace
    prm[E.P_NS_ITER] = ns.iterations if ns is not None else 0
    prm[E.P_NS_GAIN] = ns.gain if ns is not None else 0.0
    prm[E.P_NS_STEP] = 0.1
    # None: the weight that CCD's objective gives orientation, sqrt(2 rho2)
    prm[E.P_ROT_W] = (p.rotation_weight if p.rotation_weight is not None
                      else np.sqrt(2.0 * rho2))
    prm[E.P_MU0] = p.mu0
    prm[E.P_MU_DOWN] = p.mu_down
    prm[E.P_MU_MIN] = p.mu_min
    prm[E.P_MU_UP] = p.mu_up
    prm[E.P_PATIENT] = p.patient_after
    prm[E.P_WINDOW2] = p.window2 if p.window2 is not None else p.window
    prm[E.P_RATIO2] = p.ratio2 if p.ratio2 is not None else p.ratio
    return prm


def check_no_constraints(name: str, constraints: Sequence[Any]) -> None:
    """Raise for constraints, which only the ``nlp`` solver accepts."""
    if constraints:
        raise InputError(f"solver {name!r} does not accept constraints "
                         f"({len(constraints)} given); use solver 'nlp' for constrained IK")


def run_method(
    name: str,
    model: KinematicModel,
    goals: tuple[Goal, ...],
    q0: Array,
    options: IKOptions,
    constraints: Sequence[Any],
    *,
    trace: Array | None = None,
    started: float | None = None,
    label: str | None = None,
    params: MethodParams | None = None,
) -> IKResult:
    """Run one of the numerical methods by name (see the module docstring).

    Args:
        name: ``pinv``, ``dls``, ``jt``, ``ccd`` or ``ccd-jt``.
        model: The arm.
        goals: The goals.
        q0: Start inside the limits.
        options: Budgets, seed, null-space criteria.
        constraints: Must be empty.
        trace: Optional ``(T, 2)`` array that receives the largest position [m] and rotation
            [rad] error before each of the first ``T`` iterations of the first attempt.
        started: ``time.perf_counter()`` at the start of the solve (now when ``None``).
        label: Solver name in the result (``name`` when ``None``).
        params: Internal constants instead of the method's defaults (for studies).

    Returns:
        The result, built by :func:`armctl.ik.result.finish`.
    """
    t0 = time.perf_counter() if started is None else started
    check_no_constraints(name, constraints)
    check_request(name, goals)  # a goal kind the method has no form for (CCD: look-at)
    method = _METHODS[name]
    ma = model_arrays(model)
    gk = goal_kernel(model, goals)
    run = (method, method_params(model, method, options, params), options.max_iterations,
           options.restarts + 1, t0 + options.time_limit)
    if trace is None and options.nullspace is None and options.avoid is None:
        return _checked(label or name, model, goals, q0, options.seed, ma, gk, run, t0)
    q_out = np.empty(model.dof)
    q_out.fill(np.nan)  # stays NaN if no attempt ever had a finite error
    state = seed_state(options.seed)
    ns = ns_arrays(model, options.nullspace)
    status, iters, attempts, stalled = E.solve(
        np.array(q0, dtype=float), ma.kernel, gk, run, ns, state, q_out,
        _NO_TRACE if trace is None else trace)
    if options.avoid is not None and status == E.CONVERGED:
        return _avoiding(label or name, model, goals, q0, options, ma, gk, run, ns, state,
                         q_out, (iters, attempts, stalled), t0)
    return _finish(label or name, model, goals, q_out, ma, status, iters, attempts, stalled, t0,
                   q0, avoid=options.avoid)


def _avoiding(name: str, model: KinematicModel, goals: tuple[Goal, ...], q0: Array,
              options: IKOptions, ma: ModelArrays, gk: Any, run: Any, ns: Any,
              state: npt.NDArray[np.uint64],
              q_out: Array, used: tuple[int, int, int], started: float) -> IKResult:
    """Go on searching while the converged answers collide (``options.avoid``).

    Each further search starts at a random configuration from the solve's own generator
    ``state`` and gets the attempts not used yet; the deadline stays the solve's.
    """
    avoid = options.avoid
    assert avoid is not None
    iters, attempts, stalled = used
    method, prm, max_iter, budget, deadline = run
    lower, upper = ma.kernel[0], ma.kernel[1]
    mask = gk[5]
    best: tuple[float, Array] | None = None
    found = 0
    status = E.CONVERGED
    while True:
        q = wrap_continuous(q_out, ma.continuous) if ma.wraps else q_out
        contact = avoid.contact(q)
        if contact is None:
            return _finish(name, model, goals, q_out, ma, E.CONVERGED, iters, attempts, stalled,
                           started, q0, avoid=avoid)
        found += 1
        if best is None or contact.depth < best[0]:
            best = (contact.depth, q_out.copy())
        if attempts >= budget or status != E.CONVERGED:
            break
        start = np.array(q0, dtype=float)
        E._random_q(lower, upper, state, mask, start)
        status, it, att, stl = E.solve(start, ma.kernel, gk,
                                       (method, prm, max_iter, budget - attempts, deadline), ns,
                                       state, q_out, _NO_TRACE)
        iters, attempts, stalled = iters + it, attempts + att, stalled + stl
        if status != E.CONVERGED:
            break
    note = (f"{found} answer(s) found in {attempts} start(s), every one in contact; the one "
            "with the shallowest contact is returned")
    return _finish(name, model, goals, best[1], ma, E.CONVERGED, iters, attempts, stalled,
                   started, q0, avoid=avoid, note=note)


#: The ``trace`` of a solve that records none (no rows: the kernel never writes to it).
_NO_TRACE = np.empty((0, 2))


def _checked(name: str, model: KinematicModel, goals: tuple[Goal, ...], q0: Any,
             seed: int | None, ma: ModelArrays, gk: E.GoalGroup, run: E.RunGroup,
             started: float) -> IKResult:
    """One compiled call that solves and checks the answer (:func:`_engine.solve_checked`).

    An answer the kernel found to meet every goal inside the limits becomes the result at once
    (:func:`armctl.ik.result.converged`); any other goes through :func:`_finish`, which checks
    it again and settles its status. ``q0`` may be anything :meth:`KinematicModel.clip`
    accepts: a float vector of the right length goes to the kernel as it is (which refuses a
    NaN or infinite value), anything else is converted (or refused) first.
    """
    if not (type(q0) is np.ndarray and q0.dtype is _F64 and q0.shape == (model.dof,)):
        q0 = model.clip(q0)
    q_out = np.empty(model.dof)
    one = gk[0].shape[0] == 1
    errs = _SCRATCH if one else np.empty((gk[0].shape[0], 2))
    status, iters, attempts, stalled, ok, dp, dr = E.solve_checked(
        q0, ma.kernel, gk, run, seed_value(seed), q_out, errs)
    if ok:
        return converged(model.tool, goals, q_out, ((dp, dr),) if one else errs.tolist(),
                         dp, dr, solver=name, iterations=iters, restarts=attempts - 1,
                         started=started)
    if status == E.BAD_START:
        model.clip(q0)  # raises, naming the value
    return _finish(name, model, goals, q_out, ma, status, iters, attempts, stalled, started,
                   model.clip(q0), wrapped=True)


_F64 = np.dtype(np.float64)
_STRIDES = (8,)  # a C-contiguous float vector
_ROW_STRIDES = (144, 8)  # a C-contiguous (1, 18) float row
_clock = time.perf_counter
_solve_checked = E.solve_checked
#: The per-goal errors of one-goal solves, which the kernel writes and nobody reads (it returns
#: them too); shared, since a write that nobody reads cannot race with anything.
_SCRATCH = np.empty((1, 2))


class _Call:
    """What :func:`solve_goal` keeps per model: the packed arm, parameters, goal structures."""

    __slots__ = ("dof", "kernel", "ma", "middle", "model", "shape", "structures", "tool")

    def __init__(self, model: KinematicModel) -> None:
        key = id(model)
        self.model = weakref.ref(model, lambda _ref: _CALLS.pop(key, None))
        self.ma = model_arrays(model)
        self.kernel = self.ma.kernel
        self.dof = model.dof
        self.shape = (model.dof,)
        self.tool = model.tool
        self.middle = model.middle()
        self.structures: dict[tuple[Any, ...], tuple[Any, ...]] = {}


#: id(model) -> its :class:`_Call` (an entry leaves with its model)
_CALLS: dict[int, _Call] = {}
_DEFAULT_OPTIONS = IKOptions()


def solve_goal(name: str, model: KinematicModel, goal: Goal, q0: Any, options: IKOptions | None,
               label: str) -> IKResult | None:
    """One goal with a method that needs no null space or collision checks: the short path.

    What :func:`run_method` does for ``(goal,)`` with its checks (the goal's kind and frame, the
    start), with the per-model arrays looked up once; ``None`` when the options ask for more
    (null-space criteria, a collision checker, CCD weights or a fixed J^T gain), for
    :func:`run_method` to do.

    Args:
        name: The method (``dls``, ``pinv``, ``jt``, ``ccd``, ``ccd-jt``).
        model: The arm.
        goal: The goal.
        q0: The start as the caller gave it (``None``: the middle of the ranges); clipped
            into the limits, a wrong length or a NaN refused.
        options: Budgets and seed (``None``: the defaults).
        label: Solver name in the result.
    """
    started = _clock()
    opts = _DEFAULT_OPTIONS if options is None else options
    if (opts.nullspace is not None or opts.avoid is not None or opts.ccd_weights is not None
            or opts.jt_gain is not None):
        return None
    call = _CALLS.get(id(model))
    if call is None or call.model() is not model:
        call = _CALLS[id(model)] = _Call(model)
    tol = goal.tolerance
    key = (type(goal), goal.frame, goal.weight, tol.position, tol.rotation, name)
    structure = call.structures.get(key)
    if structure is None:
        goals = (goal,)
        as_goals(goals)  # a goal class without a kind is refused here
        check_request(name, goals)
        method = _METHODS[name]
        structure = (*goal_structure(model, goals), method,
                     method_params(model, method, _DEFAULT_OPTIONS), None)
        if len(call.structures) >= 256:
            call.structures.clear()
        call.structures[key] = structure
    gf, gt, gw, gtol, mask, method, prm, entry = structure
    row = goal.__dict__.get("_row")  # goal.packed_row(), without the call
    if row is None:
        row = goal.packed_row()
    gk = (gf, gt, row, gw, gtol, mask)
    if opts is not _DEFAULT_OPTIONS and not (
            type(opts.max_iterations) is int and type(opts.restarts) is int
            and type(opts.time_limit) is float and row.dtype is _F64
            and row.strides == _ROW_STRIDES):
        entry = None  # numbers or a row of other types: the dispatcher picks the code
    run = (method, prm, opts.max_iterations, opts.restarts + 1, started + opts.time_limit)
    # _checked for one goal, written out: this path is the one most calls take
    if q0 is None:
        q0 = call.middle
    elif not (type(q0) is np.ndarray and q0.dtype is _F64 and q0.strides == _STRIDES):
        q0 = model.clip(q0)
    if q0.shape != call.shape:
        q0 = model.clip(q0)  # raises, naming the joints
    q_out = np.empty(call.dof)
    args = (q0, call.kernel, gk, run, seed_value(opts.seed), q_out, _SCRATCH)
    if entry is not None:  # the arguments have the types the entry point was found for
        status, iters, attempts, stalled, ok, dp, dr = entry(*args)
    else:
        status, iters, attempts, stalled, ok, dp, dr = _solve_checked(*args)
        if opts is _DEFAULT_OPTIONS and row.dtype is _F64 and row.strides == _ROW_STRIDES:
            call.structures[key] = (*structure[:7], E.entry_point(_solve_checked, args))
    if ok:
        return converged(call.tool, (goal,), q_out, ((dp, dr),), dp, dr, solver=label,
                         iterations=iters, restarts=attempts - 1, started=started)
    if status == E.BAD_START:
        model.clip(q0)  # raises, naming the value
    return _finish(label, model, (goal,), q_out, call.ma, status, iters, attempts, stalled,
                   started, model.clip(q0), wrapped=True)


def _finish(name: str, model: KinematicModel, goals: tuple[Goal, ...], q: Array,
            ma: ModelArrays, status: int, iters: int, attempts: int, stalled: int,
            started: float, start: Array, *, avoid: CollisionModel | None = None,
            note: str = "", wrapped: bool = False) -> IKResult:
    if ma.wraps and not wrapped:
        q = wrap_continuous(q, ma.continuous)
    message = note
    if status == E.CONVERGED:
        st = IKStatus.COLLIDES if note else IKStatus.CONVERGED
    elif status == E.TIME_LIMIT:
        st = IKStatus.TIME_LIMIT
        message = f"time limit reached after {attempts} start(s)"
    elif stalled >= attempts:
        st = IKStatus.UNREACHABLE
        message = (f"none of {attempts} start(s) reached the goal (each stopped at a minimum "
                   "of the error)")
    else:
        st = IKStatus.MAX_ITERATIONS
        message = f"iteration budget used up in {attempts} start(s)"
    return finish(model, goals, q, solver=name, status=st, iterations=int(iters),
                  restarts=max(int(attempts) - 1, 0), started=started, message=message,
                  start=start, search=True, avoid=avoid)


def pinv(model: KinematicModel, goals: tuple[Goal, ...], q0: Array, options: IKOptions,
         constraints: Sequence[Any]) -> IKResult:
    """Moore-Penrose pseudoinverse IK as in the lecture, null-space criteria optional."""
    return run_method("pinv", model, goals, q0, options, constraints)


def dls(model: KinematicModel, goals: tuple[Goal, ...], q0: Array, options: IKOptions,
        constraints: Sequence[Any]) -> IKResult:
    """Damped least squares / Levenberg-Marquardt IK, null-space criteria optional."""
    return run_method("dls", model, goals, q0, options, constraints)


def jt(model: KinematicModel, goals: tuple[Goal, ...], q0: Array, options: IKOptions,
       constraints: Sequence[Any]) -> IKResult:
    """Jacobian-transpose IK (the lecture's virtual-force step) with the optimal step length."""
    return run_method("jt", model, goals, q0, options, constraints)


def ccd(model: KinematicModel, goals: tuple[Goal, ...], q0: Array, options: IKOptions,
        constraints: Sequence[Any]) -> IKResult:
    """Cyclic coordinate descent with the lecture's closed-form joint angle."""
    return run_method("ccd", model, goals, q0, options, constraints)


def ccd_jt(model: KinematicModel, goals: tuple[Goal, ...], q0: Array, options: IKOptions,
           constraints: Sequence[Any]) -> IKResult:
    """CCD sweeps alternated with optimal Jacobian-transpose steps (the lecture's combination)."""
    return run_method("ccd-jt", model, goals, q0, options, constraints)
