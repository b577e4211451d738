"""Canonical subproblems of analytic IK, compiled with numba.

Every decomposition in this package reduces a chain to a few of these problems, each solved in
closed form (or through the roots of a quartic):

* :func:`sp1`: the angle that rotates one vector onto another about an axis.
* :func:`lin_trig`: ``a cos t + b sin t = e`` (two angles at most).
* :func:`trig2`: ``a0 + a1 cos t + b1 sin t + a2 cos 2t + b2 sin 2t = 0`` (four at most).
* :func:`circle2`: two unknown angles in two equations linear in their sines and cosines,
  ``A [cos t1, sin t1] + B [cos t2, sin t2] = d`` (four pairs at most). Both the three-circle
  problem (subproblem 5 of IK-Geo) and the two-angle problem (subproblem 6) reduce to it.

Functions return a count; -1 means a continuum of solutions (the caller picks representatives
and flags the goal as singular). Thresholds are generous: every candidate is checked and
polished against the exact forward kinematics afterwards, so a doubtful root costs a check,
while a missed root would cost a solution.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

#: Largest distance of a quartic root from the unit circle kept as a candidate.
ROOT_TOL = 1e-5


@nb.njit(cache=True, nogil=True, error_model="numpy")
def dot(a: np.ndarray, b: np.ndarray) -> float:
    """Dot product of two 3-vectors."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@nb.njit(cache=True, nogil=True, error_model="numpy")
def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of two 3-vectors."""
    out = np.empty(3)
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def norm(a: np.ndarray) -> float:
    """Euclidean norm of a 3-vector."""
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


@nb.njit(cache=True, nogil=True, error_model="numpy")
def mm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` for 3x3 matrices (no BLAS call)."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def mtm(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a.T @ b`` for 3x3 matrices."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = a[0, i] * b[0, j] + a[1, i] * b[1, j] + a[2, i] * b[2, j]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def mmt(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b.T`` for 3x3 matrices."""
    out = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[j, 0] + a[i, 1] * b[j, 1] + a[i, 2] * b[j, 2]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def mv(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``a @ x`` for a 3x3 (or the 3x3 block of a larger) matrix and a 3-vector."""
    out = np.empty(3)
    for i in range(3):
        out[i] = a[i, 0] * x[0] + a[i, 1] * x[1] + a[i, 2] * x[2]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def mtv(a: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``a.T @ x`` for a 3x3 (or the 3x3 block of a larger) matrix and a 3-vector."""
    out = np.empty(3)
    for i in range(3):
        out[i] = a[0, i] * x[0] + a[1, i] * x[1] + a[2, i] * x[2]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def rot(k: np.ndarray, t: float) -> np.ndarray:
    """Rotation matrix ``(3, 3)`` about the unit axis ``k`` by ``t`` [rad] (Rodrigues)."""
    c = math.cos(t)
    s = math.sin(t)
    v = 1.0 - c
    x, y, z = k[0], k[1], k[2]
    r = np.empty((3, 3))
    r[0, 0] = c + x * x * v
    r[0, 1] = x * y * v - z * s
    r[0, 2] = x * z * v + y * s
    r[1, 0] = y * x * v + z * s
    r[1, 1] = c + y * y * v
    r[1, 2] = y * z * v - x * s
    r[2, 0] = z * x * v - y * s
    r[2, 1] = z * y * v + x * s
    r[2, 2] = c + z * z * v
    return r


@nb.njit(cache=True, nogil=True, error_model="numpy")
def rot_into(k: np.ndarray, t: float, r: np.ndarray) -> None:
    """:func:`rot` written into ``r`` (no allocation, for the hot loops)."""
    c = math.cos(t)
    s = math.sin(t)
    v = 1.0 - c
    x, y, z = k[0], k[1], k[2]
    r[0, 0] = c + x * x * v
    r[0, 1] = x * y * v - z * s
    r[0, 2] = x * z * v + y * s
    r[1, 0] = y * x * v + z * s
    r[1, 1] = c + y * y * v
    r[1, 2] = y * z * v - x * s
    r[2, 0] = z * x * v - y * s
    r[2, 1] = z * y * v + x * s
    r[2, 2] = c + z * z * v


@nb.njit(cache=True, nogil=True, error_model="numpy")
def rot_cs_into(k: np.ndarray, c: float, s: float, r: np.ndarray) -> None:
    """:func:`rot_into` from the cosine ``c`` and sine ``s`` of the angle (no trigonometry)."""
    v = 1.0 - c
    x, y, z = k[0], k[1], k[2]
    r[0, 0] = c + x * x * v
    r[0, 1] = x * y * v - z * s
    r[0, 2] = x * z * v + y * s
    r[1, 0] = y * x * v + z * s
    r[1, 1] = c + y * y * v
    r[1, 2] = y * z * v - x * s
    r[2, 0] = z * x * v - y * s
    r[2, 1] = z * y * v + x * s
    r[2, 2] = c + z * z * v


@nb.njit(cache=True, nogil=True, error_model="numpy")
def rotv_cs_into(k: np.ndarray, c: float, s: float, x: np.ndarray, out: np.ndarray) -> None:
    """``out = rot(k, t) @ x`` from the cosine ``c`` and sine ``s`` of ``t`` (``out`` not ``x``)."""
    kx = (k[0] * x[0] + k[1] * x[1] + k[2] * x[2]) * (1.0 - c)
    out[0] = x[0] * c + (k[1] * x[2] - k[2] * x[1]) * s + k[0] * kx
    out[1] = x[1] * c + (k[2] * x[0] - k[0] * x[2]) * s + k[1] * kx
    out[2] = x[2] * c + (k[0] * x[1] - k[1] * x[0]) * s + k[2] * kx


@nb.njit(cache=True, nogil=True, error_model="numpy")
def mm_into(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out = a @ b`` for 3x3 matrices (``out`` distinct from both)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@nb.njit(cache=True, nogil=True, error_model="numpy")
def mtm_into(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:
    """``out = a.T @ b`` for 3x3 matrices (``out`` distinct from both)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[0, i] * b[0, j] + a[1, i] * b[1, j] + a[2, i] * b[2, j]


@nb.njit(cache=True, nogil=True, error_model="numpy")
def mv_into(a: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    """``out = a @ x`` for a 3x3 matrix and a 3-vector (``out`` distinct from ``x``)."""
    for i in range(3):
        out[i] = a[i, 0] * x[0] + a[i, 1] * x[1] + a[i, 2] * x[2]


@nb.njit(cache=True, nogil=True, error_model="numpy")
def rotv(k: np.ndarray, t: float, x: np.ndarray) -> np.ndarray:
    """``rot(k, t) @ x`` without forming the matrix."""
    c = math.cos(t)
    s = math.sin(t)
    kx = dot(k, x)
    kc = cross(k, x)
    out = np.empty(3)
    for i in range(3):
        out[i] = x[i] * c + kc[i] * s + k[i] * kx * (1.0 - c)
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def trig_coeffs(h: np.ndarray, k: np.ndarray, x: np.ndarray) -> tuple[float, float, float]:
    """``h . rot(k, t) x = cc cos t + ss sin t + cst``; returns ``(cc, ss, cst)``."""
    kx = k[0] * x[0] + k[1] * x[1] + k[2] * x[2]
    cst = kx * (h[0] * k[0] + h[1] * k[1] + h[2] * k[2])
    cc = h[0] * x[0] + h[1] * x[1] + h[2] * x[2] - cst
    ss = (h[0] * (k[1] * x[2] - k[2] * x[1]) + h[1] * (k[2] * x[0] - k[0] * x[2])
          + h[2] * (k[0] * x[1] - k[1] * x[0]))  # h . (k x x)
    return cc, ss, cst


@nb.njit(cache=True, nogil=True, error_model="numpy")
def wrap(t: float) -> float:
    """An angle wrapped into (-pi, pi] [rad]."""
    w = t - 2.0 * math.pi * math.floor((t + math.pi) / (2.0 * math.pi))
    return math.pi if w <= -math.pi else w


@nb.njit(cache=True, nogil=True, error_model="numpy")
def sp1(k: np.ndarray, p: np.ndarray, q: np.ndarray, tol: float) -> tuple[float, bool]:
    """Subproblem 1: the angle ``t`` with ``rot(k, t) p`` closest to ``q``.

    Returns:
        ``(t, degenerate)``; ``degenerate`` when ``p`` or ``q`` lies (within ``tol``) on the
        axis, so any angle does equally well.
    """
    kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2]
    kq = k[0] * q[0] + k[1] * q[1] + k[2] * q[2]
    p0, p1, p2 = p[0] - kp * k[0], p[1] - kp * k[1], p[2] - kp * k[2]
    q0, q1, q2 = q[0] - kq * k[0], q[1] - kq * k[1], q[2] - kq * k[2]
    if (math.sqrt(p0 * p0 + p1 * p1 + p2 * p2) <= tol
            or math.sqrt(q0 * q0 + q1 * q1 + q2 * q2) <= tol):
        return 0.0, True
    # k . (pp x qp) and pp . qp, without temporaries
    s = (k[0] * (p1 * q2 - p2 * q1) + k[1] * (p2 * q0 - p0 * q2) + k[2] * (p0 * q1 - p1 * q0))
    return math.atan2(s, p0 * q0 + p1 * q1 + p2 * q2), False


@nb.njit(cache=True, nogil=True, error_model="numpy")
def sp1_cs(k: np.ndarray, p: np.ndarray, q: np.ndarray,
           tol: float) -> tuple[float, float, float, bool]:
    """:func:`sp1` with the cosine and sine of the angle: ``(t, cos t, sin t, degenerate)``.

    The cosine and sine come from the same two products as the angle (no trigonometry); a
    degenerate problem gives ``(0, 1, 0, True)``.
    """
    kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2]
    kq = k[0] * q[0] + k[1] * q[1] + k[2] * q[2]
    p0, p1, p2 = p[0] - kp * k[0], p[1] - kp * k[1], p[2] - kp * k[2]
    q0, q1, q2 = q[0] - kq * k[0], q[1] - kq * k[1], q[2] - kq * k[2]
    if (math.sqrt(p0 * p0 + p1 * p1 + p2 * p2) <= tol
            or math.sqrt(q0 * q0 + q1 * q1 + q2 * q2) <= tol):
        return 0.0, 1.0, 0.0, True
    s = (k[0] * (p1 * q2 - p2 * q1) + k[1] * (p2 * q0 - p0 * q2) + k[2] * (p0 * q1 - p1 * q0))
    c = p0 * q0 + p1 * q1 + p2 * q2
    r = math.hypot(s, c)  # |pp| |qp| > 0: both are off the axis
    return math.atan2(s, c), c / r, s / r, False


@nb.njit(cache=True, nogil=True, error_model="numpy")
def lin_trig(a: float, b: float, e: float, scale: float, out: np.ndarray) -> int:
    """Solve ``a cos t + b sin t = e`` for ``t`` [rad].

    Args:
        a: Coefficient of ``cos t``.
        b: Coefficient of ``sin t``.
        e: Right-hand side.
        scale: Magnitude of the terms (for the degeneracy tests).
        out: Receives up to two angles.

    Returns:
        The number of solutions, or -1 for every angle (``a = b = e = 0``).
    """
    r = math.hypot(a, b)
    if r <= 1e-11 * scale:
        return -1 if abs(e) <= 1e-9 * scale else 0
    x = e / r
    if abs(x) > 1.0 + 1e-5:  # generous: a goal just past a fold still gets its tangent
        return 0  # candidate, which the polish on the exact FK accepts or rejects
    x = min(1.0, max(-1.0, x))
    phi = math.atan2(b, a)
    d = math.acos(x)
    if d < 1e-12:
        out[0] = wrap(phi)
        return 1
    out[0] = wrap(phi + d)
    out[1] = wrap(phi - d)
    return 2


@nb.njit(cache=True, nogil=True, error_model="numpy")
def lin_trig_cs(a: float, b: float, e: float, scale: float, out: np.ndarray,
                cs: np.ndarray) -> int:
    """:func:`lin_trig` with the cosine and sine of each angle in ``cs`` ``(>=2, 2)``.

    The same angles in ``out``; ``cs[i]`` is ``(cos out[i], sin out[i])`` from the equation's
    own coefficients (no trigonometry beyond the angles'). Nothing is written to ``cs`` for a
    continuum (-1).
    """
    r = math.hypot(a, b)
    if r <= 1e-11 * scale:
        return -1 if abs(e) <= 1e-9 * scale else 0
    x = e / r
    if abs(x) > 1.0 + 1e-5:  # as lin_trig
        return 0
    x = min(1.0, max(-1.0, x))
    phi = math.atan2(b, a)
    d = math.acos(x)
    cp, sp = a / r, b / r
    if d < 1e-12:
        out[0] = wrap(phi)
        cs[0, 0], cs[0, 1] = cp, sp
        return 1
    sd = math.sqrt((1.0 - x) * (1.0 + x))  # sin d
    out[0] = wrap(phi + d)
    cs[0, 0], cs[0, 1] = cp * x - sp * sd, sp * x + cp * sd
    out[1] = wrap(phi - d)
    cs[1, 0], cs[1, 1] = cp * x + sp * sd, sp * x - cp * sd
    return 2


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _trig2_eval(c: np.ndarray, t: float) -> tuple[float, float]:
    ct, st = math.cos(t), math.sin(t)
    c2, s2 = math.cos(2.0 * t), math.sin(2.0 * t)
    f = c[0] + c[1] * ct + c[2] * st + c[3] * c2 + c[4] * s2
    df = -c[1] * st + c[2] * ct - 2.0 * c[3] * s2 + 2.0 * c[4] * c2
    return f, df


@nb.njit(cache=True, nogil=True, error_model="numpy")
def quartic_roots(poly: np.ndarray) -> np.ndarray:
    """The four complex roots of ``poly[0] z^4 + ... + poly[4]`` (``poly[0] != 0``).

    Aberth-Ehrlich iteration started on the unit circle (where the roots of interest lie). Simple
    roots converge cubically; a multiple root (a tangency) converges linearly, and its estimate
    after the iteration budget is refined by the Newton steps of the callers and the polish.
    """
    c = poly / poly[0]
    z = np.empty(4, dtype=np.complex128)
    for i in range(4):
        ang = 0.4 + 0.5 * math.pi * i
        z[i] = complex(math.cos(ang), math.sin(ang))
    for _ in range(60):
        moved = 0.0
        for i in range(4):
            zi = z[i]
            p = (((zi + c[1]) * zi + c[2]) * zi + c[3]) * zi + c[4]
            dp = ((4.0 * zi + 3.0 * c[1]) * zi + 2.0 * c[2]) * zi + c[3]
            if p == 0:
                continue
            r = p / dp if dp != 0 else p
            s = 0j
            for j in range(4):
                if j != i:
                    s += 1.0 / (zi - z[j])
            w = r / (1.0 - r * s)
            z[i] = zi - w
            moved = max(moved, abs(w) / max(1.0, abs(zi)))
        if moved < 1e-12:  # quadratic-to-cubic convergence: one more sweep is exact
            return z
    return z  # near a multiple root: close enough for the Newton steps that follow


@nb.njit(cache=True, nogil=True, error_model="numpy")
def trig2(a0: float, a1: float, b1: float, a2: float, b2: float, out: np.ndarray) -> int:
    """Solve ``a0 + a1 cos t + b1 sin t + a2 cos 2t + b2 sin 2t = 0`` for ``t`` [rad].

    With ``z = exp(i t)`` the equation times ``z^2`` is a quartic in ``z``; its roots on the unit
    circle (within :data:`ROOT_TOL`) are the solutions, found by :func:`quartic_roots`
    (no tangent half-angle, so ``t = pi`` is not special), then refined by Newton steps.

    Args:
        a0: Constant term (the coefficients are dimensionless, of order one).
        a1: Coefficient of ``cos t``.
        b1: Coefficient of ``sin t``.
        a2: Coefficient of ``cos 2t``.
        b2: Coefficient of ``sin 2t``.
        out: Receives up to four angles.

    Returns:
        The number of solutions, or -1 when the equation holds for every angle.
    """
    scale = max(abs(a0), abs(a1), abs(b1), abs(a2), abs(b2))
    if scale == 0.0:
        return -1
    r2 = math.hypot(a2, b2)
    if r2 <= 1e-12 * scale:
        r1 = math.hypot(a1, b1)
        if r1 <= 1e-12 * scale:
            return -1 if abs(a0) <= 1e-9 else 0
        return lin_trig(a1, b1, -a0, scale, out)
    coef = np.empty(5)
    coef[0] = a0
    coef[1] = a1
    coef[2] = b1
    coef[3] = a2
    coef[4] = b2
    poly = np.empty(5, dtype=np.complex128)  # z^4 .. z^0
    poly[0] = 0.5 * (a2 - 1j * b2)
    poly[1] = 0.5 * (a1 - 1j * b1)
    poly[2] = a0
    poly[3] = 0.5 * (a1 + 1j * b1)
    poly[4] = 0.5 * (a2 + 1j * b2)
    roots = quartic_roots(poly)
    n = 0
    for z in roots:
        if abs(abs(z) - 1.0) > ROOT_TOL:
            continue
        t = math.atan2(z.imag, z.real)
        for _ in range(3):
            f, df = _trig2_eval(coef, t)
            if abs(df) < 1e-9 * scale:
                break
            t -= f / df
        out[n] = wrap(t)
        n += 1
    return n


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _left_null(a: np.ndarray) -> np.ndarray:
    """A unit ``u`` with ``u @ a = 0`` for a singular 2x2 ``a``."""
    u = np.empty(2)
    if math.hypot(a[1, 0], a[0, 0]) >= math.hypot(a[1, 1], a[0, 1]):
        u[0], u[1] = a[1, 0], -a[0, 0]
    else:
        u[0], u[1] = a[1, 1], -a[0, 1]
    n = math.hypot(u[0], u[1])
    u /= n
    return u


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _reduce_rank1(G: np.ndarray, g0: float, g1: float, t1: np.ndarray, t2: np.ndarray) -> int:
    """``|g - G x1| = 1`` with ``x1 = [cos t1, sin t1]`` when ``G`` has rank one.

    Then ``G = u w^T`` and ``G x1 = u s`` with ``s = w . x1``: a quadratic in ``s`` and, for
    each root, ``w . x1 = s`` by :func:`lin_trig` (the decoupled arms: UR-type wrists, shoulders
    whose second and third axes are parallel). The quartic of :func:`trig2` degenerates there
    (a root runs off to infinity) and its iteration is slow, so this exact form is used instead.

    Returns:
        The number of pairs written to ``t1``, ``t2``, or -1 when ``G`` is not of rank one (or
        ``w`` vanishes): the caller then takes the general path.
    """
    n0 = G[0, 0] * G[0, 0] + G[0, 1] * G[0, 1]
    n1 = G[1, 0] * G[1, 0] + G[1, 1] * G[1, 1]
    big = max(n0, n1)
    if big <= 1e-18 or abs(G[0, 0] * G[1, 1] - G[0, 1] * G[1, 0]) > 1e-13 * big:
        return -1
    r = 0 if n0 >= n1 else 1
    w0, w1 = G[r, 0], G[r, 1]
    alpha = (G[1 - r, 0] * w0 + G[1 - r, 1] * w1) / big  # the other row is alpha * w
    u0, u1 = (1.0, alpha) if r == 0 else (alpha, 1.0)
    uu = u0 * u0 + u1 * u1
    ug = u0 * g0 + u1 * g1
    gg = g0 * g0 + g1 * g1
    disc = ug * ug - uu * (gg - 1.0)
    if disc < -ROOT_TOL * (ug * ug + uu * (gg + 1.0)):
        return 0
    root = math.sqrt(max(disc, 0.0))
    ns = 1 if root == 0.0 else 2
    wn = math.sqrt(big)
    sol = np.empty(2)
    n = 0
    for i in range(ns):
        k = lin_trig(w0, w1, (ug + root) / uu if i == 0 else (ug - root) / uu, wn, sol)
        if k == -1:
            return -1
        for j in range(k):
            c, s = math.cos(sol[j]), math.sin(sol[j])
            t1[n] = sol[j]
            t2[n] = math.atan2(g1 - G[1, 0] * c - G[1, 1] * s, g0 - G[0, 0] * c - G[0, 1] * s)
            n += 1
    return n


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _reduce(a: np.ndarray, b: np.ndarray, d: np.ndarray, ref: float,
            t1: np.ndarray, t2: np.ndarray) -> tuple[int, bool]:
    """``circle2`` when ``b`` is invertible: ``x2 = g - G x1`` and ``|x2| = 1``.

    ``ref`` is the representative ``t1`` of a continuum.
    """
    det = b[0, 0] * b[1, 1] - b[0, 1] * b[1, 0]
    # G = b^-1 a, g = b^-1 d
    g0 = (b[1, 1] * d[0] - b[0, 1] * d[1]) / det
    g1 = (-b[1, 0] * d[0] + b[0, 0] * d[1]) / det
    G = np.empty((2, 2))
    for j in range(2):
        G[0, j] = (b[1, 1] * a[0, j] - b[0, 1] * a[1, j]) / det
        G[1, j] = (-b[1, 0] * a[0, j] + b[0, 0] * a[1, j]) / det
    q00 = G[0, 0] * G[0, 0] + G[1, 0] * G[1, 0]
    q11 = G[0, 1] * G[0, 1] + G[1, 1] * G[1, 1]
    q01 = G[0, 0] * G[0, 1] + G[1, 0] * G[1, 1]
    gg0 = G[0, 0] * g0 + G[1, 0] * g1
    gg1 = G[0, 1] * g0 + G[1, 1] * g1
    n = _reduce_rank1(G, g0, g1, t1, t2)
    if n >= 0:
        return n, False
    roots = np.empty(4)
    n = trig2(g0 * g0 + g1 * g1 - 1.0 + 0.5 * (q00 + q11), -2.0 * gg0, -2.0 * gg1,
              0.5 * (q00 - q11), q01, roots)
    if n == -1:  # |g - G x1| = 1 for every t1: take t1 as the representative
        x1c, x1s = math.cos(ref), math.sin(ref)
        t1[0] = ref
        t2[0] = math.atan2(g1 - G[1, 0] * x1c - G[1, 1] * x1s, g0 - G[0, 0] * x1c - G[0, 1] * x1s)
        return 1, True
    for i in range(n):
        c, s = math.cos(roots[i]), math.sin(roots[i])
        t1[i] = roots[i]
        t2[i] = math.atan2(g1 - G[1, 0] * c - G[1, 1] * s, g0 - G[0, 0] * c - G[0, 1] * s)
    return n, False


@nb.njit(cache=True, nogil=True, error_model="numpy")
def circle2(a: np.ndarray, b: np.ndarray, d: np.ndarray, ref1: float, ref2: float,
            t1: np.ndarray, t2: np.ndarray) -> tuple[int, bool]:
    """Solve ``a @ [cos t1, sin t1] + b @ [cos t2, sin t2] = d`` for the angle pairs.

    Args:
        a: ``(2, 2)`` coefficients of ``[cos t1, sin t1]``.
        b: ``(2, 2)`` coefficients of ``[cos t2, sin t2]``.
        d: ``(2,)`` right-hand side.
        ref1: Representative ``t1`` when the solutions are a continuum [rad].
        ref2: Representative ``t2`` likewise [rad].
        t1: Receives up to four angles [rad].
        t2: Receives the matching angles [rad].

    Returns:
        ``(count, continuum)``; ``continuum`` is True when the returned pairs are representatives
        of infinitely many.
    """
    s = 0.0
    for i in range(2):
        for j in range(2):
            s = max(s, abs(a[i, j]), abs(b[i, j]))
    if s == 0.0:
        return 0, False
    det_a = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    det_b = b[0, 0] * b[1, 1] - b[0, 1] * b[1, 0]
    if max(abs(det_a), abs(det_b)) > 1e-10 * s * s:
        if abs(det_b) >= abs(det_a):
            return _reduce(a, b, d, ref1, t1, t2)
        return _reduce(b, a, d, ref2, t2, t1)
    # both singular: either rank [a b] = 2 with two rank-one blocks (the equations decouple),
    # or rank [a b] <= 1 (one equation for two angles: a continuum)
    # rank of [a b]: its largest 2x2 minor
    cols = np.empty((2, 4))
    cols[:, :2] = a
    cols[:, 2:] = b
    minor = 0.0
    for i in range(4):
        for j in range(i + 1, 4):
            minor = max(minor, abs(cols[0, i] * cols[1, j] - cols[0, j] * cols[1, i]))
    sol1 = np.empty(2)
    sol2 = np.empty(2)
    if minor <= 1e-10 * s * s:
        # one equation (the larger row; the other is a multiple of it): x1 at its
        # representative, solve for x2 (or the other way round)
        r = 0 if np.abs(cols[0]).max() >= np.abs(cols[1]).max() else 1
        ca, sa, cb, sb, e = a[r, 0], a[r, 1], b[r, 0], b[r, 1], d[r]
        if abs(d[1 - r]) > 1e-9 * (abs(e) + s) and np.abs(cols[1 - r]).max() <= 1e-10 * s:
            return 0, False  # the other equation reads 0 = d: inconsistent
        if math.hypot(cb, sb) >= math.hypot(ca, sa):
            n = lin_trig(cb, sb, e - ca * math.cos(ref1) - sa * math.sin(ref1), s, sol2)
            if n == -1:
                n, sol2[0] = 1, ref2
            for i in range(n):
                t1[i] = ref1
                t2[i] = sol2[i]
        else:
            n = lin_trig(ca, sa, e - cb * math.cos(ref2) - sb * math.sin(ref2), s, sol1)
            if n == -1:
                n, sol1[0] = 1, ref1
            for i in range(n):
                t1[i] = sol1[i]
                t2[i] = ref2
        return max(n, 0), True
    u = _left_null(a)
    v = _left_null(b)
    n2 = lin_trig(u[0] * b[0, 0] + u[1] * b[1, 0], u[0] * b[0, 1] + u[1] * b[1, 1],
                  u[0] * d[0] + u[1] * d[1], s, sol2)
    n1 = lin_trig(v[0] * a[0, 0] + v[1] * a[1, 0], v[0] * a[0, 1] + v[1] * a[1, 1],
                  v[0] * d[0] + v[1] * d[1], s, sol1)
    cont = False
    if n1 == -1:
        n1, sol1[0], cont = 1, ref1, True
    if n2 == -1:
        n2, sol2[0], cont = 1, ref2, True
    n = 0
    for i in range(n1):
        for j in range(n2):
            t1[n] = sol1[i]
            t2[n] = sol2[j]
            n += 1
    return n, cont
