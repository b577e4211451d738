"""Compiled (numba) core of the numerical IK solvers: residuals, steps, CCD, restarts, batches.

Goals are packed into flat arrays by :mod:`armctl.ik._pack`:

* ``gf`` ``(G,)``: frame index of each goal.
* ``gt`` ``(G,)``: goal type (:data:`POSITION`, :data:`ORIENTATION`, :data:`DIRECTION`,
  :data:`POSE`).
* ``gd`` ``(G, 18)``: target position (0-2), target rotation row-major (3-11), target direction
  (12-14), tool axis in the goal frame's coordinates (15-17).
* ``gw`` ``(G,)``: goal weights; ``gtol`` ``(G, 2)``: position [m] and rotation [rad] tolerance.
* ``mask`` ``(G, n)``: 1 where joint ``j`` moves goal ``g``'s frame.

The residual of a goal stacks its position error ``p_target - p`` (3 rows, Jacobian rows
``J_v``) and its orientation part: the rotation vector of ``R_target R^T`` (3 rows, ``J_w``) for
orientation and pose goals, or ``d_target - a`` for a direction goal, where ``a`` is the current
tool axis in the base frame, with the seed's columns ``w_i x a`` (zero for prismatic joints).
Rows are scaled by ``sqrt(weight)``.

Every attempt clamps ``q`` into the limits after each step, so every returned ``q`` lies inside
them. Random restarts draw uniformly inside the limits from a splitmix64 generator whose state
is passed in, so a seed fixes the answer.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numba as nb
import numpy as np

from armctl.kinematics._kernels import _step, fk_into, fk_jacobian_into

_OPTS: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}
_OPTS_CLOCK: dict[str, Any] = {"cache": True, "error_model": "numpy"}  # these read the clock

POSITION, ORIENTATION, DIRECTION, POSE = 0, 1, 2, 3
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

# null-space weights ``nsw``: posture, joint-limit avoidance, keep-out spheres, manipulability
NS_POSTURE, NS_LIMITS, NS_SPHERES, NS_MANIP = 0, 1, 2, 3


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


@nb.njit(**_OPTS)
def _clamp(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
    for i in range(q.shape[0]):
        if q[i] < lower[i]:
            q[i] = lower[i]
        elif q[i] > upper[i]:
            q[i] = upper[i]


@nb.njit(**_OPTS)
def _wrap_into(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray) -> bool:
    """Shift revolute joints by multiples of 2 pi into their ranges where possible.

    Returns whether every joint is then inside its limits.
    """
    inside = True
    for i in range(q.shape[0]):
        if q[i] >= lower[i] and q[i] <= upper[i]:
            continue
        if jd[i, 15] < 0.5 and math.isfinite(lower[i]):
            t = lower[i] + (q[i] - lower[i]) % (2.0 * math.pi)
            if t <= upper[i]:
                q[i] = t
                continue
        inside = False
    return inside


@nb.njit(**_OPTS)
def _cap(dq: np.ndarray, max_step: float) -> None:
    m = 0.0
    for i in range(dq.shape[0]):
        m = max(m, abs(dq[i]))
    if m > max_step:
        s = max_step / m
        for i in range(dq.shape[0]):
            dq[i] *= s


@nb.njit(**_OPTS)
def _rotation_error(gd: np.ndarray, pose: np.ndarray, out: np.ndarray, k: int, s: float) -> None:
    """``out[k:k+3] = s * log(R_target R^T)`` (rotation vector, base frame) [rad]."""
    d = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            d[i, j] = (gd[3 + 3 * i] * pose[j, 0] + gd[4 + 3 * i] * pose[j, 1]
                       + gd[5 + 3 * i] * pose[j, 2])
    v0 = d[2, 1] - d[1, 2]
    v1 = d[0, 2] - d[2, 0]
    v2 = d[1, 0] - d[0, 1]
    sn = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    c = (d[0, 0] + d[1, 1] + d[2, 2] - 1.0) / 2.0
    ang = math.atan2(sn / 2.0, c)
    if ang < 1e-9:
        f = 0.5
    elif ang < math.pi - 1e-6:
        f = ang / sn
    else:  # near pi: the axis from the symmetric part, the sign from the skew part
        b = 0
        for i in range(3):
            if d[i, i] > d[b, b]:
                b = i
        ax = np.empty(3)
        ax[b] = math.sqrt(max((d[b, b] - c) / (1.0 - c), 1e-300))
        for i in range(3):
            if i != b:
                ax[i] = (d[i, b] + d[b, i]) / 2.0 / ((1.0 - c) * ax[b])
        nrm = math.sqrt(ax[0] ** 2 + ax[1] ** 2 + ax[2] ** 2)
        sign = 1.0 if ax[0] * v0 + ax[1] * v1 + ax[2] * v2 >= 0 else -1.0
        for i in range(3):
            out[k + i] = s * sign * ang * ax[i] / nrm
        return
    out[k] = s * f * v0
    out[k + 1] = s * f * v1
    out[k + 2] = s * f * v2


@nb.njit(**_OPTS)
def goal_error(t: int, gd: np.ndarray, pose: np.ndarray) -> tuple[float, float]:
    """Position error [m] and rotation/direction error [rad] of one goal, as ``Goal.errors``."""
    dp = 0.0
    dr = 0.0
    if t != ORIENTATION:
        x = gd[0] - pose[0, 3]
        y = gd[1] - pose[1, 3]
        z = gd[2] - pose[2, 3]
        dp = math.sqrt(x * x + y * y + z * z)
    if t == ORIENTATION or t == POSE:
        d = np.empty((3, 3))
        for i in range(3):
            for j in range(3):
                d[i, j] = (gd[3 + 3 * i] * pose[j, 0] + gd[4 + 3 * i] * pose[j, 1]
                           + gd[5 + 3 * i] * pose[j, 2])
        v0 = d[2, 1] - d[1, 2]
        v1 = d[0, 2] - d[2, 0]
        v2 = d[1, 0] - d[0, 1]
        c = (d[0, 0] + d[1, 1] + d[2, 2] - 1.0) / 2.0
        dr = math.atan2(math.sqrt(v0 * v0 + v1 * v1 + v2 * v2) / 2.0, c)
    elif t == DIRECTION:
        a0 = pose[0, 0] * gd[15] + pose[0, 1] * gd[16] + pose[0, 2] * gd[17]
        a1 = pose[1, 0] * gd[15] + pose[1, 1] * gd[16] + pose[1, 2] * gd[17]
        a2 = pose[2, 0] * gd[15] + pose[2, 1] * gd[16] + pose[2, 2] * gd[17]
        c0 = a1 * gd[14] - a2 * gd[13]
        c1 = a2 * gd[12] - a0 * gd[14]
        c2 = a0 * gd[13] - a1 * gd[12]
        dr = math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2),
                        a0 * gd[12] + a1 * gd[13] + a2 * gd[14])
    return dp, dr


@nb.njit(**_OPTS)
def _all_met(gt: np.ndarray, gd: np.ndarray, gtol: np.ndarray, pose: np.ndarray,
             margin: float) -> bool:
    for g in range(gt.shape[0]):
        dp, dr = goal_error(gt[g], gd[g], pose[g])
        if dp > gtol[g, 0] * margin or dr > gtol[g, 1] * margin:
            return False
    return True


@nb.njit(**_OPTS)
def _max_errors(gt: np.ndarray, gd: np.ndarray, pose: np.ndarray) -> tuple[float, float]:
    mp = 0.0
    mr = 0.0
    for g in range(gt.shape[0]):
        dp, dr = goal_error(gt[g], gd[g], pose[g])
        mp = max(mp, dp)
        mr = max(mr, dr)
    return mp, mr


# ---- residual and Jacobian --------------------------------------------------------------------
@nb.njit(**_OPTS)
def n_rows(gt: np.ndarray) -> int:
    """Rows of the stacked residual."""
    m = 0
    for g in range(gt.shape[0]):
        m += 3 if (gt[g] == POSITION or gt[g] == ORIENTATION) else 6
    return m


@nb.njit(**_OPTS)
def _residual(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, gf: np.ndarray,
              gt: np.ndarray, gd: np.ndarray, gw: np.ndarray, rw: float, pose: np.ndarray,
              jg: np.ndarray, e: np.ndarray, jac: np.ndarray, with_jac: bool) -> float:
    """Fill ``e`` (and ``jac`` when ``with_jac``) and the goal poses; return ``E = |e|^2 / 2``.

    ``rw`` [m/rad] scales the orientation rows against the position rows.
    """
    n = q.shape[0]
    r = 0
    for g in range(gf.shape[0]):
        if with_jac:
            fk_jacobian_into(q, jd, fd, paths, gf[g], pose[g], jg)
        else:
            fk_into(q, jd, fd, paths, gf[g], pose[g])
        s = math.sqrt(gw[g])
        t = gt[g]
        p = pose[g]
        if t != ORIENTATION:
            for i in range(3):
                e[r + i] = s * (gd[g, i] - p[i, 3])
                if with_jac:
                    for c in range(n):
                        jac[r + i, c] = s * jg[i, c]
            r += 3
        sr = s * rw
        if t == ORIENTATION or t == POSE:
            _rotation_error(gd[g], p, e, r, sr)
            if with_jac:
                for i in range(3):
                    for c in range(n):
                        jac[r + i, c] = sr * jg[3 + i, c]
            r += 3
        elif t == DIRECTION:
            ax = gd[g, 15:18]
            a0 = p[0, 0] * ax[0] + p[0, 1] * ax[1] + p[0, 2] * ax[2]
            a1 = p[1, 0] * ax[0] + p[1, 1] * ax[1] + p[1, 2] * ax[2]
            a2 = p[2, 0] * ax[0] + p[2, 1] * ax[1] + p[2, 2] * ax[2]
            e[r] = sr * (gd[g, 12] - a0)
            e[r + 1] = sr * (gd[g, 13] - a1)
            e[r + 2] = sr * (gd[g, 14] - a2)
            if with_jac:  # the seed's column w x v for the direction part
                for c in range(n):
                    wx, wy, wz = jg[3, c], jg[4, c], jg[5, c]
                    jac[r, c] = sr * (wy * a2 - wz * a1)
                    jac[r + 1, c] = sr * (wz * a0 - wx * a2)
                    jac[r + 2, c] = sr * (wx * a1 - wy * a0)
            r += 3
    en = 0.0
    for i in range(r):
        en += e[i] * e[i]
    return 0.5 * en


# ---- linear algebra ---------------------------------------------------------------------------
@nb.njit(**_OPTS)
def _chol_solve(a: np.ndarray, b: np.ndarray, k: int, x: np.ndarray) -> bool:
    """Solve ``a[:k,:k] x = b[:k]`` for symmetric positive definite ``a`` (overwritten)."""
    for j in range(k):
        s = a[j, j]
        for p in range(j):
            s -= a[j, p] * a[j, p]
        if s <= 0.0:
            return False
        d = math.sqrt(s)
        a[j, j] = d
        for i in range(j + 1, k):
            s = a[i, j]
            for p in range(j):
                s -= a[i, p] * a[j, p]
            a[i, j] = s / d
    for i in range(k):
        s = b[i]
        for p in range(i):
            s -= a[i, p] * x[p]
        x[i] = s / a[i, i]
    for i in range(k - 1, -1, -1):
        s = x[i]
        for p in range(i + 1, k):
            s -= a[p, i] * x[p]
        x[i] = s / a[i, i]
    return True


@nb.njit(**_OPTS)
def _dls_step(jac: np.ndarray, e: np.ndarray, m: int, n: int, lam: float, a: np.ndarray,
              b: np.ndarray, y: np.ndarray, dq: np.ndarray) -> bool:
    """Damped least squares ``dq = (J^T J + lam I)^-1 J^T e`` in the smaller of two forms."""
    if m < n:  # dq = J^T (J J^T + lam I)^-1 e
        for i in range(m):
            for k in range(i + 1):
                s = 0.0
                for c in range(n):
                    s += jac[i, c] * jac[k, c]
                a[i, k] = s
                a[k, i] = s
            a[i, i] += lam
            b[i] = e[i]
        if not _chol_solve(a, b, m, y):
            return False
        for c in range(n):
            s = 0.0
            for i in range(m):
                s += jac[i, c] * y[i]
            dq[c] = s
        return True
    for i in range(n):
        for k in range(i + 1):
            s = 0.0
            for r in range(m):
                s += jac[r, i] * jac[r, k]
            a[i, k] = s
            a[k, i] = s
        a[i, i] += lam
        s = 0.0
        for r in range(m):
            s += jac[r, i] * e[r]
        b[i] = s
    return _chol_solve(a, b, n, dq)


@nb.njit(**_OPTS)
def _dls_bounded(jac: np.ndarray, e: np.ndarray, m: int, n: int, lam: float, q: np.ndarray,
                 lower: np.ndarray, upper: np.ndarray, max_step: float, a: np.ndarray,
                 b: np.ndarray, y: np.ndarray, dq: np.ndarray, jfree: np.ndarray,
                 efree: np.ndarray, fixed: np.ndarray) -> bool:
    """A DLS step that respects the joint limits.

    Joints that the step would push out of their range are held at the limit and the step is
    solved again for the others (up to ``n`` passes).
    """
    for c in range(n):
        fixed[c] = 0
    for _ in range(n):
        for r in range(m):
            efree[r] = e[r]
        for c in range(n):
            if fixed[c] != 0:
                d = (lower[c] if fixed[c] < 0 else upper[c]) - q[c]
                dq[c] = d
                for r in range(m):
                    efree[r] -= jac[r, c] * d
                    jfree[r, c] = 0.0
            else:
                for r in range(m):
                    jfree[r, c] = jac[r, c]
        keep = dq.copy()
        if not _dls_step(jfree, efree, m, n, lam, a, b, y, dq):
            return False
        for c in range(n):
            if fixed[c] != 0:
                dq[c] = keep[c]
        _cap(dq, max_step)
        more = False
        for c in range(n):
            if fixed[c] == 0:
                if q[c] + dq[c] < lower[c] - 1e-12:
                    fixed[c] = -1
                    more = True
                elif q[c] + dq[c] > upper[c] + 1e-12:
                    fixed[c] = 1
                    more = True
        if not more:
            return True
    return True


@nb.njit(**_OPTS)
def _pinv_step(jac: np.ndarray, e: np.ndarray, m: int, n: int, rcond: float, dq: np.ndarray,
               proj: np.ndarray, want_proj: bool) -> None:
    """Moore-Penrose step ``dq = J^+ e`` by SVD; with ``want_proj`` also ``proj = I - J^+ J``."""
    u, sv, vt = np.linalg.svd(np.ascontiguousarray(jac[:m]), full_matrices=False)
    k = sv.shape[0]
    cut = rcond * sv[0] if k > 0 else 0.0
    for c in range(n):
        dq[c] = 0.0
    if want_proj:
        for i in range(n):
            for c in range(n):
                proj[i, c] = 1.0 if i == c else 0.0
    for s in range(k):
        if sv[s] <= cut or sv[s] <= 1e-300:
            continue
        ue = 0.0
        for r in range(m):
            ue += u[r, s] * e[r]
        f = ue / sv[s]
        for c in range(n):
            dq[c] += vt[s, c] * f
        if want_proj:
            for i in range(n):
                for c in range(n):
                    proj[i, c] -= vt[s, i] * vt[s, c]


@nb.njit(**_OPTS)
def _jt_step(jac: np.ndarray, e: np.ndarray, m: int, n: int, tmp: np.ndarray,
             dq: np.ndarray) -> None:
    """Jacobian transpose ``dq = alpha J^T e`` with the optimal step length.

    ``alpha = <e, J J^T e> / |J J^T e|^2`` minimises the linearised error ``|e - J dq|^2``.
    """
    for c in range(n):
        s = 0.0
        for r in range(m):
            s += jac[r, c] * e[r]
        dq[c] = s
    num = 0.0
    den = 0.0
    for r in range(m):
        s = 0.0
        for c in range(n):
            s += jac[r, c] * dq[c]
        tmp[r] = s
        num += e[r] * s
        den += s * s
    alpha = num / den if den > 0.0 else 0.0
    for c in range(n):
        dq[c] *= alpha


@nb.njit(**_OPTS)
def _descend(q: np.ndarray, qn: np.ndarray, dq: np.ndarray, en: float, lower: np.ndarray,
             upper: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray,
             gf: np.ndarray, gt: np.ndarray, gd: np.ndarray, gw: np.ndarray, rw: float,
             pose: np.ndarray, jg: np.ndarray, e: np.ndarray, jac: np.ndarray) -> bool:
    """Take the step ``dq`` (halved up to 4 times) only if it lowers the error ``en``.

    The J^T step length is optimal for the linearised error; on the real, non-linear error it
    can overshoot, so it is kept only when the error falls.
    """
    for _ in range(5):
        for i in range(q.shape[0]):
            qn[i] = q[i] + dq[i]
        _clamp(qn, lower, upper)
        if _residual(qn, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac, False) < en:
            for i in range(q.shape[0]):
                q[i] = qn[i]
            return True
        for i in range(q.shape[0]):
            dq[i] *= 0.5
    return False


# ---- cyclic coordinate descent ----------------------------------------------------------------
@nb.njit(**_OPTS)
def ccd_coefficients(w: np.ndarray, o: np.ndarray, gt: np.ndarray, gd: np.ndarray,
                     gw: np.ndarray, mask: np.ndarray, j: int, pose: np.ndarray,
                     rho2: float) -> tuple[float, float, float]:
    """``k1, k2, k3`` of ``g(t) = k1 (1 - cos t) + k2 cos t + k3 sin t`` for revolute joint ``j``.

    ``g`` is the seed's objective ``w1 g1 + w2 g2`` summed over the goals that ``j`` moves:
    ``g1`` the dot product of the joint-to-goal and rotated joint-to-effector vectors, ``g2`` the
    sum over the constrained axes of goal-axis . rotated current axis; ``w1`` is the goal weight
    and ``w2`` the goal weight times ``rho2`` [m^2]. Rotating a vector ``a`` about the unit axis
    ``w`` by ``t`` (Rodrigues) gives ``b . R a = (w.a)(w.b)(1 - cos t) + (a.b) cos t +
    b.(w x a) sin t``.
    """
    k1 = 0.0
    k2 = 0.0
    k3 = 0.0
    for g in range(gt.shape[0]):
        if mask[g, j] == 0:
            continue
        t = gt[g]
        p = pose[g]
        for part in range(4):
            # part 0: position; 1-3: orientation axes (all three for orientation/pose goals,
            # the tool axis for a direction goal)
            if part == 0:
                if t == ORIENTATION:
                    continue
                wt = gw[g]
                a0, a1, a2 = p[0, 3] - o[0], p[1, 3] - o[1], p[2, 3] - o[2]
                b0, b1, b2 = gd[g, 0] - o[0], gd[g, 1] - o[1], gd[g, 2] - o[2]
            elif t == ORIENTATION or t == POSE:
                c = part - 1
                wt = gw[g] * rho2
                a0, a1, a2 = p[0, c], p[1, c], p[2, c]
                b0, b1, b2 = gd[g, 3 + c], gd[g, 6 + c], gd[g, 9 + c]
            elif t == DIRECTION and part == 1:
                wt = gw[g] * rho2
                ax = gd[g, 15:18]
                a0 = p[0, 0] * ax[0] + p[0, 1] * ax[1] + p[0, 2] * ax[2]
                a1 = p[1, 0] * ax[0] + p[1, 1] * ax[1] + p[1, 2] * ax[2]
                a2 = p[2, 0] * ax[0] + p[2, 1] * ax[1] + p[2, 2] * ax[2]
                b0, b1, b2 = gd[g, 12], gd[g, 13], gd[g, 14]
            else:
                continue
            wa = w[0] * a0 + w[1] * a1 + w[2] * a2
            wb = w[0] * b0 + w[1] * b1 + w[2] * b2
            k1 += wt * wa * wb
            k2 += wt * (a0 * b0 + a1 * b1 + a2 * b2)
            # b . (w x a)
            k3 += wt * (b0 * (w[1] * a2 - w[2] * a1) + b1 * (w[2] * a0 - w[0] * a2)
                        + b2 * (w[0] * a1 - w[1] * a0))
    return k1, k2, k3


@nb.njit(**_OPTS)
def ccd_angle(k1: float, k2: float, k3: float, lo: float, hi: float) -> float:
    """The turn ``t`` in ``[lo, hi]`` that maximises ``k1 (1 - cos t) + k2 cos t + k3 sin t``.

    Unconstrained, ``dg/dt = 0`` gives ``tan t = k3 / (k2 - k1)``; of the two roots the maximum
    is ``atan2(k3, k2 - k1)``. ``g`` has a single maximum on the circle, so when no copy of it
    (``+- 2 pi``) lies in ``[lo, hi]`` the better end of the interval is the constrained maximum.
    """
    t = math.atan2(k3, k2 - k1)
    for cand in (t, t - 2.0 * math.pi, t + 2.0 * math.pi):
        if lo <= cand <= hi:
            return cand
    glo = k1 * (1.0 - math.cos(lo)) + k2 * math.cos(lo) + k3 * math.sin(lo)
    ghi = k1 * (1.0 - math.cos(hi)) + k2 * math.cos(hi) + k3 * math.sin(hi)
    return lo if glo >= ghi else hi


@nb.njit(**_OPTS)
def joint_frames(q: np.ndarray, jd: np.ndarray, parent: np.ndarray, world: np.ndarray) -> None:
    """World 3x4 frame of every joint after its motion, ``world`` ``(n, 3, 4)``."""
    for j in range(jd.shape[0]):
        p = parent[j]
        for i in range(3):
            for k in range(4):
                if p < 0:
                    world[j, i, k] = 1.0 if i == k else 0.0
                else:
                    world[j, i, k] = world[p, i, k]
        _step(world[j], jd[j], q[j])


@nb.njit(**_OPTS)
def _ccd_sweep(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray,
               parent: np.ndarray, fd: np.ndarray, paths: np.ndarray, gf: np.ndarray,
               gt: np.ndarray, gd: np.ndarray, gw: np.ndarray, mask: np.ndarray, rho2: float,
               world: np.ndarray, pose: np.ndarray) -> None:
    """One CCD sweep over the joints from the tips to the base.

    Joints are visited in decreasing index; parents come first in the joint order, so turning
    joint ``j`` never moves the axis of a joint visited later, and the goal poses are updated
    in closed form after each turn.
    """
    n = q.shape[0]
    joint_frames(q, jd, parent, world)
    for g in range(gf.shape[0]):
        fk_into(q, jd, fd, paths, gf[g], pose[g])
    w = np.empty(3)
    o = np.empty(3)
    for j in range(n - 1, -1, -1):
        ax = jd[j, 12:15]
        for i in range(3):
            w[i] = world[j, i, 0] * ax[0] + world[j, i, 1] * ax[1] + world[j, i, 2] * ax[2]
            o[i] = world[j, i, 3]
        if jd[j, 15] > 0.5:  # prismatic: the closed-form least-squares slide along w
            num = 0.0
            den = 0.0
            for g in range(gf.shape[0]):
                if mask[g, j] == 0 or gt[g] == ORIENTATION:
                    continue
                num += gw[g] * (w[0] * (gd[g, 0] - pose[g, 0, 3])
                                + w[1] * (gd[g, 1] - pose[g, 1, 3])
                                + w[2] * (gd[g, 2] - pose[g, 2, 3]))
                den += gw[g]
            if den == 0.0:
                continue
            t = min(max(num / den, lower[j] - q[j]), upper[j] - q[j])
            q[j] += t
            for g in range(gf.shape[0]):
                if mask[g, j] != 0:
                    for i in range(3):
                        pose[g, i, 3] += t * w[i]
            continue
        k1, k2, k3 = ccd_coefficients(w, o, gt, gd, gw, mask, j, pose, rho2)
        # a joint that cannot change the objective (e.g. a roll axis through the goal point of
        # a position goal) has k2 - k1 = k3 = 0 up to round-off: leave it where it is
        if math.hypot(k3, k2 - k1) <= 1e-12 * (abs(k1) + abs(k2) + abs(k3)) + 1e-300:
            continue
        t = ccd_angle(k1, k2, k3, lower[j] - q[j], upper[j] - q[j])
        if t == 0.0:
            continue
        q[j] += t
        c = math.cos(t)
        s = math.sin(t)
        v = 1.0 - c
        x, y, z = w[0], w[1], w[2]
        r00, r01, r02 = c + x * x * v, x * y * v - z * s, x * z * v + y * s
        r10, r11, r12 = y * x * v + z * s, c + y * y * v, y * z * v - x * s
        r20, r21, r22 = z * x * v - y * s, z * y * v + x * s, c + z * z * v
        for g in range(gf.shape[0]):
            if mask[g, j] == 0:
                continue
            p = pose[g]
            for col in range(4):
                if col == 3:
                    a0, a1, a2 = p[0, 3] - o[0], p[1, 3] - o[1], p[2, 3] - o[2]
                else:
                    a0, a1, a2 = p[0, col], p[1, col], p[2, col]
                b0 = r00 * a0 + r01 * a1 + r02 * a2
                b1 = r10 * a0 + r11 * a1 + r12 * a2
                b2 = r20 * a0 + r21 * a1 + r22 * a2
                if col == 3:
                    b0 += o[0]
                    b1 += o[1]
                    b2 += o[2]
                p[0, col], p[1, col], p[2, col] = b0, b1, b2


# ---- null-space objectives --------------------------------------------------------------------
@nb.njit(**_OPTS)
def _manipulability(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, f: int,
                    pose: np.ndarray, jg: np.ndarray, a: np.ndarray) -> float:
    """``sqrt(det(J J^T))`` (or ``J^T J`` when the arm has fewer than 6 joints) of frame ``f``."""
    fk_jacobian_into(q, jd, fd, paths, f, pose, jg)
    n = q.shape[0]
    k = min(6, n)
    for i in range(k):
        for j in range(i + 1):
            s = 0.0
            if n >= 6:
                for c in range(n):
                    s += jg[i, c] * jg[j, c]
            else:
                for r in range(6):
                    s += jg[r, i] * jg[r, j]
            a[i, j] = s
            a[j, i] = s
    det = 1.0
    for j in range(k):  # Cholesky pivots
        s = a[j, j]
        for p in range(j):
            s -= a[j, p] * a[j, p]
        if s <= 0.0:
            return 0.0
        d = math.sqrt(s)
        a[j, j] = d
        det *= d
        for i in range(j + 1, k):
            s = a[i, j]
            for p in range(j):
                s -= a[i, p] * a[j, p]
            a[i, j] = s / d
    return det


@nb.njit(**_OPTS)
def ns_objective(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray,
                 fd: np.ndarray, paths: np.ndarray, nsw: np.ndarray, pref: np.ndarray,
                 spheres: np.ndarray, mframe: int, pose: np.ndarray, jg: np.ndarray,
                 a: np.ndarray) -> float:
    """The secondary objective ``h(q)`` to minimise in the null space.

    ``h = w_p |q - q_pref|^2 / 2 + w_l sum((q - mid) / half_range)^2 / 2
    + w_s sum_spheres max(0, r - |p - c|)^2 / 2 - w_m sqrt(det(J J^T))``.
    """
    h = 0.0
    n = q.shape[0]
    if nsw[NS_POSTURE] != 0.0:
        s = 0.0
        for i in range(n):
            s += (q[i] - pref[i]) ** 2
        h += nsw[NS_POSTURE] * 0.5 * s
    if nsw[NS_LIMITS] != 0.0:
        s = 0.0
        for i in range(n):
            if math.isfinite(lower[i]) and math.isfinite(upper[i]) and upper[i] > lower[i]:
                s += ((q[i] - 0.5 * (lower[i] + upper[i])) / (0.5 * (upper[i] - lower[i]))) ** 2
        h += nsw[NS_LIMITS] * 0.5 * s
    if nsw[NS_SPHERES] != 0.0:
        s = 0.0
        for k in range(spheres.shape[0]):
            fk_into(q, jd, fd, paths, int(spheres[k, 0]), pose)
            d = math.sqrt((pose[0, 3] - spheres[k, 1]) ** 2 + (pose[1, 3] - spheres[k, 2]) ** 2
                          + (pose[2, 3] - spheres[k, 3]) ** 2)
            if d < spheres[k, 4]:
                s += (spheres[k, 4] - d) ** 2
        h += nsw[NS_SPHERES] * 0.5 * s
    if nsw[NS_MANIP] != 0.0:
        h -= nsw[NS_MANIP] * _manipulability(q, jd, fd, paths, mframe, pose, jg, a)
    return h


@nb.njit(**_OPTS)
def _ns_gradient(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray,
                 fd: np.ndarray, paths: np.ndarray, nsw: np.ndarray, pref: np.ndarray,
                 spheres: np.ndarray, mframe: int, pose: np.ndarray, jg: np.ndarray,
                 a: np.ndarray, grad: np.ndarray) -> None:
    """Gradient of :func:`ns_objective` (analytic, finite differences for manipulability)."""
    n = q.shape[0]
    for i in range(n):
        grad[i] = 0.0
        if nsw[NS_POSTURE] != 0.0:
            grad[i] += nsw[NS_POSTURE] * (q[i] - pref[i])
        if nsw[NS_LIMITS] != 0.0 and math.isfinite(lower[i]) and math.isfinite(upper[i]) \
                and upper[i] > lower[i]:
            half = 0.5 * (upper[i] - lower[i])
            grad[i] += nsw[NS_LIMITS] * (q[i] - 0.5 * (lower[i] + upper[i])) / (half * half)
    if nsw[NS_SPHERES] != 0.0:
        for k in range(spheres.shape[0]):
            fk_jacobian_into(q, jd, fd, paths, int(spheres[k, 0]), pose, jg)
            d0 = pose[0, 3] - spheres[k, 1]
            d1 = pose[1, 3] - spheres[k, 2]
            d2 = pose[2, 3] - spheres[k, 3]
            d = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if d < spheres[k, 4] and d > 1e-12:
                f = -nsw[NS_SPHERES] * (spheres[k, 4] - d) / d
                for c in range(n):
                    grad[c] += f * (jg[0, c] * d0 + jg[1, c] * d1 + jg[2, c] * d2)
    if nsw[NS_MANIP] != 0.0:
        qq = q.copy()
        h = 1e-6
        for c in range(n):
            qq[c] = q[c] + h
            mp = _manipulability(qq, jd, fd, paths, mframe, pose, jg, a)
            qq[c] = q[c] - h
            mm = _manipulability(qq, jd, fd, paths, mframe, pose, jg, a)
            qq[c] = q[c]
            grad[c] -= nsw[NS_MANIP] * (mp - mm) / (2.0 * h)


# ---- one solve with restarts ------------------------------------------------------------------
@nb.njit(**_OPTS_CLOCK)
def solve(q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray,
          parent: np.ndarray, fd: np.ndarray, paths: np.ndarray, gf: np.ndarray, gt: np.ndarray,
          gd: np.ndarray, gw: np.ndarray, gtol: np.ndarray, mask: np.ndarray, method: int,
          prm: np.ndarray, max_iter: int, attempts: int, time_limit: float, state: np.ndarray,
          nsw: np.ndarray, pref: np.ndarray, spheres: np.ndarray, q_out: np.ndarray,
          trace: np.ndarray) -> tuple[int, int, int, int]:
    """Solve from ``q0``, then from random starts, until a start converges or budgets end.

    Args:
        q0: Start ``(n,)`` (clamped into the limits).
        lower: Lower joint limits ``(n,)``.
        upper: Upper joint limits ``(n,)``.
        jd: Packed joints (see :mod:`armctl.kinematics._kernels`).
        parent: Parent joint of every joint, -1 for the base.
        fd: Packed frame offsets.
        paths: Joint paths of the frames.
        gf: Goal frames (see the module docstring, also for ``gt``, ``gd``, ``gw``, ``gtol``,
            ``mask``).
        gt: Goal types.
        gd: Goal targets.
        gw: Goal weights.
        gtol: Goal tolerances.
        mask: Which joints move which goal.
        method: :data:`PINV`, :data:`DLS`, :data:`JT`, :data:`CCD` or :data:`CCD_JT`.
        prm: Parameters (``P_*`` indices).
        max_iter: Iterations per attempt.
        attempts: Largest number of attempts (1 + restarts).
        time_limit: Wall time [s] after which no new attempt starts and a running one stops
            (checked every 256 iterations); <= 0 for none.
        state: RNG state (advanced).
        nsw: Null-space weights (all zero: no null-space term; only PINV and DLS use them).
        pref: Preferred posture for the posture objective.
        spheres: ``(S, 5)`` keep-out spheres: frame index, centre [m], radius [m].
        q_out: Receives the converged ``q``, or the one with the lowest error found.
        trace: ``(T, 2)``: when ``T > 0`` the first attempt records the largest position and
            rotation error before each iteration (NaN after it ends).

    Returns:
        ``(status, iterations, attempts used, attempts that stalled)``.
    """
    deadline = _now() + time_limit if time_limit > 0.0 else 0.0
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
        # every other DLS restart first ignores the limits (clamping creates false minima at
        # the limits); a solution found that way is wrapped by 2 pi into the ranges, or else
        # clamped and finished with the limits on
        free = method == DLS and att % 2 == 1 and not use_ns
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
def solve_batch(q0: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray,
                parent: np.ndarray, fd: np.ndarray, paths: np.ndarray, gf: np.ndarray,
                gt: np.ndarray, gd: np.ndarray, gw: np.ndarray, gtol: np.ndarray,
                mask: np.ndarray, method: int, prm: np.ndarray, max_iter: int, attempts: int,
                time_limit: float, seeds: np.ndarray, nsw: np.ndarray, pref: np.ndarray,
                spheres: np.ndarray, q_out: np.ndarray, info: np.ndarray) -> None:
    """:func:`solve` for ``N`` goal sets ``gd`` ``(N, G, 18)`` from starts ``q0`` ``(N, n)``.

    ``time_limit`` [s] applies to each problem (<= 0: none); ``seeds`` ``(N,)`` seeds each
    problem's generator; ``info`` ``(N, 4)`` receives (status, iterations, attempts, stalled).
    """
    trace = np.empty((0, 2))
    state = np.empty(1, dtype=np.uint64)
    for b in range(q0.shape[0]):
        state[0] = seeds[b]
        st, it, att, stl = solve(q0[b], lower, upper, jd, parent, fd, paths, gf, gt, gd[b], gw,
                                 gtol, mask, method, prm, max_iter, attempts, time_limit, state,
                                 nsw, pref, spheres, q_out[b], trace)
        info[b, 0] = st
        info[b, 1] = it
        info[b, 2] = att
        info[b, 3] = stl
