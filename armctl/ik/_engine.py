"""Compiled (numba) core of the numerical IK solvers: one solve with restarts, and batches.

The pieces live beside it: goal residuals in :mod:`armctl.ik._residual` (the packed goal layout
is described there), the joint steps in :mod:`armctl.ik._steps`, CCD in :mod:`armctl.ik._ccd`,
null-space objectives in :mod:`armctl.ik._objectives`.

:func:`solve` takes its inputs in four groups, plain tuples of arrays and numbers (numba unboxes
a plain tuple in a fraction of a microsecond; a named tuple or a class would cost more per call):

* ``arm`` = ``(lower, upper, jd, parent, fd, paths)``: the position limits ``(n,)`` [rad]/[m] and
  the compiled tree's ``joints``, ``parent``, ``frames`` and ``paths``
  (:class:`armctl.kinematics.compiled_tree.CompiledTree`); built once per model by
  :func:`armctl.ik._pack.model_arrays` (``ModelArrays.kernel``).
* ``goals`` = ``(gf, gt, gd, gw, gtol, mask)``: the packed goals (layout in
  :mod:`armctl.ik._residual`), ``GoalArrays.kernel`` of :func:`armctl.ik._pack.pack_goals`.
* ``run`` = ``(method, prm, max_iter, attempts, deadline)``: the method (:data:`PINV`,
  :data:`DLS`, :data:`JT`, :data:`CCD` or :data:`CCD_JT`), its parameter vector (``P_*``
  indices), the iterations per attempt, the largest number of attempts (1 + restarts) and the
  ``time.perf_counter()`` value [s] after which no new attempt starts and a running one stops
  (checked every 256 iterations; <= 0 for none). The caller computes the deadline, so a solve
  that converges in its first attempt never reads the clock (a read from compiled code costs
  about a microsecond). :func:`solve_batch` takes a time limit [s] per problem instead.
* ``nullspace`` = ``(nsw, pref, spheres)``: the null-space weights ``(4,)`` (all zero: no
  null-space term; only PINV and DLS use them), the preferred posture ``(n,)`` and the keep-out
  spheres ``(S, 5)`` (frame index, centre [m], radius [m]), from
  :func:`armctl.ik.nullspace.ns_arrays`.

Every returned ``q`` lies inside the limits: attempts clamp ``q`` after each step, except DLS
attempts (without null-space criteria), which first ignore the limits and whose result is
wrapped by 2 pi or clamped into them before it is used. Random restarts draw uniformly inside
the limits from a splitmix64 generator whose state is passed in, so a seed fixes the answer.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numba as nb
import numpy as np

from armctl.ik._ccd import _ccd_sweep, ccd_angle, ccd_coefficients, joint_frames
from armctl.ik._objectives import (
    NS_LIMITS,
    NS_MANIP,
    NS_POSTURE,
    NS_SPHERES,
    _ns_gradient,
    ns_objective,
)
from armctl.ik._residual import (
    DIRECTION,
    NJIT,
    ORIENTATION,
    POSE,
    POSITION,
    _all_met,
    _max_errors,
    _residual,
    goal_error,
    n_rows,
)
from armctl.ik._steps import (
    _cap,
    _clamp,
    _descend,
    _dls_bounded,
    _dls_step,
    _jt_step,
    _pinv_step,
    _wrap_into,
)

__all__ = [
    "CCD", "CCD_JT", "CONVERGED", "DIRECTION", "DLS", "JT", "MAX_ITERATIONS", "NS_LIMITS",
    "NS_MANIP", "NS_POSTURE", "NS_SPHERES", "ORIENTATION", "PINV", "POSE", "POSITION",
    "TIME_LIMIT", "ccd_angle", "ccd_coefficients", "goal_error", "joint_frames", "ns_objective",
    "rand01", "solve", "solve_batch",
]

#: ``(lower, upper, jd, parent, fd, paths)``, see the module docstring.
ArmGroup = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
#: ``(gf, gt, gd, gw, gtol, mask)``.
GoalGroup = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
#: ``(method, prm, max_iter, attempts, deadline)`` (:func:`solve`) or
#: ``(method, prm, max_iter, attempts, time_limit)`` (:func:`solve_batch`).
RunGroup = tuple[int, np.ndarray, int, int, float]
#: ``(nsw, pref, spheres)``.
NullSpaceGroup = tuple[np.ndarray, np.ndarray, np.ndarray]

_OPTS = NJIT
_OPTS_CLOCK: dict[str, Any] = {"cache": True, "error_model": "numpy"}  # these read the clock

PINV, DLS, JT, CCD, CCD_JT = 0, 1, 2, 3, 4
CONVERGED, MAX_ITERATIONS, TIME_LIMIT = 0, 1, 2

# indices into the parameter vector ``prm``
P_LAMBDA0 = 0  # damping floor of DLS
P_WINDOW = 1  # stall window [iterations]
P_RATIO = 2  # an attempt stalls when E did not fall below RATIO * E over one window
P_MAX_STEP = 3  # largest joint step per iteration [rad] / [m]
P_RHO2 = 4  # CCD: weight of the orientation term relative to the position term [m^2]
P_RCOND = 5  # pseudoinverse: singular values below RCOND * s_max count as zero
P_MARGIN = 6  # an attempt converges at MARGIN * tolerance (a guard against round-off)
P_NS_ITER = 7  # null space: iterations spent improving the objective once the goal is met
P_NS_GAIN = 8  # null space: step gain on the objective's gradient
P_NS_STEP = 9  # null space: largest joint change of one null-space step [rad] / [m]
P_ROT_W = 10  # weight of the orientation rows of the residual [m/rad]
N_PARAMS = 11



# ---- small helpers ----------------------------------------------------------------------------
@nb.njit(**_OPTS)
def rand01(state: np.ndarray) -> float:
    """A uniform number in [0, 1) from the splitmix64 state ``state[0]`` (advanced)."""
    state[0] += np.uint64(0x9E3779B97F4A7C15)
    z = state[0]
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    z = z ^ (z >> np.uint64(31))
    return float(z >> np.uint64(11)) * (1.0 / 9007199254740992.0)


@nb.njit(**_OPTS)
def _random_q(lower: np.ndarray, upper: np.ndarray, state: np.ndarray, mask: np.ndarray,
              q: np.ndarray) -> None:
    """Uniform random values for the joints that move a goal; the others keep theirs."""
    for i in range(q.shape[0]):
        moves = False
        for g in range(mask.shape[0]):
            if mask[g, i] != 0:
                moves = True
        if not moves:
            continue
        lo = lower[i] if math.isfinite(lower[i]) else -math.pi
        hi = upper[i] if math.isfinite(upper[i]) else math.pi
        q[i] = lo + (hi - lo) * rand01(state)


@nb.njit(**_OPTS_CLOCK)
def _now() -> float:
    with nb.objmode(t="float64"):
        t = time.perf_counter()
    return t


# ---- one solve with restarts ------------------------------------------------------------------
@nb.njit(**_OPTS_CLOCK)
def solve(q0: np.ndarray, arm: ArmGroup, goals: GoalGroup, run: RunGroup,
          nullspace: NullSpaceGroup, state: np.ndarray, q_out: np.ndarray,
          trace: np.ndarray) -> tuple[int, int, int, int]:
    """Solve from ``q0``, then from random starts, until a start converges or budgets end.

    Args:
        q0: Start ``(n,)`` (clamped into the limits).
        arm: ``(lower, upper, jd, parent, fd, paths)`` (see the module docstring).
        goals: ``(gf, gt, gd, gw, gtol, mask)``.
        run: ``(method, prm, max_iter, attempts, deadline)``; ``deadline`` is a
            ``time.perf_counter()`` value [s] (<= 0: none).
        nullspace: ``(nsw, pref, spheres)``.
        state: RNG state (advanced).
        q_out: Receives the converged ``q``, or the one with the lowest error found.
        trace: ``(T, 2)``: when ``T > 0`` the first attempt records the largest position and
            rotation error before each iteration (NaN after it ends).

    Returns:
        ``(status, iterations, attempts used, attempts that stalled)``.
    """
    lower, upper, jd, parent, fd, paths = arm
    gf, gt, gd, gw, gtol, mask = goals
    method, prm, max_iter, attempts, deadline = run
    nsw, pref, spheres = nullspace
    n = q0.shape[0]
    ng = gf.shape[0]
    m = n_rows(gt)
    k = max(m, n)
    pose = np.empty((ng, 4, 4))
    pose2 = np.empty((ng, 4, 4))
    jg = np.empty((6, n))
    e = np.empty(m)
    jac = np.empty((m, n))
    e2 = np.empty(m)
    a = np.empty((k, k))
    b = np.empty(k)
    y = np.empty(k)
    dq = np.empty(n)
    q = np.empty(n)
    qn = np.empty(n)
    proj = np.empty((n, n))
    grad = np.empty(n)
    dz = np.empty(n)
    tmp = np.empty(m)
    jfree = np.empty((m, n))
    efree = np.empty(m)
    fixed = np.empty(n, dtype=np.int64)
    world = np.empty((n, 3, 4))
    spose = np.empty((4, 4))
    a6 = np.empty((6, 6))
    movable = np.zeros(n, dtype=np.bool_)
    for g in range(ng):
        for i in range(n):
            if mask[g, i] != 0:
                movable[i] = True
    use_ns = (method == PINV or method == DLS) and (nsw[0] != 0.0 or nsw[1] != 0.0
                                                      or nsw[2] != 0.0 or nsw[3] != 0.0)
    mframe = gf[0]
    margin = prm[P_MARGIN]
    rw = prm[P_ROT_W]
    window = max(int(prm[P_WINDOW]), 1)
    ratio = prm[P_RATIO]
    max_step = prm[P_MAX_STEP]
    best_e = np.inf
    total = 0
    stalled = 0
    for i in range(trace.shape[0]):
        trace[i, 0] = np.nan
        trace[i, 1] = np.nan
    for att in range(attempts):
        if att > 0 and deadline > 0.0 and _now() > deadline:
            return TIME_LIMIT, total, att, stalled
        if att == 0:
            for i in range(n):
                q[i] = q0[i]
            _clamp(q, lower, upper)
        else:
            for i in range(n):
                q[i] = q0[i]
            _clamp(q, lower, upper)
            _random_q(lower, upper, state, mask, q)
        en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
        mu = 1.0
        # every DLS attempt first ignores the limits (clamping creates false minima at the
        # limits: from random starts, most clamped attempts that fail end at a limit); a
        # solution found that way is wrapped by 2 pi into the ranges, or else clamped and
        # finished with the limits on
        free = method == DLS and not use_ns
        e_window = en
        ns_count = 0
        ns_best = np.inf
        ns_found = False
        ns_stale = 0
        ns_scale = 1.0
        ended = False
        for it in range(max_iter):
            if att == 0 and it < trace.shape[0]:
                mp, mr = _max_errors(gt, gd, pose)
                trace[it, 0] = mp
                trace[it, 1] = mr
            met = _all_met(gt, gd, gtol, pose, margin)
            if met and free:
                free = False
                if not _wrap_into(q, lower, upper, jd):
                    _clamp(q, lower, upper)
                    en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
                    met = _all_met(gt, gd, gtol, pose, margin)
                    mu = 1.0
            if met:
                if not use_ns:
                    for i in range(n):
                        q_out[i] = q[i]
                    return CONVERGED, total, att + 1, stalled
                h = ns_objective(q, lower, upper, jd, fd, paths, nsw, pref, spheres, mframe,
                                 spose, jg, a6)
                if h < ns_best - 1e-12 * (1.0 + abs(ns_best)) or not ns_found:
                    ns_best = h
                    ns_found = True
                    ns_scale = min(2.0 * ns_scale, 1.0)
                    for i in range(n):
                        q_out[i] = q[i]
                else:  # the last null-space step did not help: back to the best, shorter steps
                    ns_stale += 1
                    ns_scale *= 0.25
                    for i in range(n):
                        q[i] = q_out[i]
                    en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
                ns_count += 1
                if ns_count > int(prm[P_NS_ITER]) or ns_stale >= 6:
                    return CONVERGED, total, att + 1, stalled
            total += 1
            if (it + 1) % 256 == 0 and deadline > 0.0 and _now() > deadline:
                ended = True
                break
            if method == DLS or method == PINV:
                if method == PINV or use_ns:
                    _pinv_step(jac, e, m, n, prm[P_RCOND], dq, proj, use_ns)
                if method == DLS:
                    lam = mu * en + prm[P_LAMBDA0]
                    if free:
                        if not _dls_step(jac, e, m, n, lam, a, b, y, dq):
                            break
                    elif not _dls_bounded(jac, e, m, n, lam, q, lower, upper, max_step, a, b, y,
                                          dq, jfree, efree, fixed):
                        break
                _cap(dq, max_step)
                if use_ns and met:  # move along the self-motion manifold only from a solution
                    _ns_gradient(q, lower, upper, jd, fd, paths, nsw, pref, spheres, mframe,
                                 spose, jg, a6, grad)
                    for i in range(n):
                        if not movable[i]:
                            grad[i] = 0.0
                    for i in range(n):
                        s = 0.0
                        if movable[i]:
                            for c in range(n):
                                s -= proj[i, c] * grad[c]
                        dz[i] = prm[P_NS_GAIN] * ns_scale * s
                    _cap(dz, prm[P_NS_STEP] * ns_scale)
                    for i in range(n):
                        dq[i] += dz[i]
                for i in range(n):
                    qn[i] = q[i] + dq[i]
                if not free:
                    _clamp(qn, lower, upper)
                if method == DLS and not use_ns:
                    en2 = _residual(qn, jd, fd, paths, gf, gt, gd, gw, rw,
                                    pose2, jg, e2, jac, False)
                    if en2 < en:
                        mu = max(mu * 0.25, 1e-3)
                        for i in range(n):
                            q[i] = qn[i]
                        en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
                    else:
                        mu *= 8.0
                        if mu > 1e12:
                            stalled += 1
                            ended = True
                            break
                else:
                    for i in range(n):
                        q[i] = qn[i]
                    en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
            elif method == JT:
                _jt_step(jac, e, m, n, tmp, dq)
                _cap(dq, max_step)
                _descend(q, qn, dq, en, lower, upper, jd, fd, paths, gf, gt, gd, gw, rw, pose2,
                         jg, e2, jac)
                en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
            else:
                _ccd_sweep(q, lower, upper, jd, parent, fd, paths, gf, gt, gd, gw, mask,
                           prm[P_RHO2], world, pose)
                if method == CCD_JT:
                    en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
                    _jt_step(jac, e, m, n, tmp, dq)
                    _cap(dq, max_step)
                    _descend(q, qn, dq, en, lower, upper, jd, fd, paths, gf, gt, gd, gw, rw,
                             pose2, jg, e2, jac)
                en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, False)
            if (it + 1) % window == 0 and not ns_found:
                if en > ratio * e_window:
                    stalled += 1
                    ended = True
                    break
                e_window = en
        if ns_found:  # the goal was met; the null-space budget ran out
            return CONVERGED, total, att + 1, stalled
        if free:  # an attempt that ignored the limits ends inside them
            _wrap_into(q, lower, upper, jd)
            _clamp(q, lower, upper)
            _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, False)
        if not ended and _all_met(gt, gd, gtol, pose, margin):
            for i in range(n):
                q_out[i] = q[i]
            return CONVERGED, total, att + 1, stalled
        en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, False)
        if en < best_e:
            best_e = en
            for i in range(n):
                q_out[i] = q[i]
        if deadline > 0.0 and _now() > deadline:
            return TIME_LIMIT, total, att + 1, stalled
    return MAX_ITERATIONS, total, attempts, stalled


@nb.njit(**_OPTS_CLOCK)
def solve_batch(q0: np.ndarray, arm: ArmGroup, goals: GoalGroup, run: RunGroup,
                nullspace: NullSpaceGroup, seeds: np.ndarray, q_out: np.ndarray,
                info: np.ndarray) -> None:
    """:func:`solve` for ``N`` goal sets from starts ``q0`` ``(N, n)``.

    ``goals`` is as for :func:`solve` except that its ``gd`` is ``(N, G, 18)``, one row of
    targets per problem; ``time_limit`` [s] applies to each problem (<= 0: none); ``seeds``
    ``(N,)`` seeds each problem's generator; ``info`` ``(N, 4)`` receives (status, iterations,
    attempts, stalled).
    """
    gf, gt, gd, gw, gtol, mask = goals
    method, prm, max_iter, attempts, time_limit = run
    trace = np.empty((0, 2))
    state = np.empty(1, dtype=np.uint64)
    for b in range(q0.shape[0]):
        state[0] = seeds[b]
        deadline = _now() + time_limit if time_limit > 0.0 else 0.0
        st, it, att, stl = solve(q0[b], arm, (gf, gt, gd[b], gw, gtol, mask),
                                 (method, prm, max_iter, attempts, deadline), nullspace,
                                 state, q_out[b], trace)
        info[b, 0] = st
        info[b, 1] = it
        info[b, 2] = att
        info[b, 3] = stl
