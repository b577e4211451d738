"""General 6R chains: every solution by Raghavan-Roth elimination in Manocha-Canny's form.

The closure equation ``E1 E2 E3 E4 E5 E6 M = T`` (product of exponentials, see :mod:`.chain`)
is split as ``E3 E4 E5 (o6, h6) = E2^-1 E1^-1 (T M^-1 o6, R_T R_M^T h6)``: joint 6 fixes
the points and the direction of its own axis, so it drops out. Measured from the point ``o3`` on
axis 3, the point ``p`` and the direction ``l`` of both sides give 14 scalar equations (Raghavan
and Roth, 1993): ``p``, ``l``, ``p.p``, ``p.l``, ``p x l`` and ``(p.p) l - 2 (p.l) p``. Each is of
degree at most one in the sine and cosine of every joint: on the left

    P(t3) [s4 s5, s4 c5, s4, c4 s5, c4 c5, c4, s5, c5, 1] = Q [s1 s2, s1 c2, s1, c1 s2, ..., 1]

with the entries of ``P`` affine in ``(s3, c3)`` and ``Q`` constant for a goal. Both are found
numerically, by evaluating the two sides on a 3-point grid per joint (the grid fit is exact for
this structure). The 8 non-constant products of joints 1 and 2 are eliminated with the left null
space of ``Q`` (6 equations remain); the tangent of half of each of joints 3, 4, 5 turns them
into polynomials of degree 2 in each, and multiplying them by ``x4`` gives 12 equations linear in
the 12 monomials ``x4^a x5^b`` (``a <= 3``, ``b <= 2``): ``(A2 x^2 + A1 x + A0) v = 0``
(Manocha and Canny, 1994). Its determinant has degree 24 in ``x`` (16 solutions and the spurious
pair ``x = +-i`` four times); the roots are the eigenvalues of the 24 x 24 companion matrix,
and ``x4``, ``x5`` come from the eigenvector. Joint 3's angle is measured from a shifted zero
(``t3 = phi + shift``, ``x = tan(phi / 2)``), the shift chosen from a fixed list so that ``A2`` is
well conditioned: a root at ``x = inf`` would otherwise be lost. Joints 1 and 2 follow from the
14 equations (least squares), joint 6 from subproblem 1. Every candidate is then polished and
checked on the exact FK (:mod:`._polish`).

Every solution of the chain is a real eigenvalue of the pencil, so the method is complete up to
the accuracy of the eigenvalues; candidates whose eigenvalue is nearly real (double roots split
by round-off) are kept too and decided by the polish.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from armctl.ik.analytic._subproblems import cross, dot, mm, mtm, mv, rot, sp1
from armctl.ik.analytic.chain import screw

__all__ = ["MAX_CANDIDATES", "general6r", "lhs_coefficients", "pencil", "rhs_coefficients",
           "well_posed"]

#: At most this many candidates (the pencil's degree).
MAX_CANDIDATES = 24
#: Shifts of joint 3's zero tried in turn for the eigenvalue variable [rad].
SHIFTS = np.array([0.5772156649, 2.6180339887, -1.4142135624, -2.7182818285, 1.7320508076])
#: Largest condition number of the leading coefficient accepted without trying another shift.
COND_OK = 1e7
#: Largest imaginary part (as an angle [rad]) of an eigenvalue kept as a candidate.
IMAG_TOL = 5e-3

_GRID = 2.0 * np.pi * np.arange(3) / 3.0
#: Inverse of the grid matrix ``[sin g, cos g, 1]``: grid values -> (s, c, 1) coefficients.
_FIT = np.ascontiguousarray(np.linalg.inv(np.column_stack(
    [np.sin(_GRID), np.cos(_GRID), np.ones(3)])))
#: (s, c, 1) times (1 + x^2) as polynomials in x = tan(t / 2): coefficients of 1, x, x^2.
_HALF = np.array([[0.0, 2.0, 0.0], [1.0, 0.0, -1.0], [1.0, 0.0, 1.0]])


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _fourteen(p: np.ndarray, u: np.ndarray, out: np.ndarray) -> None:
    """Raghavan and Roth's 14 quantities of a point ``p`` and a direction ``u``."""
    pp = dot(p, p)
    pl = dot(p, u)
    c = cross(p, u)
    for i in range(3):
        out[i] = p[i]
        out[3 + i] = u[i]
        out[8 + i] = c[i]
        out[11 + i] = pp * u[i] - 2.0 * pl * p[i]
    out[6] = pp
    out[7] = pl


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _lhs(h: np.ndarray, o: np.ndarray, t3: float, t4: float, t5: float, scale: float,
         out: np.ndarray) -> None:
    """The 14 quantities of ``E3 E4 E5 (o6, h6)`` relative to ``o3`` (lengths / ``scale``)."""
    r3 = rot(h[2], t3)
    r4 = rot(h[3], t4)
    r5 = rot(h[4], t5)
    v = mv(r5, o[5] - o[4]) + o[4] - o[3]
    v = mv(r4, v) + o[3] - o[2]
    p = mv(r3, v) / scale
    u = mv(r3, mv(r4, mv(r5, h[5])))
    _fourteen(p, u, out)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _rhs(h: np.ndarray, o: np.ndarray, xt: np.ndarray, lt: np.ndarray, t1: float, t2: float,
         scale: float, out: np.ndarray) -> None:
    """The 14 quantities of ``E2^-1 E1^-1 (xt, lt)`` relative to ``o3`` (lengths / ``scale``)."""
    r1 = rot(h[0], -t1)
    r2 = rot(h[1], -t2)
    v = mv(r1, xt - o[0]) + o[0] - o[1]
    p = (mv(r2, v) + o[1] - o[2]) / scale
    u = mv(r2, mv(r1, lt))
    _fourteen(p, u, out)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _scale(o: np.ndarray, m: np.ndarray) -> float:
    """A length of the arm's size (so that the equations are dimensionless) [m]."""
    s = 0.0
    for i in range(5):
        s += math.sqrt(dot(o[i + 1] - o[i], o[i + 1] - o[i]))
    d = m[:3, 3] - o[5]
    s += math.sqrt(dot(d, d))
    return max(s, 1e-3)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def lhs_coefficients(h: np.ndarray, o: np.ndarray, scale: float) -> np.ndarray:
    """``P`` as ``(14, 3, 9)``: equation, (s3, c3, 1), monomial ``(s4, c4, 1) x (s5, c5, 1)``."""
    vals = np.empty((3, 3, 3, 14))
    tmp = np.empty(14)
    for a in range(3):
        for b in range(3):
            for c in range(3):
                _lhs(h, o, _GRID[a], _GRID[b], _GRID[c], scale, tmp)
                vals[a, b, c] = tmp
    out = np.zeros((14, 3, 9))
    for i3 in range(3):
        for i4 in range(3):
            for i5 in range(3):
                for a in range(3):
                    for b in range(3):
                        for c in range(3):
                            w = _FIT[i3, a] * _FIT[i4, b] * _FIT[i5, c]
                            for k in range(14):
                                out[k, i3, i4 * 3 + i5] += w * vals[a, b, c, k]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def rhs_coefficients(h: np.ndarray, o: np.ndarray, xt: np.ndarray, lt: np.ndarray,
                     scale: float) -> np.ndarray:
    """``Q`` as ``(14, 9)``: monomials ``(s1, c1, 1) x (s2, c2, 1)``."""
    vals = np.empty((3, 3, 14))
    tmp = np.empty(14)
    for a in range(3):
        for b in range(3):
            _rhs(h, o, xt, lt, _GRID[a], _GRID[b], scale, tmp)
            vals[a, b] = tmp
    out = np.zeros((14, 9))
    for i1 in range(3):
        for i2 in range(3):
            for a in range(3):
                for b in range(3):
                    w = _FIT[i1, a] * _FIT[i2, b]
                    for k in range(14):
                        out[k, i1 * 3 + i2] += w * vals[a, b, k]
    return out


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _goal_parts(h: np.ndarray, o: np.ndarray, m: np.ndarray,
                goal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``T M^-1 o6`` and ``R_T R_M^T h6``: where axis 6 must be."""
    rm = m[:3, :3].copy()
    rg = goal[:3, :3].copy()
    local = np.empty(3)
    d = o[5] - m[:3, 3]
    for i in range(3):
        local[i] = rm[0, i] * d[0] + rm[1, i] * d[1] + rm[2, i] * d[2]
    xt = mv(rg, local) + goal[:3, 3]
    lt = mv(rg, np.ascontiguousarray(rm.T) @ h[5])
    return xt, lt


@nb.njit(cache=True, nogil=True, error_model="numpy")
def pencil(e: np.ndarray, shift: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 12 x 12 matrix polynomial ``A2 x^2 + A1 x + A0`` of the 6 eliminated equations.

    Args:
        e: ``(6, 3, 9)`` the equations: (s3, c3, 1) coefficients of the 9 monomials.
        shift: ``t3 = phi + shift`` and ``x = tan(phi / 2)`` [rad].

    Returns:
        ``(A0, A1, A2)``; columns are the monomials ``x4^a x5^b`` at ``3 a + b``.
    """
    cd, sd = math.cos(shift), math.sin(shift)
    polys = np.zeros((3, 6, 9))  # power of x, equation, (s4, c4, 1) x (s5, c5, 1)
    for r in range(6):
        for j in range(9):
            es = e[r, 0, j] * cd - e[r, 1, j] * sd  # coefficient of sin(phi)
            ec = e[r, 0, j] * sd + e[r, 1, j] * cd  # coefficient of cos(phi)
            e1 = e[r, 2, j]
            polys[0, r, j] = e1 + ec
            polys[1, r, j] = 2.0 * es
            polys[2, r, j] = e1 - ec
    mats = np.zeros((3, 12, 12))
    for k in range(3):
        for r in range(6):
            row = np.zeros(9)  # x4^a x5^b at 3 a + b
            for i4 in range(3):
                for i5 in range(3):
                    c = polys[k, r, i4 * 3 + i5]
                    if c == 0.0:
                        continue
                    for a in range(3):
                        for b in range(3):
                            row[a * 3 + b] += c * _HALF[i4, a] * _HALF[i5, b]
            for j in range(9):
                mats[k, r, j] = row[j]
                mats[k, 6 + r, 3 + j] = row[j]
    # balance: every row of the three matrices together to unit largest entry
    for r in range(12):
        big = 0.0
        for k in range(3):
            for j in range(12):
                big = max(big, abs(mats[k, r, j]))
        if big > 0.0:
            for k in range(3):
                for j in range(12):
                    mats[k, r, j] /= big
    return mats[0].copy(), mats[1].copy(), mats[2].copy()


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _half_angle(num: float, den: float) -> float:
    """``2 atan(num / den)`` without dividing (``den = 0``: the angle pi) [rad]."""
    return 2.0 * math.atan2(num, den)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def general6r(h: np.ndarray, o: np.ndarray, m: np.ndarray, goal: np.ndarray, ref: np.ndarray,
              out: np.ndarray) -> tuple[int, bool]:
    """Every candidate solution of a pose goal for a general 6R chain.

    Args:
        h: ``(6, 3)`` unit axes.
        o: ``(6, 3)`` points on them [m].
        m: ``(4, 4)`` tool pose at the zero configuration.
        goal: ``(4, 4)`` target pose.
        ref: ``(6,)`` reference configuration (unused: a general 6R goal has no continuum
            that this method resolves) [rad].
        out: ``(>= MAX_CANDIDATES, >= 6)`` receives the candidates [rad].

    Returns:
        ``(count, singular)``; ``singular`` is always False.
    """
    scale = _scale(o, m)
    xt, lt = _goal_parts(h, o, m, goal)
    pc = lhs_coefficients(h, o, scale)
    qc = rhs_coefficients(h, o, xt, lt, scale)
    for k in range(14):  # the right side's constant goes to the left
        pc[k, 2, 8] -= qc[k, 8]
    q8 = np.ascontiguousarray(qc[:, :8])
    u, sv, vt = np.linalg.svd(q8)
    if not sv[7] > 1e-12 * sv[0]:
        return 0, False
    # the 6 combinations of the 14 equations free of joints 1 and 2
    e = np.zeros((6, 3, 9))
    for r in range(6):
        for k in range(14):
            w = u[k, 8 + r]
            for i3 in range(3):
                for j in range(9):
                    e[r, i3, j] += w * pc[k, i3, j]
    best_cond = np.inf
    shift = SHIFTS[0]
    a0 = np.empty((12, 12))
    a1 = np.empty((12, 12))
    a2 = np.empty((12, 12))
    for s in SHIFTS:
        b0, b1, b2 = pencil(e, s)
        c = np.linalg.cond(b2)
        if c < best_cond:
            best_cond, shift = c, s
            a0, a1, a2 = b0, b1, b2
        if c < COND_OK:
            break
    if not best_cond < 1e14:
        return 0, False
    comp = np.zeros((24, 24), dtype=np.complex128)
    s0 = np.linalg.solve(a2, a0)
    s1 = np.linalg.solve(a2, a1)
    for i in range(12):
        comp[i, 12 + i] = 1.0
        for j in range(12):
            comp[12 + i, j] = -s0[i, j]
            comp[12 + i, 12 + j] = -s1[i, j]
    w, vec = np.linalg.eig(comp)
    n = 0
    f14 = np.empty(14)
    rhs = np.empty(14)
    vr = np.empty(12)
    for idx in range(24):
        x = w[idx]
        if not (math.isfinite(x.real) and math.isfinite(x.imag)):
            continue
        if 2.0 * abs(x.imag) / (1.0 + abs(x) ** 2) > IMAG_TOL:
            continue
        t3 = 2.0 * math.atan(x.real) + shift
        # the monomial vector, made real by dividing by its largest entry
        big, kb = -1.0, 0
        for j in range(12):
            if abs(vec[j, idx]) > big:
                big, kb = abs(vec[j, idx]), j
        piv = vec[kb, idx]
        for j in range(12):
            vr[j] = (vec[j, idx] / piv).real
        best, a4, b4 = -1.0, 0, 0
        for a in range(3):
            for b in range(3):
                g = abs(vr[a * 3 + b]) + abs(vr[(a + 1) * 3 + b])
                if g > best:
                    best, a4, b4 = g, a, b
        t4 = _half_angle(vr[(a4 + 1) * 3 + b4], vr[a4 * 3 + b4])
        best, a5, b5 = -1.0, 0, 0
        for a in range(4):
            for b in range(2):
                g = abs(vr[a * 3 + b]) + abs(vr[a * 3 + b + 1])
                if g > best:
                    best, a5, b5 = g, a, b
        t5 = _half_angle(vr[a5 * 3 + b5 + 1], vr[a5 * 3 + b5])
        # joints 1 and 2: the 14 equations are linear in their 8 products
        _lhs(h, o, t3, t4, t5, scale, f14)
        for k in range(14):
            rhs[k] = f14[k] - qc[k, 8]
        mono = np.zeros(8)
        for j in range(8):
            cj = 0.0
            for k in range(14):
                cj += u[k, j] * rhs[k]
            cj /= sv[j]
            for i in range(8):
                mono[i] += vt[j, i] * cj
        t1 = math.atan2(mono[2], mono[5])
        t2 = math.atan2(mono[6], mono[7])
        # joint 6: the rotation left for it
        r05 = mm(mm(mm(rot(h[0], t1), rot(h[1], t2)), mm(rot(h[2], t3), rot(h[3], t4))),
                 rot(h[4], t5))
        r6 = mtm(r05, mm(goal[:3, :3].copy(), np.ascontiguousarray(m[:3, :3].T)))
        ax = np.zeros(3)
        ax[np.argmin(np.abs(h[5]))] = 1.0
        u6 = cross(h[5], ax)
        t6, _ = sp1(h[5], u6, mv(r6, u6), 1e-12)
        if n >= out.shape[0]:
            break
        out[n, 0], out[n, 1], out[n, 2] = t1, t2, t3
        out[n, 3], out[n, 4], out[n, 5] = t4, t5, t6
        n += 1
    return n, False


def well_posed(h: np.ndarray, o: np.ndarray, m: np.ndarray, trials: int = 4) -> bool:
    """Whether the elimination works on this chain: it recovers known configurations.

    Special geometry the families do not cover (two parallel or two meeting consecutive axes)
    can make the eliminated system degenerate (``Q`` loses rank, or the pencil becomes singular
    for every ``x``). The chain passes if, for a few fixed configurations, the configuration
    that generated the goal is among the candidates (to 1e-5 rad; the polish does the rest).

    Args:
        h: ``(6, 3)`` unit axes.
        o: ``(6, 3)`` points on them [m].
        m: ``(4, 4)`` tool pose at the zero configuration.
        trials: How many configurations to try.
    """
    rng = np.random.default_rng(7)
    out = np.empty((MAX_CANDIDATES, 6))
    for _ in range(trials):
        q = rng.uniform(-np.pi, np.pi, 6)
        t = np.eye(4)
        for k in range(6):
            t = t @ screw(h[k], o[k], q[k])
        n, _ = general6r(h, o, m, np.ascontiguousarray(t @ m), q, out)
        if n == 0:
            return False
        gap = np.abs((out[:n, :6] - q + np.pi) % (2.0 * np.pi) - np.pi).max(axis=1)
        if gap.min() > 1e-5:
            return False
    return True
