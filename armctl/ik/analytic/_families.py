"""Closed-form solvers of the decomposable chain families, compiled with numba.

A chain is given in product-of-exponentials form at its zero configuration: ``H`` ``(n, 3)`` unit
joint axes and ``O`` ``(n, 3)`` points on them, both in the base frame, and ``M`` ``(4, 4)`` the
tool pose. The pose at ``q`` is ``E1(q1) ... En(qn) M`` with ``Ei`` the rotation about axis ``i``.
Each solver writes candidate joint vectors (chain order) into ``out`` and returns
``(count, singular)``; candidates are checked and polished afterwards (:mod:`._polish`).
Continua take the matching entry of ``ref`` as their representative and set ``singular``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from armctl.ik.analytic._subproblems import (
    circle2,
    cross,
    dot,
    lin_trig,
    lin_trig_cs,
    mm_into,
    mtm_into,
    mv,
    mv_into,
    norm,
    rot,
    rot_cs_into,
    rot_into,
    rotv,
    rotv_cs_into,
    sp1,
    sp1_cs,
    trig_coeffs,
    wrap,
)

_DEG = 1e-9  # below this a unit vector counts as lying on an axis
_AXIS = 1e-5  # [rad] a tool axis or goal direction this close to a joint axis counts as on it
_NEAR = 1e-3  # [rad] a goal direction this close to axis 1 also gets the continuum's candidates


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _perp(k: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to the unit vector ``k``."""
    e = np.zeros(3)
    e[np.argmin(np.abs(k))] = 1.0
    u = cross(k, e)
    return u / norm(u)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _perp_into(k: np.ndarray, out: np.ndarray) -> None:
    """:func:`_perp` written into ``out`` (no allocation)."""
    i = 0
    if abs(k[1]) < abs(k[i]):
        i = 1
    if abs(k[2]) < abs(k[i]):
        i = 2
    # k x e_i
    if i == 0:
        x, y, z = 0.0, k[2], -k[1]
    elif i == 1:
        x, y, z = -k[2], 0.0, k[0]
    else:
        x, y, z = k[1], -k[0], 0.0
    n = math.sqrt(x * x + y * y + z * z)
    out[0], out[1], out[2] = x / n, y / n, z / n


@nb.njit(cache=True, nogil=True, error_model="numpy")
def pos3(h: np.ndarray, o: np.ndarray, w: np.ndarray, target: np.ndarray, ref: np.ndarray,
         out: np.ndarray) -> tuple[int, bool]:
    """Angles of three revolute joints that bring the point ``w`` to ``target``.

    :func:`pos3_cs` without the cosines and sines (see there).
    """
    return pos3_cs(h, o, w, target, ref, out, np.empty((out.shape[0], 6)))


@nb.njit(cache=True, nogil=True, error_model="numpy")
def pos3_cs(h: np.ndarray, o: np.ndarray, w: np.ndarray, target: np.ndarray, ref: np.ndarray,
            out: np.ndarray, cs: np.ndarray) -> tuple[int, bool]:
    """Angles of three revolute joints that bring the point ``w`` to ``target``.

    The point's equation ``target - o1 = R1 (p12 + R2 (p23 + R3 p34))`` is reduced, by the
    invariants of the middle rotation (the component along ``h2`` and the norm), to two equations
    linear in the sines and cosines of ``q1`` and ``q3`` (:func:`circle2`); ``q2`` then follows
    by subproblem 1. Up to four solutions.

    Args:
        h: ``(>=3, 3)`` axes; rows 0-2 are used.
        o: ``(>=3, 3)`` points on the axes.
        w: The moving point at the zero configuration [m].
        target: Where it must go [m].
        ref: Representatives ``(>=3,)`` for continua [rad].
        out: ``(>=4, >=3)`` receives the angles in columns 0-2.
        cs: ``(>=4, 6)`` receives the cosine and sine of each angle (columns 0-1, 2-3, 4-5),
            computed on the way (the caller builds rotations from them without trigonometry).
    """
    h1, h2, h3 = h[0], h[1], h[2]
    vec = np.empty((6, 3))  # one allocation for the vectors below
    v, p12, p23, p34, rv, pv = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5]
    for r in range(3):
        v[r] = target[r] - o[0, r]
        p12[r] = o[1, r] - o[0, r]
        p23[r] = o[2, r] - o[1, r]
        p34[r] = w[r] - o[2, r]
    lscale = norm(v) + norm(p12) + norm(p23) + norm(p34) + 1e-300
    cca, ssa, csa = trig_coeffs(h2, h1, v)
    ccb, ssb, csb = trig_coeffs(p12, h1, v)
    ccc, ssc, csc = trig_coeffs(h2, h3, p34)
    ccd, ssd, csd = trig_coeffs(p23, h3, p34)
    coef = np.empty((5, 2))  # a (rows 0-1), b (rows 2-3), d (row 4)
    a, b, d = coef[0:2], coef[2:4], coef[4]
    k1 = 1.0 / lscale
    k2 = k1 * k1
    a[0, 0], a[0, 1] = cca * k1, -ssa * k1
    b[0, 0], b[0, 1] = -ccc * k1, -ssc * k1
    d[0] = (dot(h2, p12) + dot(h2, p23) - csa + csc) * k1
    a[1, 0], a[1, 1] = -2.0 * ccb * k2, 2.0 * ssb * k2
    b[1, 0], b[1, 1] = -2.0 * ccd * k2, -2.0 * ssd * k2
    d[1] = (dot(p23, p23) + dot(p34, p34) - dot(v, v) - dot(p12, p12) + 2.0 * csb
            + 2.0 * csd) * k2
    ts = np.empty((2, 4))
    t1, t3 = ts[0], ts[1]
    n, singular = circle2(a, b, d, ref[0], ref[2], t1, t3)
    for i in range(n):
        # rv = rot(h1, -t1) v - p12, pv = p23 + rot(h3, t3) p34 (Rodrigues, no temporaries)
        c1, s1 = math.cos(t1[i]), -math.sin(t1[i])
        c3, s3 = math.cos(t3[i]), math.sin(t3[i])
        k1 = (h1[0] * v[0] + h1[1] * v[1] + h1[2] * v[2]) * (1.0 - c1)
        k3 = (h3[0] * p34[0] + h3[1] * p34[1] + h3[2] * p34[2]) * (1.0 - c3)
        for r in range(3):
            r1, r2 = (r + 1) % 3, (r + 2) % 3
            rv[r] = (v[r] * c1 + (h1[r1] * v[r2] - h1[r2] * v[r1]) * s1 + h1[r] * k1
                     - p12[r])
            pv[r] = (p23[r] + p34[r] * c3 + (h3[r1] * p34[r2] - h3[r2] * p34[r1]) * s3
                     + h3[r] * k3)
        t2, c2, s2, deg = sp1_cs(h2, pv, rv, _DEG * lscale)
        if deg:
            t2, c2, s2 = ref[1], math.cos(ref[1]), math.sin(ref[1])
            singular = True
        out[i, 0] = t1[i]
        out[i, 1] = t2
        out[i, 2] = t3[i]
        cs[i, 0], cs[i, 1], cs[i, 2], cs[i, 3], cs[i, 4], cs[i, 5] = c1, -s1, c2, s2, c3, s3
    return n, singular


@nb.njit(cache=True, nogil=True, error_model="numpy")
def spherical_wrist(h: np.ndarray, o: np.ndarray, m: np.ndarray, goal: np.ndarray,
                    ref: np.ndarray, out: np.ndarray) -> tuple[int, bool]:
    """6R chain whose axes 4, 5, 6 meet in one point ``o[3]`` (Pieper): up to 8 solutions.

    The wrist centre fixes joints 1-3 (:func:`pos3`); the wrist rotation gives ``q5`` by
    subproblem 4 and ``q4``, ``q6`` by subproblem 1. Axes 4 and 6 aligned (a continuum) take
    ``ref[3]`` for ``q4``.
    """
    w = o[3]
    # scratch (a few allocations, none per candidate)
    vec = np.empty((11, 3))
    dw, target, u6, v456, v5, v6, t5s = vec[0], vec[1], vec[2], vec[3], vec[4], vec[5], vec[6]
    cs5 = vec[7:9, 0:2]  # cosines and sines of the q5 candidates
    w6, x6 = vec[9], vec[10]
    mats = np.empty((5, 3, 3))
    rg, ra, rb, rc, r456 = mats[0], mats[1], mats[2], mats[3], mats[4]
    for r in range(3):
        dw[r] = w[r] - m[r, 3]
    for r in range(3):  # the wrist centre: goal applied to its place in the tool frame
        target[r] = goal[r, 3]
        for c in range(3):
            target[r] += goal[r, c] * (m[0, c] * dw[0] + m[1, c] * dw[1] + m[2, c] * dw[2])
    arm = np.empty((4, 9))  # angles of joints 1-3 (columns 0-2), their cosines and sines
    n3, singular = pos3_cs(h, o, w, target, ref, arm, arm[:, 3:9])
    for r in range(3):  # rg = goal R m R^T
        for c in range(3):
            rg[r, c] = goal[r, 0] * m[c, 0] + goal[r, 1] * m[c, 1] + goal[r, 2] * m[c, 2]
    h1, h2, h3, h4, h5, h6 = h[0], h[1], h[2], h[3], h[4], h[5]  # (views cost refcounts)
    _perp_into(h6, u6)
    cc, ss, cst = trig_coeffs(h4, h5, h6)
    n = 0
    for i in range(n3):
        rot_cs_into(h1, arm[i, 3], arm[i, 4], ra)
        rot_cs_into(h2, arm[i, 5], arm[i, 6], rb)
        mm_into(ra, rb, rc)
        rot_cs_into(h3, arm[i, 7], arm[i, 8], ra)
        mm_into(rc, ra, rb)  # R1 R2 R3
        mtm_into(rb, rg, r456)  # R4 R5 R6
        mv_into(r456, h6, v456)
        mv_into(r456, u6, w6)
        k5 = lin_trig_cs(cc, ss, dot(h4, v456) - cst, 1.0, t5s, cs5)
        if k5 == -1:
            k5, t5s[0], singular = 1, ref[4], True
            cs5[0, 0], cs5[0, 1] = math.cos(ref[4]), math.sin(ref[4])
        for j in range(k5):
            # rotations of vectors from the cosines and sines that their equations give (no
            # trigonometry, no matrices)
            c5, s5 = cs5[j, 0], cs5[j, 1]
            rotv_cs_into(h5, c5, s5, h6, v5)  # R5 h6
            t4, c4, s4, deg = sp1_cs(h4, v5, v456, _DEG)
            if deg:
                t4, c4, s4 = ref[3], math.cos(ref[3]), math.sin(ref[3])
                singular = True
            rotv_cs_into(h4, c4, -s4, w6, x6)  # R4^T R4 R5 R6 u6
            rotv_cs_into(h5, c5, -s5, x6, v6)  # R6 u6
            t6, _ = sp1(h6, u6, v6, _DEG)
            out[n, 0], out[n, 1], out[n, 2] = arm[i, 0], arm[i, 1], arm[i, 2]
            out[n, 3], out[n, 4], out[n, 5] = t4, t5s[j], t6
            n += 1
    return n, singular


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _parallel_pair(h: np.ndarray, o: np.ndarray, p: np.ndarray, p5: np.ndarray,
                   e: np.ndarray, e5: np.ndarray, ref1: float, ref5: float,
                   t1: np.ndarray, t5: np.ndarray) -> tuple[int, bool]:
    """``q1`` and ``q5`` of a chain whose axes 2, 3, 4 are parallel.

    The rotations about the parallel axes keep the ``h2`` component, so
    ``h2 . R1^T p = h2 . (o5 - o1) + h2 . R5 p5`` and ``h2 . R1^T e = h2 . R5 e5``: two equations
    linear in the sines and cosines of ``q1`` and ``q5`` (:func:`circle2`).

    Args:
        h: ``(>=5, 3)`` axes (``h[1]`` the common direction of axes 2-4).
        o: ``(>=5, 3)`` points on the axes [m].
        p: Position part: the point to reach relative to ``o1`` with the known tail removed.
        p5: Vector carried by joint 5 from ``o5``.
        e: A direction the tool must have (in the base frame).
        e5: The same direction at the zero configuration, carried by joint 5.
        ref1: Representative ``q1`` for a continuum [rad].
        ref5: Representative ``q5`` for a continuum [rad].
        t1: Receives up to four ``q1`` [rad].
        t5: Receives the matching ``q5`` [rad].
    """
    h1, h2, h5 = h[0], h[1], h[4]
    d15 = math.sqrt((o[4, 0] - o[0, 0]) ** 2 + (o[4, 1] - o[0, 1]) ** 2
                    + (o[4, 2] - o[0, 2]) ** 2)
    lscale = norm(p) + norm(p5) + d15 + 1e-300
    cca, ssa, csa = trig_coeffs(h2, h1, p)
    ccb, ssb, csb = trig_coeffs(h2, h5, p5)
    ccc, ssc, csc = trig_coeffs(h2, h1, e)
    ccd, ssd, csd = trig_coeffs(h2, h5, e5)
    coef = np.empty((5, 2))  # a (rows 0-1), b (rows 2-3), d (row 4)
    a, b, d = coef[0:2], coef[2:4], coef[4]
    k = 1.0 / lscale
    a[0, 0], a[0, 1] = cca * k, -ssa * k
    b[0, 0], b[0, 1] = -ccb * k, -ssb * k
    d[0] = (h2[0] * (o[4, 0] - o[0, 0]) + h2[1] * (o[4, 1] - o[0, 1])
            + h2[2] * (o[4, 2] - o[0, 2]) - csa + csb) * k
    a[1, 0], a[1, 1] = ccc, -ssc
    b[1, 0], b[1, 1] = -ccd, -ssd
    d[1] = csd - csc
    return circle2(a, b, d, ref1, ref5, t1, t5)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _planar(h: np.ndarray, o: np.ndarray, q: np.ndarray, t234: float, ref: np.ndarray,
            out: np.ndarray, row: int) -> tuple[int, bool]:
    """``q2, q3, q4`` of three parallel axes given ``R2 (p23 + R3 p34) = q`` and their sum."""
    return _planar_into(h, o, q, t234, ref, out, row, np.empty((4, 3)))


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _planar_into(h: np.ndarray, o: np.ndarray, q: np.ndarray, t234: float, ref: np.ndarray,
                 out: np.ndarray, row: int, vec: np.ndarray) -> tuple[int, bool]:
    """:func:`_planar` with its scratch ``vec`` ``(4, 3)`` given (no allocation)."""
    h2, h3 = h[1], h[2]
    p23, p34, pv, t3s = vec[0], vec[1], vec[2], vec[3]
    for r in range(3):
        p23[r] = o[2, r] - o[1, r]
        p34[r] = o[3, r] - o[2, r]
    ls = norm(p23) + norm(p34) + norm(q) + 1e-300
    cc, ss, cst = trig_coeffs(p23, h3, p34)
    k3 = lin_trig(2.0 * cc, 2.0 * ss,
                  dot(q, q) - dot(p23, p23) - dot(p34, p34) - 2.0 * cst, ls * ls, t3s)
    singular = False
    if k3 == -1:
        k3, t3s[0], singular = 1, ref[2], True
    hp = dot(h3, p34)
    for j in range(k3):
        c3, s3 = math.cos(t3s[j]), math.sin(t3s[j])
        for r in range(3):  # p23 + rot(h3, t3) p34 (Rodrigues, no temporaries)
            r1, r2 = (r + 1) % 3, (r + 2) % 3
            pv[r] = (p23[r] + p34[r] * c3 + (h3[r1] * p34[r2] - h3[r2] * p34[r1]) * s3
                     + h3[r] * hp * (1.0 - c3))
        t2, deg = sp1(h2, pv, q, _DEG * ls)
        if deg:
            t2 = ref[1]
            singular = True
        out[row + j, 1] = t2
        out[row + j, 2] = t3s[j]
        out[row + j, 3] = wrap(t234 - t2 - t3s[j])
    return k3, singular


@nb.njit(cache=True, nogil=True, error_model="numpy")
def three_parallel(h: np.ndarray, o: np.ndarray, m: np.ndarray, goal: np.ndarray,
                   ref: np.ndarray, out: np.ndarray) -> tuple[int, bool]:
    """6R chain whose axes 2, 3, 4 are parallel (UR type): up to 8 solutions.

    ``q1, q5`` from :func:`_parallel_pair`; ``q6`` and the sum ``q2 + q3 + q4`` by
    subproblem 1; ``q3`` from the planar distance, ``q2`` by subproblem 1.
    """
    h1, h2, h5, h6 = h[0], h[1], h[4], h[5]
    # scratch (a few allocations, none per candidate)
    mats = np.empty((6, 3, 3))
    rg, r1, r5, r6, ra, rb = mats[0], mats[1], mats[2], mats[3], mats[4], mats[5]
    vec = np.empty((12, 4))
    t1s, t5s = vec[0], vec[1]
    p, e, u2, p21, p45, p56 = vec[2, :3], vec[3, :3], vec[4, :3], vec[5, :3], vec[6, :3], vec[7, :3]
    va, vb, vc, q = vec[8, :3], vec[9, :3], vec[10, :3], vec[11, :3]
    planar = np.empty((4, 3))  # _planar_into's scratch
    for r in range(3):  # rg = goal R m R^T
        for c in range(3):
            rg[r, c] = goal[r, 0] * m[c, 0] + goal[r, 1] * m[c, 1] + goal[r, 2] * m[c, 2]
    for r in range(3):
        va[r] = m[r, 3] - o[5, r]
        p21[r] = o[1, r] - o[0, r]
        p45[r] = o[4, r] - o[3, r]
        p56[r] = o[5, r] - o[4, r]
    for r in range(3):
        p[r] = goal[r, 3] - o[0, r] - (rg[r, 0] * va[0] + rg[r, 1] * va[1] + rg[r, 2] * va[2])
        e[r] = rg[r, 0] * h6[0] + rg[r, 1] * h6[1] + rg[r, 2] * h6[2]
    n2, singular = _parallel_pair(h, o, p, p56, e, h6, ref[0], ref[4], t1s, t5s)
    _perp_into(h2, u2)
    n = 0
    for i in range(n2):
        rot_into(h1, t1s[i], r1)
        rot_into(h5, t5s[i], r5)
        mv_into(r1, h2, va)
        for r in range(3):
            vb[r] = rg[0, r] * va[0] + rg[1, r] * va[1] + rg[2, r] * va[2]  # rg^T (r1 h2)
            vc[r] = r5[0, r] * h2[0] + r5[1, r] * h2[1] + r5[2, r] * h2[2]  # r5^T h2
        t6, c6, s6, deg = sp1_cs(h6, vb, vc, _DEG)
        if deg:
            t6, c6, s6 = ref[5], math.cos(ref[5]), math.sin(ref[5])
            singular = True
        rot_cs_into(h6, c6, s6, r6)
        mtm_into(r1, rg, ra)
        for r in range(3):  # r234 = r1^T rg r6^T r5^T
            for c in range(3):
                rb[r, c] = ra[r, 0] * r6[c, 0] + ra[r, 1] * r6[c, 1] + ra[r, 2] * r6[c, 2]
        for r in range(3):
            for c in range(3):
                ra[r, c] = rb[r, 0] * r5[c, 0] + rb[r, 1] * r5[c, 1] + rb[r, 2] * r5[c, 2]
        mv_into(ra, u2, va)
        t234, _ = sp1(h2, u2, va, _DEG)
        mv_into(r5, p56, vb)
        for r in range(3):
            vb[r] += p45[r]
        mv_into(ra, vb, vc)
        for r in range(3):
            q[r] = (r1[0, r] * p[0] + r1[1, r] * p[1] + r1[2, r] * p[2]) - p21[r] - vc[r]
        k, s = _planar_into(h, o, q, t234, ref, out, n, planar)
        singular = singular or s
        for j in range(n, n + k):
            out[j, 0] = t1s[i]
            out[j, 4] = t5s[i]
            out[j, 5] = t6
        n += k
    return n, singular


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _add_pairs(ca: float, sa: float, cb: float, sb: float, e: float, t: float, fixed_first: bool,
               t1: np.ndarray, t5: np.ndarray, n: int) -> int:
    """Append the solutions of ``ca cos t1 + sa sin t1 + cb cos t5 + sb sin t5 = e``.

    One angle is fixed at ``t`` [rad] (``t1`` when ``fixed_first``, else ``t5``), the other
    solved; the pairs go to ``t1``, ``t5`` from row ``n`` on. Returns the new count.
    """
    sol = np.empty(2)
    if fixed_first:
        k = lin_trig(cb, sb, e - ca * math.cos(t) - sa * math.sin(t), 1.0, sol)
    else:
        k = lin_trig(ca, sa, e - cb * math.cos(t) - sb * math.sin(t), 1.0, sol)
    for j in range(max(k, 0)):
        t1[n] = t if fixed_first else sol[j]
        t5[n] = sol[j] if fixed_first else t
        n += 1
    return n


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _direction_pairs(h: np.ndarray, o: np.ndarray, p: np.ndarray, p5: np.ndarray,
                     e: np.ndarray, e5: np.ndarray, ref1: float, ref5: float,
                     t1: np.ndarray, t5: np.ndarray) -> tuple[int, bool]:
    """``q1`` and ``q5`` candidates of the 5R direction family, including its special goals.

    The two equations of :func:`_parallel_pair` are solved jointly; then, when one of the
    direction equation's coefficient rows (nearly) vanishes, it is also solved decoupled, which
    stays exact where the joint solution is ill-conditioned:

    * tool axis along axis 5 (the roll only spins the tool axis): the direction alone gives
      ``q1`` (the azimuth of its part across ``h1``) and the position equation ``q5``;
    * direction along axis 1: the direction gives ``q5`` and the position ``q1``;
    * both (the SO-101 pointing straight down or up): ``q1`` turns the tool axis about
      itself, so ``q1`` and ``q5`` together only have to meet the position equation: a
      continuum. Its representatives are ``q1 = ref1``, ``q5 = ref5`` and the two ``q5`` that
      turn the tool point's offset from axis 5 into the arm's plane, each with the other angle
      from the position equation, and the result is flagged singular.

    A direction within :data:`_NEAR` of axis 1 gets the continuum's candidates as well: on a
    nearly idealised chain the exact solutions of such a goal lie near the continuum. Extra
    candidates cost a polish each; the exact forward kinematics keeps the true ones only.

    Args:
        h: ``(>=5, 3)`` axes (``h[1]`` the common direction of axes 2-4).
        o: ``(>=5, 3)`` points on the axes [m].
        p: The tool point's goal relative to ``o1`` [m].
        p5: The tool point relative to ``o5`` at the zero configuration [m].
        e: The goal direction (unit, base frame).
        e5: The tool axis at the zero configuration (unit, base frame).
        ref1: Representative ``q1`` for a continuum [rad].
        ref5: Representative ``q5`` for a continuum [rad].
        t1: ``(>=20,)`` receives the ``q1`` candidates [rad].
        t5: ``(>=20,)`` receives the matching ``q5`` [rad].

    Returns:
        ``(count, singular)``.
    """
    h1, h2, h5 = h[0], h[1], h[4]
    n, singular = _parallel_pair(h, o, p, p5, e, e5, ref1, ref5, t1, t5)
    lscale = norm(p) + norm(p5) + norm(o[4] - o[0]) + 1e-300
    k = 1.0 / lscale
    cca, ssa, csa = trig_coeffs(h2, h1, p)
    ccb, ssb, csb = trig_coeffs(h2, h5, p5)
    ccc, ssc, csc = trig_coeffs(h2, h1, e)
    ccd, ssd, csd = trig_coeffs(h2, h5, e5)
    # position row: ka . [c1, s1] + kb . [c5, s5] = kd (dimensionless)
    ka0, ka1, kb0, kb1 = cca * k, -ssa * k, -ccb * k, -ssb * k
    kd = (dot(h2, o[4] - o[0]) - csa + csb) * k
    roll_only = norm(cross(h5, e5)) <= _AXIS  # axis 5 only spins the tool axis
    along = norm(cross(h1, e))  # how far the direction is from axis 1 [rad]
    if roll_only and along > 1e-11:
        # h2 . R1^T e = h2 . R5 e5, the right side (nearly) constant: q1 from the direction
        sol = np.empty(2)
        rhs = csd + ccd * math.cos(ref5) + ssd * math.sin(ref5) - csc
        r = math.hypot(ccc, ssc)
        if abs(rhs) > r:  # noise of a nearly idealised chain beyond a tiny across part
            rhs = math.copysign(r, rhs)
        k1 = lin_trig(ccc, -ssc, rhs, 1.0, sol)
        for i in range(max(k1, 0)):
            n = _add_pairs(ka0, ka1, kb0, kb1, kd, sol[i], True, t1, t5, n)
    if not roll_only and along <= _NEAR:
        # h2 . R1^T e (nearly) constant: q5 from the direction, q1 from the position
        sol = np.empty(2)
        k5 = lin_trig(-ccd, -ssd, csd - csc - ccc * math.cos(ref1) + ssc * math.sin(ref1),
                      1.0, sol)
        for i in range(max(k5, 0)):
            n = _add_pairs(ka0, ka1, kb0, kb1, kd, sol[i], False, t1, t5, n)
    if roll_only and along <= _NEAR:
        n = _add_pairs(ka0, ka1, kb0, kb1, kd, ref1, True, t1, t5, n)
        n = _add_pairs(ka0, ka1, kb0, kb1, kd, ref5, False, t1, t5, n)
        # and the rolls that turn the tool point's offset into the arm's plane (the farthest
        # and nearest reach: near the workspace boundary the continuum is a short arc there)
        sol = np.empty(2)
        for i in range(max(lin_trig(ccb, ssb, -csb, lscale, sol), 0)):
            n = _add_pairs(ka0, ka1, kb0, kb1, kd, sol[i], False, t1, t5, n)
        if along <= _AXIS:
            singular = True
    return n, singular


@nb.njit(cache=True, nogil=True, error_model="numpy")
def three_parallel_direction(h: np.ndarray, o: np.ndarray, m: np.ndarray, p_goal: np.ndarray,
                             d_goal: np.ndarray, axis: np.ndarray, ref: np.ndarray,
                             out: np.ndarray) -> tuple[int, bool]:
    """5R chain with axes 2, 3, 4 parallel, goal position plus tool direction.

    Same reduction as :func:`three_parallel` with the tool direction in place of the sixth axis
    (up to 8 solutions); the special goals are in :func:`_direction_pairs`.
    """
    h1, h2, h5 = h[0], h[1], h[4]
    a0 = mv(m, axis)
    t0 = m[:3, 3]
    p = p_goal - o[0]
    t1s = np.empty(20)
    t5s = np.empty(20)
    n2, singular = _direction_pairs(h, o, p, t0 - o[4], d_goal, a0, ref[0], ref[4], t1s, t5s)
    n = 0
    for i in range(n2):
        r5 = rot(h5, t5s[i])
        rd = rotv(h1, -t1s[i], d_goal)
        t234, deg = sp1(h2, mv(r5, a0), rd, _DEG)
        if deg:
            t234 = ref[1] + ref[2] + ref[3]
            singular = True
        r234 = rot(h2, t234)
        q = rotv(h1, -t1s[i], p) - (o[1] - o[0]) - mv(r234, (o[4] - o[3]) + mv(r5, t0 - o[4]))
        k, s = _planar(h, o, q, t234, ref, out, n)
        singular = singular or s
        for j in range(n, n + k):
            out[j, 0] = t1s[i]
            out[j, 4] = t5s[i]
        n += k
    return n, singular


@nb.njit(cache=True, nogil=True, error_model="numpy")
def yaw_three_parallel_direction(h: np.ndarray, o: np.ndarray, m: np.ndarray,
                                 p_goal: np.ndarray, d_goal: np.ndarray, axis: np.ndarray,
                                 ref: np.ndarray, out: np.ndarray) -> tuple[int, bool]:
    """4R chain, axes 2, 3, 4 parallel, goal position plus a tool direction: up to 4.

    ``q1`` puts the goal in the arm's plane (subproblem 4 on the ``h2`` component; for a goal
    point on axis 1 the direction's component does it instead, and with the direction along
    axis 1 as well ``q1`` is free: ``ref[0]``, singular); the direction
    then fixes ``q2 + q3 + q4`` (subproblem 1; a direction out of the plane is not reachable and
    its candidates fail the final check), and the planar part gives ``q2, q3, q4``.
    """
    h1, h2 = h[0], h[1]
    a0 = mv(m, axis)
    t0 = m[:3, 3]
    p = p_goal - o[0]
    cc, ss, cst = trig_coeffs(h2, h1, p)
    t1s = np.empty(2)
    ls = norm(p) + norm(t0 - o[0]) + 1e-300
    k1 = lin_trig(cc, -ss, dot(h2, t0 - o[0]) - cst, ls, t1s)
    singular = False
    if k1 == -1:  # the goal point on axis 1: the direction's part across it gives q1
        cc, ss, cst = trig_coeffs(h2, h1, d_goal)
        k1 = lin_trig(cc, -ss, dot(h2, a0) - cst, 1.0, t1s)
    if k1 == -1:  # and the direction along axis 1 too: q1 is free
        k1, t1s[0], singular = 1, ref[0], True
    n = 0
    for i in range(k1):
        t234, deg = sp1(h2, a0, rotv(h1, -t1s[i], d_goal), _DEG)
        if deg:
            t234 = ref[1] + ref[2] + ref[3]
            singular = True
        q = rotv(h1, -t1s[i], p) - (o[1] - o[0]) - rotv(h2, t234, t0 - o[3])
        k, s = _planar(h, o, q, t234, ref, out, n)
        singular = singular or s
        for j in range(n, n + k):
            out[j, 0] = t1s[i]
        n += k
    return n, singular
