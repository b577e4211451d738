"""Polishing candidates on the exact forward kinematics, and keeping only true solutions.

Every candidate from a closed form is refined by a few Gauss-Newton steps on the model's own FK
(:mod:`armctl.kinematics._kernels`), then kept only if its residual is within the acceptance
tolerance; duplicates are merged. This is what makes the answers exact to machine precision and
what keeps false roots (near-tangent quartic roots, clipped cosines) out.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from armctl.ik.goals import GoalKind
from armctl.kinematics._kernels import fk_into, fk_jacobian_into

#: The goal kinds with a closed form, as the kernels see them (compile-time constants).
POSE = int(GoalKind.POSE)
DIRECTION = int(GoalKind.DIRECTION)
POSITION = int(GoalKind.POSITION)
#: Errors [m], [rad] below which the polish stops: a few units of round-off of the FK.
_ROUNDOFF = 1e-14
#: Summed error [m + rad] below which a step that fails to reduce it ends the polish (the
#: remaining error is round-off; raising the damping would only repeat the FK).
_SETTLED = 1e-12


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _residual(pose: np.ndarray, kind: int, goal: np.ndarray, p: np.ndarray, d: np.ndarray,
              a: np.ndarray, e: np.ndarray) -> tuple[float, float]:
    """Error vector ``e`` (6) to drive to zero, and the position [m] / rotation [rad] errors."""
    for i in range(3):
        e[i] = p[i] - pose[i, 3]
    ep = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    if kind == POSE:
        # D = Rg R^T; e_rot = vee(D - D^T) / 2 (= sin(angle) * axis); written out (a 3x3
        # product through BLAS costs more than the whole forward kinematics)
        d00 = goal[0, 0] * pose[0, 0] + goal[0, 1] * pose[0, 1] + goal[0, 2] * pose[0, 2]
        d11 = goal[1, 0] * pose[1, 0] + goal[1, 1] * pose[1, 1] + goal[1, 2] * pose[1, 2]
        d22 = goal[2, 0] * pose[2, 0] + goal[2, 1] * pose[2, 1] + goal[2, 2] * pose[2, 2]
        d01 = goal[0, 0] * pose[1, 0] + goal[0, 1] * pose[1, 1] + goal[0, 2] * pose[1, 2]
        d10 = goal[1, 0] * pose[0, 0] + goal[1, 1] * pose[0, 1] + goal[1, 2] * pose[0, 2]
        d02 = goal[0, 0] * pose[2, 0] + goal[0, 1] * pose[2, 1] + goal[0, 2] * pose[2, 2]
        d20 = goal[2, 0] * pose[0, 0] + goal[2, 1] * pose[0, 1] + goal[2, 2] * pose[0, 2]
        d12 = goal[1, 0] * pose[2, 0] + goal[1, 1] * pose[2, 1] + goal[1, 2] * pose[2, 2]
        d21 = goal[2, 0] * pose[1, 0] + goal[2, 1] * pose[1, 1] + goal[2, 2] * pose[1, 2]
        e[3] = 0.5 * (d21 - d12)
        e[4] = 0.5 * (d02 - d20)
        e[5] = 0.5 * (d10 - d01)
        s = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        c = 0.5 * (d00 + d11 + d22 - 1.0)
        return ep, math.atan2(s, c)
    if kind == DIRECTION:
        aw = np.empty(3)
        for i in range(3):
            aw[i] = pose[i, 0] * a[0] + pose[i, 1] * a[1] + pose[i, 2] * a[2]
        e[3] = aw[1] * d[2] - aw[2] * d[1]
        e[4] = aw[2] * d[0] - aw[0] * d[2]
        e[5] = aw[0] * d[1] - aw[1] * d[0]
        s = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        return ep, math.atan2(s, aw[0] * d[0] + aw[1] * d[1] + aw[2] * d[2])
    e[3] = 0.0
    e[4] = 0.0
    e[5] = 0.0
    return ep, 0.0


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _solve_sym(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve the small symmetric positive (semi)definite system ``a x = b``.

    Gaussian elimination without pivoting (fine for these matrices) with a floor on the pivots.
    """
    n = b.shape[0]
    m = a.copy()
    x = b.copy()
    for k in range(n):
        piv = m[k, k]
        if piv <= 1e-300:
            piv = 1e-300
        for i in range(k + 1, n):
            f = m[i, k] / piv
            for j in range(k, n):
                m[i, j] -= f * m[k, j]
            x[i] -= f * x[k]
    for k in range(n - 1, -1, -1):
        s = x[k]
        for j in range(k + 1, n):
            s -= m[k, j] * x[j]
        piv = m[k, k] if m[k, k] > 1e-300 else 1e-300
        x[k] = s / piv
    return x


@nb.njit(cache=True, nogil=True, error_model="numpy")
def polish(q: np.ndarray, cols: np.ndarray, kind: int, goal: np.ndarray, p: np.ndarray,
           d: np.ndarray, a: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray,
           f: int, iters: int) -> tuple[float, float]:
    """Refine ``q`` in place by Levenberg-Marquardt steps on the joints ``cols``.

    The damping starts negligible (Gauss-Newton, quadratic convergence) and grows a hundredfold
    after a step that does not reduce the error, so candidates near a fold of the workspace
    (where the Jacobian is nearly singular) still converge instead of stalling.

    Returns:
        The final position error [m] and rotation error [rad].
    """
    n = q.shape[0]
    k = cols.shape[0]
    pose = np.empty((4, 4))
    jac = np.empty((6, n))
    e = np.empty(6)
    fk_jacobian_into(q, jd, fd, paths, f, pose, jac)
    ep, er = _residual(pose, kind, goal, p, d, a, e)
    best = ep + er
    trial = q.copy()
    jtj0 = np.zeros((k, k))
    grad = np.zeros(k)
    scale = 0.0
    damping = 1e-13
    fresh = True
    for _ in range(iters):
        if ep < _ROUNDOFF and er < _ROUNDOFF:  # at the FK round-off: nothing left to gain
            break
        if fresh:  # linearise at the current iterate
            js = np.zeros((6, k))
            for c in range(k):
                for r in range(6):
                    js[r, c] = jac[r, cols[c]]
            if kind == DIRECTION:  # the rotation about the tool axis is free
                aw = pose[:3, :3].copy() @ a
                for c in range(k):
                    w = js[3:, c].copy()
                    t = w[0] * aw[0] + w[1] * aw[1] + w[2] * aw[2]
                    for r in range(3):
                        js[3 + r, c] = w[r] - t * aw[r]
            for c in range(k):
                g = 0.0
                for r in range(6):
                    g += js[r, c] * e[r]
                grad[c] = g
                for c2 in range(k):
                    t = 0.0
                    for r in range(6):
                        t += js[r, c] * js[r, c2]
                    jtj0[c, c2] = t
            scale = np.trace(jtj0) + 1e-300
        jtj = jtj0.copy()
        for c in range(k):
            jtj[c, c] += damping * scale
        dq = _solve_sym(jtj, grad)
        for i in range(n):
            trial[i] = q[i]
        for c in range(k):
            trial[cols[c]] += dq[c]
        fk_jacobian_into(trial, jd, fd, paths, f, pose, jac)
        ep2, er2 = _residual(pose, kind, goal, p, d, a, e)
        if ep2 + er2 < best:  # accept (a NaN compares False and is rejected)
            best = ep2 + er2
            ep, er = ep2, er2
            for i in range(n):
                q[i] = trial[i]
            damping = max(damping * 0.1, 1e-13)
            fresh = True
        else:
            damping *= 100.0
            fresh = False
            if damping > 1e3 or best < _SETTLED:  # a failed step this close: at round-off
                break
    return ep, er


@nb.njit(cache=True, nogil=True, error_model="numpy")
def finalize(cands: np.ndarray, count: int, cols: np.ndarray, kind: int, goal: np.ndarray,
             p: np.ndarray, d: np.ndarray, a: np.ndarray, jd: np.ndarray, fd: np.ndarray,
             paths: np.ndarray, f: int, tol: float, out: np.ndarray,
             errs: np.ndarray) -> int:
    """Polish ``count`` candidate rows of ``cands`` and copy the true, distinct ones to ``out``.

    Args:
        cands: ``(>=count, dof)`` full joint vectors (modified).
        count: How many rows of ``cands`` are candidates.
        cols: The joints the polish may move.
        kind: :data:`POSE`, :data:`DIRECTION` or :data:`POSITION`.
        goal: ``(4, 4)`` target pose (POSE goals).
        p: Target position [m].
        d: Target direction (DIRECTION goals).
        a: The tool axis that must point along ``d``, in the frame's coordinates.
        jd: Packed joints of the model (:mod:`armctl.kinematics._kernels`).
        fd: Packed frames of the model.
        paths: Joint paths of the model's frames.
        f: The goal frame's index.
        tol: Acceptance tolerance on both errors [m] and [rad].
        out: Receives the solutions, angles of ``cols`` wrapped into (-pi, pi].
        errs: ``(len(out), 2)`` receives their position and rotation errors.

    Returns:
        The number of solutions.
    """
    m = 0
    pose = np.empty((4, 4))
    e = np.empty(6)
    for i in range(count):
        q = cands[i]
        ok = True
        for j in range(q.shape[0]):
            if not math.isfinite(q[j]):
                ok = False
        if not ok:
            continue
        # most closed-form candidates are exact to round-off already: a forward kinematics
        # (no Jacobian) shows it, and the polish is skipped
        fk_into(q, jd, fd, paths, f, pose)
        ep, er = _residual(pose, kind, goal, p, d, a, e)
        if not (ep < _ROUNDOFF and er < _ROUNDOFF):
            ep, er = polish(q, cols, kind, goal, p, d, a, jd, fd, paths, f, 20)
        if not (ep <= tol and er <= tol):
            continue
        for c in range(cols.shape[0]):
            j = cols[c]
            w = q[j] - 2.0 * math.pi * math.floor((q[j] + math.pi) / (2.0 * math.pi))
            q[j] = math.pi if w <= -math.pi else w
        dup = False
        for r in range(m):
            diff = 0.0
            for c in range(cols.shape[0]):
                j = cols[c]
                x = abs(q[j] - out[r, j])
                diff = max(diff, min(x, 2.0 * math.pi - x))
            if diff < 1e-6:
                dup = True
                break
        if dup:
            continue
        out[m] = q
        errs[m, 0] = ep
        errs[m, 1] = er
        m += 1
    return m


@nb.njit(cache=True, nogil=True, error_model="numpy")
def expand(sols: np.ndarray, is_col: np.ndarray, lower: np.ndarray,
           upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every 2*pi variant of the solved joints (``is_col``) that lies inside its limits.

    A joint with no variant inside its limits keeps its value (the row is then outside them).

    Returns:
        ``(rows (K, dof), source (K,))``: the variants and the index of the solution each comes
        from.
    """
    m, n = sols.shape
    two_pi = 2.0 * math.pi
    lo_k = np.zeros((m, n), dtype=np.int64)
    cnt = np.ones((m, n), dtype=np.int64)
    total = 0
    for i in range(m):
        prod = 1
        for j in range(n):
            if is_col[j] and math.isfinite(lower[j]) and math.isfinite(upper[j]):
                a = math.ceil((lower[j] - 1e-9 - sols[i, j]) / two_pi)
                b = math.floor((upper[j] + 1e-9 - sols[i, j]) / two_pi)
                if b >= a:
                    lo_k[i, j] = a
                    cnt[i, j] = b - a + 1
            prod *= cnt[i, j]
        total += prod
    rows = np.empty((total, n))
    src = np.empty(total, dtype=np.int64)
    r = 0
    idx = np.zeros(n, dtype=np.int64)
    for i in range(m):
        for j in range(n):
            idx[j] = 0
        while True:
            for j in range(n):
                rows[r, j] = sols[i, j] + two_pi * (lo_k[i, j] + idx[j])
            src[r] = i
            r += 1
            j = n - 1
            while j >= 0:
                idx[j] += 1
                if idx[j] < cnt[i, j]:
                    break
                idx[j] = 0
                j -= 1
            if j < 0:
                break
    return rows, src


@nb.njit(cache=True, nogil=True, error_model="numpy")
def nearest_variants(sols: np.ndarray, is_col: np.ndarray, q_ref: np.ndarray, lower: np.ndarray,
                     upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """One row per solution, each solved joint at its 2 pi variant nearest to ``q_ref``.

    Only variants inside the joint's limits count (a joint with none there keeps its value). The
    distance to ``q_ref`` is a sum over the joints, so the joint-wise choice is the row's variant
    inside the limits nearest to it.

    Returns:
        ``(rows (m, dof), source (m,))`` as :func:`expand`.
    """
    m, n = sols.shape
    two_pi = 2.0 * math.pi
    rows = sols.copy()
    for i in range(m):
        for j in range(n):
            if is_col[j] and math.isfinite(lower[j]) and math.isfinite(upper[j]):
                v = sols[i, j]
                a = math.ceil((lower[j] - 1e-9 - v) / two_pi)
                b = math.floor((upper[j] + 1e-9 - v) / two_pi)
                if b >= a:
                    k = math.floor((q_ref[j] - v) / two_pi + 0.5)
                    rows[i, j] = v + two_pi * min(max(k, a), b)
    return rows, np.arange(m)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def assemble(raw: np.ndarray, count: int, joints: np.ndarray, sign: np.ndarray,
             cols: np.ndarray, is_col: np.ndarray, q_ref: np.ndarray, kind: int,
             goal: np.ndarray, p: np.ndarray, d: np.ndarray, a: np.ndarray, jd: np.ndarray,
             fd: np.ndarray, paths: np.ndarray, f: int, tol: float, lower: np.ndarray,
             upper: np.ndarray, variants: bool
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """From closed-form candidates to the sorted list of exact solutions (or their variants).

    Args:
        raw: ``(>=count, >=len(joints))`` candidates in solver-chain order.
        count: How many rows of ``raw`` are candidates.
        joints: Model joint index of each solver-chain column.
        sign: Sign of each solver-chain column (-1: the joint's value is the negated angle).
        cols: The solved joints (the polish moves these only).
        is_col: ``(dof,)`` mask of ``cols``.
        q_ref: ``(dof,)`` reference: held joints keep its values; rows sort by distance to it.
        kind: The goal kind (see :func:`finalize`).
        goal: ``(4, 4)`` target pose.
        p: Target position [m].
        d: Target direction.
        a: Tool axis.
        jd: Packed joints of the model.
        fd: Packed frames of the model.
        paths: Joint paths of the model's frames.
        f: The goal frame's index.
        tol: Acceptance tolerance [m] and [rad].
        lower: Lower joint limits.
        upper: Upper joint limits.
        variants: Every 2 pi variant inside the limits as a row (:func:`expand`), or one row
            per solution (:func:`nearest_variants`).

    Returns:
        ``(q (K, dof), within_limits (K,), errors (K, 2), distances (K,))`` sorted by distance.
    """
    dof = q_ref.shape[0]
    cands = np.empty((max(count, 1), dof))
    for i in range(count):
        for j in range(dof):
            cands[i, j] = q_ref[j]
        for k in range(joints.shape[0]):
            if is_col[joints[k]]:
                cands[i, joints[k]] = sign[k] * raw[i, k]
    sols = np.empty((max(count, 1), dof))
    errs = np.empty((max(count, 1), 2))
    m = finalize(cands, count, cols, kind, goal, p, d, a, jd, fd, paths, f, tol, sols, errs)
    if variants:
        rows, src = expand(sols[:m], is_col, lower, upper)
    else:
        rows, src = nearest_variants(sols[:m], is_col, q_ref, lower, upper)
    k = rows.shape[0]
    dist = np.empty(k)
    for i in range(k):
        s = 0.0
        for j in range(dof):
            s += (rows[i, j] - q_ref[j]) ** 2
        dist[i] = math.sqrt(s)
    order = np.argsort(dist, kind="mergesort")
    q = np.empty((k, dof))
    inside = np.empty(k, dtype=np.bool_)
    e = np.empty((k, 2))
    ds = np.empty(k)
    for r in range(k):
        i = order[r]
        ok = True
        for j in range(dof):
            q[r, j] = rows[i, j]
            if rows[i, j] < lower[j] - 1e-9 or rows[i, j] > upper[j] + 1e-9:
                ok = False
        inside[r] = ok
        e[r, 0] = errs[src[i], 0]
        e[r, 1] = errs[src[i], 1]
        ds[r] = dist[i]
    return q, inside, e, ds


@nb.njit(cache=True, nogil=True, error_model="numpy")
def inspect_pose(t: np.ndarray) -> tuple[bool, float, float]:
    """Of a ``(4, 4)`` array: whether all entries are finite, ``max |R R^T - I|`` and ``det R``."""
    for i in range(4):
        for j in range(4):
            if not math.isfinite(t[i, j]):
                return False, 0.0, 0.0
    dev = 0.0
    for i in range(3):
        for j in range(3):
            s = t[i, 0] * t[j, 0] + t[i, 1] * t[j, 1] + t[i, 2] * t[j, 2]
            dev = max(dev, abs(s - (1.0 if i == j else 0.0)))
    det = (t[0, 0] * (t[1, 1] * t[2, 2] - t[1, 2] * t[2, 1])
           - t[0, 1] * (t[1, 0] * t[2, 2] - t[1, 2] * t[2, 0])
           + t[0, 2] * (t[1, 0] * t[2, 1] - t[1, 1] * t[2, 0]))
    return True, dev, det


@nb.njit(cache=True, nogil=True, error_model="numpy")
def distinct_rows(raw: np.ndarray, count: int, joints: np.ndarray, sign: np.ndarray,
                  cols: np.ndarray, is_col: np.ndarray, q_ref: np.ndarray, goal: np.ndarray,
                  jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, f: int, tol: float,
                  lower: np.ndarray, upper: np.ndarray, out: np.ndarray,
                  inside: np.ndarray) -> int:
    """:func:`assemble` for a pose goal with one row per solution, in one pass.

    The same rows in the same order as ``assemble(..., POSE, ..., variants=False)`` (each
    candidate checked on the FK, polished when it is off by more than round-off, kept if within
    ``tol`` and not a duplicate of an earlier one modulo 2 pi; each solved joint at its 2 pi
    variant inside the limits nearest ``q_ref``; stably sorted by distance to ``q_ref``), built
    straight into the caller's arrays (an array handed back to Python costs more than one
    allocated there and passed in). The arguments are :func:`assemble`'s; ``out``
    ``(>= count, dof + 2)`` receives the rows, each the joints [rad] followed by the position
    [m] and rotation [rad] errors, and ``inside`` ``(>= count,)`` whether each row lies inside
    the limits.

    Returns:
        The number of solutions ``m`` (rows ``0 .. m - 1`` of ``out`` and ``inside``).
    """
    dof = q_ref.shape[0]
    cap = max(count, 1)
    # one scratch allocation for the rest (each allocation costs about as much as an FK joint)
    nc = cols.shape[0]
    scratch = np.empty(cap * (1 + nc) + dof + 25)
    dist = scratch[0:cap]
    wr = scratch[cap:cap + cap * nc].reshape((cap, nc))
    base = cap + cap * nc
    q = scratch[base:base + dof]
    pose = scratch[base + dof:base + dof + 16].reshape((4, 4))
    e = scratch[base + dof + 16:base + dof + 22]
    p = scratch[base + dof + 22:base + dof + 25]
    for i in range(3):
        p[i] = goal[i, 3]
    two_pi = 2.0 * math.pi
    m = 0
    for i in range(count):
        for j in range(dof):
            q[j] = q_ref[j]
        ok = True
        for k in range(joints.shape[0]):
            if is_col[joints[k]]:
                v = sign[k] * raw[i, k]
                if not math.isfinite(v):
                    ok = False
                q[joints[k]] = v
        if not ok:
            continue
        fk_into(q, jd, fd, paths, f, pose)
        ep, er = _residual(pose, POSE, goal, p, p, p, e)
        if not (ep < _ROUNDOFF and er < _ROUNDOFF):
            ep, er = polish(q, cols, POSE, goal, p, p, p, jd, fd, paths, f, 20)
        if not (ep <= tol and er <= tol):
            continue
        for c in range(nc):
            j = cols[c]
            w = q[j] - two_pi * math.floor((q[j] + math.pi) / two_pi)
            wr[m, c] = math.pi if w <= -math.pi else w
        dup = False
        for r in range(m):  # the kept solutions' wrapped values, in the order they were kept
            diff = 0.0
            for c in range(nc):
                x = abs(wr[m, c] - wr[r, c])
                diff = max(diff, min(x, two_pi - x))
            if diff < 1e-6:
                dup = True
                break
        if dup:
            continue
        # each solved joint at its variant inside its limits nearest q_ref (else wrapped)
        for c in range(nc):
            j = cols[c]
            v = wr[m, c]
            if math.isfinite(lower[j]) and math.isfinite(upper[j]):
                a = math.ceil((lower[j] - 1e-9 - v) / two_pi)
                b = math.floor((upper[j] + 1e-9 - v) / two_pi)
                if b >= a:
                    k = math.floor((q_ref[j] - v) / two_pi + 0.5)
                    v = v + two_pi * min(max(k, a), b)
            q[j] = v
        s = 0.0
        within = True
        for j in range(dof):
            s += (q[j] - q_ref[j]) ** 2
            if q[j] < lower[j] - 1e-9 or q[j] > upper[j] + 1e-9:
                within = False
        d = math.sqrt(s)
        at = m  # stable insertion: after every row at the same distance
        while at > 0 and dist[at - 1] > d:
            at -= 1
        for r in range(m, at, -1):
            for j in range(dof + 2):
                out[r, j] = out[r - 1, j]
            inside[r] = inside[r - 1]
            dist[r] = dist[r - 1]
        for j in range(dof):
            out[at, j] = q[j]
        out[at, dof] = ep
        out[at, dof + 1] = er
        inside[at] = within
        dist[at] = d
        m += 1
    return m
