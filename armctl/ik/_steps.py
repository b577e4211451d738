"""Compiled joint steps of the numerical IK methods: DLS, pseudoinverse, Jacobian transpose."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from armctl.ik._residual import NJIT, _residual


@nb.njit(**NJIT)
def _clamp(q: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
    for i in range(q.shape[0]):
        if q[i] < lower[i]:
            q[i] = lower[i]
        elif q[i] > upper[i]:
            q[i] = upper[i]


@nb.njit(**NJIT)
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


@nb.njit(**NJIT)
def _cap(dq: np.ndarray, max_step: float) -> None:
    m = 0.0
    for i in range(dq.shape[0]):
        m = max(m, abs(dq[i]))
    if m > max_step:
        s = max_step / m
        for i in range(dq.shape[0]):
            dq[i] *= s


@nb.njit(**NJIT)
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


@nb.njit(**NJIT)
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


@nb.njit(**NJIT)
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


@nb.njit(**NJIT)
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


@nb.njit(**NJIT)
def _jt_step(jac: np.ndarray, e: np.ndarray, m: int, n: int, tmp: np.ndarray,
             dq: np.ndarray, gain: float = 0.0) -> None:
    """Jacobian transpose ``dq = alpha J^T e``.

    ``gain`` > 0 is the lecture's fixed ``alpha``; 0 takes the optimal step length
    ``alpha = <e, J J^T e> / |J J^T e|^2``, which minimises the linearised error
    ``|e - J dq|^2``.
    """
    for c in range(n):
        s = 0.0
        for r in range(m):
            s += jac[r, c] * e[r]
        dq[c] = s
    if gain > 0.0:
        for c in range(n):
            dq[c] *= gain
        return
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


@nb.njit(**NJIT)
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




@nb.njit(**NJIT)
def _jt_apply(q: np.ndarray, qn: np.ndarray, dq: np.ndarray, en: float, gain: float,
              lower: np.ndarray, upper: np.ndarray, jd: np.ndarray, fd: np.ndarray,
              paths: np.ndarray, gf: np.ndarray, gt: np.ndarray, gd: np.ndarray, gw: np.ndarray,
              rw: float, pose: np.ndarray, jg: np.ndarray, e: np.ndarray,
              jac: np.ndarray) -> None:
    """Apply a J^T step: as it is for the lecture's fixed gain, else by :func:`_descend`.

    With a fixed gain (``gain`` > 0) the step is taken whether or not it lowers the error, as
    the lecture's iteration does; ``q`` is clamped into the limits.
    """
    if gain > 0.0:
        for i in range(q.shape[0]):
            q[i] += dq[i]
        _clamp(q, lower, upper)
        return
    _descend(q, qn, dq, en, lower, upper, jd, fd, paths, gf, gt, gd, gw, rw, pose, jg, e, jac)
