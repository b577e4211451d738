"""Closed-form solvers of the decomposable chain families, compiled with numba.

A chain is given in product-of-exponentials form at its zero configuration: ``H`` ``(n, 3)`` unit
joint axes and ``O`` ``(n, 3)`` points on them, both in the base frame, and ``M`` ``(4, 4)`` the
tool pose. The pose at ``q`` is ``E1(q1) ... En(qn) M`` with ``Ei`` the rotation about axis ``i``.
Each solver writes candidate joint vectors (chain order) into ``out`` and returns
``(count, singular)``; candidates are checked and polished afterwards (:mod:`._polish`).
Continua take the matching entry of ``ref`` as their representative and set ``singular``.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from armctl.ik.analytic._subproblems import (
    circle2,
    cross,
    dot,
    lin_trig,
    mm,
    mmt,
    mtm,
    mtv,
    mv,
    norm,
    rot,
    rotv,
    sp1,
    trig_coeffs,
    wrap,
)

_DEG = 1e-9  # below this a unit vector counts as lying on an axis


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _perp(k: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to the unit vector ``k``."""
    e = np.zeros(3)
    e[np.argmin(np.abs(k))] = 1.0
    u = cross(k, e)
    return u / norm(u)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def pos3(h: np.ndarray, o: np.ndarray, w: np.ndarray, target: np.ndarray, ref: np.ndarray,
         out: np.ndarray) -> tuple[int, bool]:
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
    """
    h1, h2, h3 = h[0], h[1], h[2]
    v = target - o[0]
    p12 = o[1] - o[0]
    p23 = o[2] - o[1]
    p34 = w - o[2]
    lscale = norm(v) + norm(p12) + norm(p23) + norm(p34) + 1e-300
    cca, ssa, csa = trig_coeffs(h2, h1, v)
    ccb, ssb, csb = trig_coeffs(p12, h1, v)
    ccc, ssc, csc = trig_coeffs(h2, h3, p34)
    ccd, ssd, csd = trig_coeffs(p23, h3, p34)
    a = np.empty((2, 2))
    b = np.empty((2, 2))
    d = np.empty(2)
    k1 = 1.0 / lscale
    k2 = k1 * k1
    a[0, 0], a[0, 1] = cca * k1, -ssa * k1
    b[0, 0], b[0, 1] = -ccc * k1, -ssc * k1
    d[0] = (dot(h2, p12) + dot(h2, p23) - csa + csc) * k1
    a[1, 0], a[1, 1] = -2.0 * ccb * k2, 2.0 * ssb * k2
    b[1, 0], b[1, 1] = -2.0 * ccd * k2, -2.0 * ssd * k2
    d[1] = (dot(p23, p23) + dot(p34, p34) - dot(v, v) - dot(p12, p12) + 2.0 * csb
            + 2.0 * csd) * k2
    t1 = np.empty(4)
    t3 = np.empty(4)
    n, singular = circle2(a, b, d, ref[0], ref[2], t1, t3)
    for i in range(n):
        rv = rotv(h1, -t1[i], v) - p12
        pv = p23 + rotv(h3, t3[i], p34)
        t2, deg = sp1(h2, pv, rv, _DEG * lscale)
        if deg:
            t2 = ref[1]
            singular = True
        out[i, 0] = t1[i]
        out[i, 1] = t2
        out[i, 2] = t3[i]
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
    wt = mtv(m, w - m[:3, 3])  # wrist centre in the tool frame
    target = mv(goal, wt) + goal[:3, 3]
    arm = np.empty((4, 3))
    n3, singular = pos3(h, o, w, target, ref, arm)
    rg = mmt(goal, m)
    h4, h5, h6 = h[3], h[4], h[5]
    u6 = _perp(h6)
    cc, ss, cst = trig_coeffs(h4, h5, h6)
    t5s = np.empty(2)
    n = 0
    for i in range(n3):
        r123 = mm(mm(rot(h[0], arm[i, 0]), rot(h[1], arm[i, 1])), rot(h[2], arm[i, 2]))
        r456 = mtm(r123, rg)
        k5 = lin_trig(cc, ss, dot(h4, mv(r456, h6)) - cst, 1.0, t5s)
        if k5 == -1:
            k5, t5s[0], singular = 1, ref[4], True
        for j in range(k5):
            r5 = rot(h5, t5s[j])
            t4, deg = sp1(h4, mv(r5, h6), mv(r456, h6), _DEG)
            if deg:
                t4 = ref[3]
                singular = True
            r6 = mtm(r5, mtm(rot(h4, t4), r456))
            t6, _ = sp1(h6, u6, mv(r6, u6), _DEG)
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
    lscale = norm(p) + norm(p5) + norm(o[4] - o[0]) + 1e-300
    cca, ssa, csa = trig_coeffs(h2, h1, p)
    ccb, ssb, csb = trig_coeffs(h2, h5, p5)
    ccc, ssc, csc = trig_coeffs(h2, h1, e)
    ccd, ssd, csd = trig_coeffs(h2, h5, e5)
    a = np.empty((2, 2))
    b = np.empty((2, 2))
    d = np.empty(2)
    k = 1.0 / lscale
    a[0, 0], a[0, 1] = cca * k, -ssa * k
    b[0, 0], b[0, 1] = -ccb * k, -ssb * k
    d[0] = (dot(h2, o[4] - o[0]) - csa + csb) * k
    a[1, 0], a[1, 1] = ccc, -ssc
    b[1, 0], b[1, 1] = -ccd, -ssd
    d[1] = csd - csc
    return circle2(a, b, d, ref1, ref5, t1, t5)


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _planar(h: np.ndarray, o: np.ndarray, q: np.ndarray, t234: float, ref: np.ndarray,
            out: np.ndarray, row: int) -> tuple[int, bool]:
    """``q2, q3, q4`` of three parallel axes given ``R2 (p23 + R3 p34) = q`` and their sum."""
    h2, h3 = h[1], h[2]
    p23 = o[2] - o[1]
    p34 = o[3] - o[2]
    ls = norm(p23) + norm(p34) + norm(q) + 1e-300
    cc, ss, cst = trig_coeffs(p23, h3, p34)
    t3s = np.empty(2)
    k3 = lin_trig(2.0 * cc, 2.0 * ss,
                  dot(q, q) - dot(p23, p23) - dot(p34, p34) - 2.0 * cst, ls * ls, t3s)
    singular = False
    if k3 == -1:
        k3, t3s[0], singular = 1, ref[2], True
    for j in range(k3):
        t2, deg = sp1(h2, p23 + rotv(h3, t3s[j], p34), q, _DEG * ls)
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
    rg = mmt(goal, m)
    h1, h2, h5, h6 = h[0], h[1], h[4], h[5]
    p = goal[:3, 3] - o[0] - mv(rg, m[:3, 3] - o[5])
    e = mv(rg, h6)
    t1s = np.empty(4)
    t5s = np.empty(4)
    n2, singular = _parallel_pair(h, o, p, o[5] - o[4], e, h6, ref[0], ref[4], t1s, t5s)
    u2 = _perp(h2)
    n = 0
    for i in range(n2):
        r1 = rot(h1, t1s[i])
        r5 = rot(h5, t5s[i])
        t6, deg = sp1(h6, mtv(rg, mv(r1, h2)), mtv(r5, h2), _DEG)
        if deg:
            t6 = ref[5]
            singular = True
        r6 = rot(h6, t6)
        r234 = mmt(mmt(mtm(r1, rg), r6), r5)
        t234, _ = sp1(h2, u2, mv(r234, u2), _DEG)
        q = mtv(r1, p) - (o[1] - o[0]) - mv(r234, (o[4] - o[3]) + mv(r5, o[5] - o[4]))
        k, s = _planar(h, o, q, t234, ref, out, n)
        singular = singular or s
        for j in range(n, n + k):
            out[j, 0] = t1s[i]
            out[j, 4] = t5s[i]
            out[j, 5] = t6
        n += k
    return n, singular


@nb.njit(cache=True, nogil=True, error_model="numpy")
def three_parallel_direction(h: np.ndarray, o: np.ndarray, m: np.ndarray, p_goal: np.ndarray,
                             d_goal: np.ndarray, axis: np.ndarray, ref: np.ndarray,
                             out: np.ndarray) -> tuple[int, bool]:
    """5R chain with axes 2, 3, 4 parallel, goal position plus tool direction: up to 8.

    Same reduction as :func:`three_parallel` with the tool direction in place of the sixth axis.
    """
    h1, h2, h5 = h[0], h[1], h[4]
    a0 = mv(m, axis)
    t0 = m[:3, 3]
    p = p_goal - o[0]
    t1s = np.empty(4)
    t5s = np.empty(4)
    n2, singular = _parallel_pair(h, o, p, t0 - o[4], d_goal, a0, ref[0], ref[4], t1s, t5s)
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

    ``q1`` puts the goal in the arm's plane (subproblem 4 on the ``h2`` component); the direction
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
    if k1 == -1:
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
