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
import warnings
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
    _dls_bounded,
    _dls_step,
    _jt_apply,
    _jt_step,
    _pinv_step,
    _wrap_into,
)
from armctl.kinematics._kernels import fk_into

__all__ = [
    "CCD", "CCD_JT", "CONVERGED", "DIRECTION", "DLS", "JT", "MAX_ITERATIONS", "NS_LIMITS",
    "NS_MANIP", "NS_POSTURE", "NS_SPHERES", "ORIENTATION", "PINV", "POSE", "POSITION",
    "TIME_LIMIT", "ccd_angle", "ccd_coefficients", "entry_point", "goal_error", "joint_frames",
    "ns_objective", "rand01", "solve", "solve_batch", "solve_checked",
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
# these read the clock, in object mode, which takes the GIL for the read; the rest of their
# work runs without it (batches on several threads)
_OPTS_CLOCK: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}
warnings.filterwarnings("ignore", message="Code running in object mode won't allow parallel",
                        category=nb.NumbaWarning)

PINV, DLS, JT, CCD, CCD_JT = 0, 1, 2, 3, 4
CONVERGED, MAX_ITERATIONS, TIME_LIMIT = 0, 1, 2
#: :func:`solve_checked`: the start has a NaN or infinite value (nothing was solved)
BAD_START = -1

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
P_MU0 = 11  # DLS: the damping factor mu at the start of an attempt (lambda = mu E + lambda_0)
P_MU_DOWN = 12  # DLS: mu is multiplied by this after a step that lowers E ...
P_MU_MIN = 13  # ... down to this
P_MU_UP = 14  # DLS: mu is multiplied by this after a step that does not lower E
P_PATIENT = 15  # attempts after this many use the patient stall test (P_WINDOW2, P_RATIO2)
P_WINDOW2 = 16  # the stall window of the later attempts [iterations]
P_RATIO2 = 17  # the stall ratio of the later attempts
P_CCD_W1 = 18  # CCD: weight of the position term (the lecture's w1; P_RHO2 is w2) [-]
P_JT_GAIN = 19  # J^T: the lecture's fixed gain alpha [rad/m^2]; 0: the optimal step length
N_PARAMS = 20



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
    # the work arrays, carved from one allocation (one allocation costs as much as a small
    # step; a solve that converges at once would spend most of its time allocating)
    ws = np.empty(32 * ng + 5 * m + 3 * m * n + k * k + 2 * k + 23 * n + n * n + 52)
    o = 0
    pose = ws[o:o + 16 * ng].reshape((ng, 4, 4))
    o += 16 * ng
    pose2 = ws[o:o + 16 * ng].reshape((ng, 4, 4))
    o += 16 * ng
    jg = ws[o:o + 6 * n].reshape((6, n))
    o += 6 * n
    e = ws[o:o + m]
    o += m
    jac = ws[o:o + m * n].reshape((m, n))
    o += m * n
    e2 = ws[o:o + m]
    o += m
    a = ws[o:o + k * k].reshape((k, k))
    o += k * k
    b = ws[o:o + k]
    o += k
    y = ws[o:o + k]
    o += k
    dq = ws[o:o + n]
    o += n
    q = ws[o:o + n]
    o += n
    qn = ws[o:o + n]
    o += n
    proj = ws[o:o + n * n].reshape((n, n))
    o += n * n
    grad = ws[o:o + n]
    o += n
    dz = ws[o:o + n]
    o += n
    tmp = ws[o:o + m]
    o += m
    jfree = ws[o:o + m * n].reshape((m, n))
    o += m * n
    jac2 = ws[o:o + m * n].reshape((m, n))
    o += m * n
    efree = ws[o:o + m]
    o += m
    world = ws[o:o + 12 * n].reshape((n, 3, 4))
    o += 12 * n
    spose = ws[o:o + 16].reshape((4, 4))
    o += 16
    a6 = ws[o:o + 36].reshape((6, 6))
    fixed = np.empty(n, dtype=np.int64)
    movable = np.zeros(n, dtype=np.bool_)
    for g in range(ng):
        for i in range(n):
            if mask[g, i] != 0:
                movable[i] = True
    use_ns = (method == PINV or method == DLS) and (nsw[0] != 0.0 or nsw[1] != 0.0
                                                      or nsw[2] != 0.0 or nsw[3] != 0.0)
    lazy = method == DLS and not use_ns
    mframe = gf[0]
    margin = prm[P_MARGIN]
    rw = prm[P_ROT_W]
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
        # DLS without null-space criteria forms the Jacobian only when it takes a step: a
        # start or an accepted step that meets the goals ends the solve without it
        en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, not lazy)
        need_jac = lazy
        mu = prm[P_MU0]
        # early attempts give up quickly on a start that makes little progress (most goals
        # are met from the first or second start); later ones, for the goals that are hard
        # from most starts (near the limits), are patient
        if att < int(prm[P_PATIENT]):
            window = max(int(prm[P_WINDOW]), 1)
            ratio = prm[P_RATIO]
        else:
            window = max(int(prm[P_WINDOW2]), 1)
            ratio = prm[P_RATIO2]
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
                    need_jac = False
                    met = _all_met(gt, gd, gtol, pose, margin)
                    mu = prm[P_MU0]
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
            if need_jac:
                en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
                need_jac = False
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
                    # the trial forms its Jacobian too: most steps are taken, and a taken step
                    # then needs no second pass over the chain
                    en2 = _residual(qn, jd, fd, paths, gf, gt, gd, gw, rw,
                                    pose2, jg, e2, jac2, True)
                    if en2 < en:
                        mu = max(mu * prm[P_MU_DOWN], prm[P_MU_MIN])
                        for i in range(n):
                            q[i] = qn[i]
                        en = en2
                        pose, pose2 = pose2, pose
                        e, e2 = e2, e
                        jac, jac2 = jac2, jac
                    else:
                        mu *= prm[P_MU_UP]
                        if mu > 1e12:
                            stalled += 1
                            ended = True
                            break
                else:
                    for i in range(n):
                        q[i] = qn[i]
                    en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
            elif method == JT:
                _jt_step(jac, e, m, n, tmp, dq, prm[P_JT_GAIN])
                _cap(dq, max_step)
                _jt_apply(q, qn, dq, en, prm[P_JT_GAIN], lower, upper, jd, fd, paths, gf, gt,
                          gd, gw, rw, pose2, jg, e2, jac)
                en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
            else:
                _ccd_sweep(q, lower, upper, jd, parent, fd, paths, gf, gt, gd, gw, mask,
                           prm[P_RHO2], world, pose, prm[P_CCD_W1])
                if method == CCD_JT:
                    en = _residual(q, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, True)
                    _jt_step(jac, e, m, n, tmp, dq, prm[P_JT_GAIN])
                    _cap(dq, max_step)
                    _jt_apply(q, qn, dq, en, prm[P_JT_GAIN], lower, upper, jd, fd, paths, gf,
                              gt, gd, gw, rw, pose2, jg, e2, jac)
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


@nb.njit(**_OPTS_CLOCK)
def solve_checked(q0: np.ndarray, arm: ArmGroup, goals: GoalGroup, run: RunGroup, seed: int,
                  q_out: np.ndarray, errs: np.ndarray
                  ) -> tuple[int, int, int, int, bool, float, float]:
    """:func:`solve` without null-space criteria, then the answer checked by forward kinematics.

    One compiled call for the whole of a plain numerical solve: the start is checked and
    clamped, the search runs, the answer is wrapped (joints without limits into [-pi, pi)) and
    then checked on its own: forward kinematics of the wrapped answer, every goal's error
    against its tolerance (:func:`armctl.ik._residual.goal_error`, as ``Goal.errors``) and the
    joint limits (1e-9 of slack, as ``KinematicModel.within_limits``).

    Args:
        q0: Start ``(n,)`` as given (not yet clamped; a NaN or infinite value returns
            :data:`BAD_START` without solving).
        arm: See :func:`solve`.
        goals: See :func:`solve`.
        run: See :func:`solve`.
        seed: The generator's state (the 64 bits of :func:`armctl.ik._pack.seed_state`, as a
            signed integer).
        q_out: Receives the answer ``(n,)``, wrapped.
        errs: ``(G, 2)``: receives each goal's position [m] and rotation [rad] error at
            ``q_out``.

    Returns:
        ``(status, iterations, attempts, stalled, ok, position error, rotation error)``: those
        of :func:`solve`; whether the answer is finite, meets every goal within its tolerance
        and lies inside the limits; the largest errors over the goals [m], [rad] (NaN for an
        answer that is not finite).
    """
    lower, upper, jd, _parent, fd, paths = arm
    gf, gt, gd, _gw, gtol, _mask = goals
    n = q0.shape[0]
    for i in range(n):
        if not math.isfinite(q0[i]):
            return BAD_START, 0, 0, 0, False, np.nan, np.nan
    state = np.empty(1, dtype=np.uint64)
    state[0] = np.uint64(seed)
    buf = np.zeros(20 + n)  # no null-space weights (nor a posture or spheres), no trace
    nsw = buf[0:4]
    pose = buf[4:20].reshape((4, 4))
    pref = buf[20:20 + n]
    spheres = buf[0:0].reshape((0, 5))
    trace = buf[0:0].reshape((0, 2))
    for i in range(n):
        q_out[i] = np.nan
    status, iters, att, stalled = solve(q0, arm, goals, run, (nsw, pref, spheres), state, q_out,
                                        trace)
    finite = True
    ok = True
    for i in range(n):
        v = q_out[i]
        if not math.isfinite(v):
            finite = False
            continue
        if not (math.isfinite(lower[i]) and math.isfinite(upper[i])):
            v = (v + math.pi) % (2.0 * math.pi) - math.pi
            q_out[i] = v
        if not (lower[i] - 1e-9 <= v <= upper[i] + 1e-9):
            ok = False
    ok = ok and finite
    dp_max = 0.0
    dr_max = 0.0
    for g in range(gf.shape[0]):
        if finite:
            fk_into(q_out, jd, fd, paths, gf[g], pose)
            dp, dr = goal_error(gt[g], gd[g], pose)
        else:
            dp, dr = np.nan, np.nan
        errs[g, 0] = dp
        errs[g, 1] = dr
        dp_max = max(dp_max, dp) if dp == dp else dp
        dr_max = max(dr_max, dr) if dr == dr else dr
        if not (dp <= gtol[g, 0] and dr <= gtol[g, 1]):
            ok = False
    return status, iters, att, stalled, ok, dp_max, dr_max


def entry_point(kernel: Any, args: tuple[Any, ...]) -> Any:
    """The compiled function ``kernel`` runs for arguments of the types of ``args``, or None.

    Calling it skips the dispatcher's type checks (about half a microsecond for the many arrays
    of :func:`solve_checked`): the caller must pass arguments of exactly these types (arrays of
    the same dtype, dimensions and layout; integers and floats where these have them) or the
    compiled code misreads them. ``None`` before ``kernel`` has run for these types.
    """
    cres = kernel.overloads.get(tuple(nb.typeof(a) for a in args))
    return None if cres is None else cres.entry_point
