"""Compiled (numba) kernels of the collision checks: capsules against capsules and obstacles.

numba compiles them when the first one is read from this module (see
:mod:`armctl.kinematics._lazy_kernels`); :func:`interpreted` runs them without numba. The
joint frames are computed as the kinematics kernels' ``_step`` computes them (a copy, kept for
speed on arms of 1-DOF joints); an arm with universal or ball joints is stepped by the
kinematics kernels' own ``_step_any`` (:func:`_place_multi`). Each check tells the two apart
once per call (``q`` has more entries than the arm has joints) and hands its body a flag, so
that the code that places the capsules of a 1-DOF arm is the same as before multi-DOF joints.

Everything a check needs is packed by :class:`armctl.collision.model.CollisionModel` into two
arrays, so that a call passes three arguments (the joint vector, ``F`` and ``I``):

* ``I`` (int64, 1-D): a header of :data:`HEADER` entries (counts and the row or index where
  each block starts, named by the ``H_*`` constants), then the integer blocks: per joint its
  parent joint (-1: the base); per capsule the joint that carries it (-1: fixed to the base);
  the self pairs (two capsule indices each); per obstacle its kind (``K_*``); the scene pairs
  (capsule, obstacle); the visiting block made by :func:`pair_records` (the capsules in the
  order the checks visit them, each capsule's pair with the table, a capsule-by-obstacle
  table of pair indices, the self pairs in visiting order).
* ``F`` (float64, 2-D, ``max(WIDTH, nv)`` columns): the joints' rows of
  :attr:`~armctl.kinematics.compiled_tree.CompiledTree.joints` (all 22 columns); per capsule its
  end points in the frame of its joint and its radius (7 columns); per capsule its lever row
  (one column per tangent entry: how far a point of it moves per unit of travel of that entry,
  an upper bound over every configuration: [m/rad] for rotations, 1 for prismatic joints, 0
  for joints that do not carry it; a universal joint has two entries, a ball joint three);
  per obstacle its data (below), in columns 16-19 a bounding sphere (centre, radius; an
  infinite radius for the table) and in columns 20-25 its axis-aligned bounding
  box in the base frame (lower corner, upper corner; :func:`obstacle_aabb`); one row with the
  paddings (scene, self) [m]; then the pairs' allowances, row after row (how much closer than
  its padding a pair may come [m]: 0, except for pairs that a motion starts in contact with,
  see :meth:`~armctl.collision.model.CollisionModel.escaping`).

Obstacle data by kind: table ``[h]`` (the half-space z <= h of the base frame); sphere
``[c(3), r]``; capsule ``[a(3), b(3), r]``; box ``[R(9, row-major, columns the box axes),
t(3), half extents(3)]``.

A pair's *slack* is its distance minus the padding it must keep [m]: negative is a contact.
Distances are exact for the primitives (up to rounding): segment-segment and segment-point in
closed form, segment-box by minimising the convex, piecewise quadratic squared gap over its
pieces; a segment that enters a box gets minus its penetration depth (the least translation
that separates them, over the separating-axis candidates of a segment and a box). Pairs are
culled first by a lower bound of their distance (the separation of axis-aligned bounding
boxes, then of the box's own slabs), so a check computes few exact distances; the obstacles'
boxes are tested against one capsule's box all at once (a loop the compiler vectorises).

The hot loops touch arrays only element by element and call helpers that take scalars and
tuples: in compiled code an array view, or a call of a branching helper with array
arguments, costs atomic reference-count updates that outweigh the arithmetic of a pair.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from armctl.kinematics._lazy_kernels import KernelSet

_ks = KernelSet(__name__)
#: The kinematics kernels' joint step (any kind of joint), for arms with universal or ball joints.
_ks.borrow("_step_any", "armctl.kinematics._kernels", "_step_any")
_step_any: Any = None  # the borrowed kernel, in place once the kernels are compiled

#: Header entries of ``I``.
H_N, H_K, H_P, H_O, H_S = 0, 1, 2, 3, 4  # joints, capsules, self pairs, obstacles, scene pairs
H_CAP, H_LEV, H_OBS, H_MISC = 5, 6, 7, 8  # first rows in F: capsules, levers, obstacles, paddings
H_PAR, H_CB, H_SP, H_OK, H_OP = 9, 10, 11, 12, 13  # first indices in I of the integer blocks
H_ALW = 14  # first row in F of the pairs' allowances
H_ORD = 15  # first index in I of the visiting block (see pair_records)
HEADER = 16
#: Obstacle kinds.
K_TABLE, K_SPHERE, K_CAPSULE, K_BOX = 0, 1, 2, 3
#: Obstacle columns of the bounding sphere.
BOUND = 16
#: Obstacle columns of the axis-aligned bounding box (lower corner, upper corner).
AABB = 20
#: Columns of F.
WIDTH = 26
#: Rows of the placed capsules (one column each): ends a, b, radius, bounding box (lower corner,
#: upper corner), b - a.
CW = 16
#: How much the capsules' bounding boxes are widened against rounding [m].
SLOP = 1e-9

_INF = 1e300


# ---- packing (plain Python, used by the model) ----------------------------------------------
def obstacle_aabb(kind: int, data: Sequence[float]) -> tuple[float, ...]:
    """An obstacle's axis-aligned bounding box ``(lower corner, upper corner)`` [m].

    Args:
        kind: ``K_*``.
        data: The obstacle's data (see the module notes).

    Returns:
        Six numbers; the table gets an unbounded box.
    """
    if kind == K_TABLE:
        return (-math.inf, -math.inf, -math.inf, math.inf, math.inf, data[0])
    if kind == K_SPHERE:
        c, r = np.asarray(data[:3], dtype=float), float(data[3])
        lo, hi = c - r, c + r
    elif kind == K_CAPSULE:
        a, b = np.asarray(data[:3], dtype=float), np.asarray(data[3:6], dtype=float)
        r = float(data[6])
        lo, hi = np.minimum(a, b) - r, np.maximum(a, b) + r
    elif kind == K_BOX:
        rot = np.asarray(data[:9], dtype=float).reshape(3, 3)
        t = np.asarray(data[9:12], dtype=float)
        ext = np.abs(rot) @ np.asarray(data[12:15], dtype=float)
        lo, hi = t - ext, t + ext
    else:
        raise ValueError(f"unknown obstacle kind {kind}")
    # widen by a few ulps so that rounding never makes the box smaller than the shape
    slop = 1e-12 * (1.0 + np.abs(lo) + np.abs(hi))
    return (*(lo - slop).tolist(), *(hi + slop).tolist())


def pair_records(parent: npt.ArrayLike, cap_body: npt.ArrayLike,
                 self_pairs: Sequence[tuple[int, int]], scene_pairs: Sequence[tuple[int, int]],
                 kinds: Sequence[int]) -> npt.NDArray[np.int64]:
    """The block of ``I`` that tells the checks which pairs to visit, in which order.

    Pairs that random configurations put in contact most often come first, so that a check
    of a configuration in contact stops early: the table against the capsules farthest down
    the chain, then the other obstacles (farthest capsules first), then the self pairs (those
    farthest apart along the chain first). With ``k`` capsules, ``m`` obstacles and ``P``
    self pairs the block holds: the capsules in visiting order (``k``); per capsule the index
    of its pair with the table, else -1 (``k``); per capsule and obstacle the index of their
    pair, else -1 (also for the table; ``k * m``, capsule-major); the self pairs in visiting
    order as (pair index, capsule, capsule) (``3 P``).

    Args:
        parent: Per joint its parent joint (-1: the base).
        cap_body: Per capsule the joint that carries it (-1: the base).
        self_pairs: The self pairs (capsule, capsule), in pair-index order.
        scene_pairs: The scene pairs (capsule, obstacle), following the self pairs.
        kinds: Per obstacle its kind.

    Returns:
        The block (int64).
    """
    par = [int(p) for p in np.asarray(parent, dtype=np.int64)]
    body = [int(b) for b in np.asarray(cap_body, dtype=np.int64)]
    k, m = len(body), len(kinds)

    def depth(c: int) -> int:
        d, j = 0, body[c]
        while j >= 0:
            d, j = d + 1, par[j]
        return d

    order = sorted(range(k), key=lambda c: (-depth(c), c))
    table = [-1] * k
    scene = [-1] * (k * m)
    base = len(self_pairs)
    for s, (c, o) in enumerate(scene_pairs):
        if int(kinds[o]) == K_TABLE:
            table[c] = base + s
        else:
            scene[c * m + o] = base + s
    selfs = sorted(range(len(self_pairs)), key=lambda i: (
        -abs(depth(self_pairs[i][0]) - depth(self_pairs[i][1])), i))
    recs = [v for i in selfs for v in (i, self_pairs[i][0], self_pairs[i][1])]
    return np.asarray(order + table + scene + recs, dtype=np.int64)


# ---- placing the capsules ---------------------------------------------------------------------
@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _frame_step(t: tuple[float, ...], r: tuple[float, ...], qj: float) -> tuple[float, ...]:
    """``t @ pre @ M(qj)`` for 3x4 frames as row-major 12-tuples; ``r`` is a joint row (16).

    The same operations in the same order as the kinematics kernels' ``_step``.
    """
    t00, t01, t02, t03, t10, t11, t12, t13, t20, t21, t22, t23 = t
    a00 = t00 * r[0] + t01 * r[4] + t02 * r[8]
    a01 = t00 * r[1] + t01 * r[5] + t02 * r[9]
    a02 = t00 * r[2] + t01 * r[6] + t02 * r[10]
    a10 = t10 * r[0] + t11 * r[4] + t12 * r[8]
    a11 = t10 * r[1] + t11 * r[5] + t12 * r[9]
    a12 = t10 * r[2] + t11 * r[6] + t12 * r[10]
    a20 = t20 * r[0] + t21 * r[4] + t22 * r[8]
    a21 = t20 * r[1] + t21 * r[5] + t22 * r[9]
    a22 = t20 * r[2] + t21 * r[6] + t22 * r[10]
    p0 = t03 + t00 * r[3] + t01 * r[7] + t02 * r[11]
    p1 = t13 + t10 * r[3] + t11 * r[7] + t12 * r[11]
    p2 = t23 + t20 * r[3] + t21 * r[7] + t22 * r[11]
    x, y, z = r[12], r[13], r[14]
    if r[15] > 0.5:  # prismatic: translate along the axis
        return (a00, a01, a02, p0 + (a00 * x + a01 * y + a02 * z) * qj,
                a10, a11, a12, p1 + (a10 * x + a11 * y + a12 * z) * qj,
                a20, a21, a22, p2 + (a20 * x + a21 * y + a22 * z) * qj)
    c = math.cos(qj)
    s = math.sin(qj)
    v = 1.0 - c
    r00 = c + x * x * v
    r01 = x * y * v - z * s
    r02 = x * z * v + y * s
    r10 = y * x * v + z * s
    r11 = c + y * y * v
    r12 = y * z * v - x * s
    r20 = z * x * v - y * s
    r21 = z * y * v + x * s
    r22 = c + z * z * v
    return (a00 * r00 + a01 * r10 + a02 * r20, a00 * r01 + a01 * r11 + a02 * r21,
            a00 * r02 + a01 * r12 + a02 * r22, p0,
            a10 * r00 + a11 * r10 + a12 * r20, a10 * r01 + a11 * r11 + a12 * r21,
            a10 * r02 + a11 * r12 + a12 * r22, p1,
            a20 * r00 + a21 * r10 + a22 * r20, a20 * r01 + a21 * r11 + a22 * r21,
            a20 * r02 + a21 * r12 + a22 * r22, p2)


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _place_capsules(F: np.ndarray, I: np.ndarray, T: np.ndarray,  # noqa: E741
                    C: np.ndarray) -> None:
    """World capsules ``C`` (:data:`CW`, k) on the joint frames ``T`` (see :func:`_place`)."""
    k = I[H_K]
    cb, cap = I[H_CB], I[H_CAP]
    for c in range(k):
        row = cap + c
        b = I[cb + c]
        if b < 0:
            a0, a1, a2 = F[row, 0], F[row, 1], F[row, 2]
            b0, b1, b2 = F[row, 3], F[row, 4], F[row, 5]
        else:
            x, y, z = F[row, 0], F[row, 1], F[row, 2]
            a0 = T[b, 0] * x + T[b, 1] * y + T[b, 2] * z + T[b, 3]
            a1 = T[b, 4] * x + T[b, 5] * y + T[b, 6] * z + T[b, 7]
            a2 = T[b, 8] * x + T[b, 9] * y + T[b, 10] * z + T[b, 11]
            x, y, z = F[row, 3], F[row, 4], F[row, 5]
            b0 = T[b, 0] * x + T[b, 1] * y + T[b, 2] * z + T[b, 3]
            b1 = T[b, 4] * x + T[b, 5] * y + T[b, 6] * z + T[b, 7]
            b2 = T[b, 8] * x + T[b, 9] * y + T[b, 10] * z + T[b, 11]
        rad = F[row, 6]
        C[0, c], C[1, c], C[2, c], C[3, c], C[4, c], C[5, c] = a0, a1, a2, b0, b1, b2
        C[6, c] = rad
        wide = rad + SLOP
        C[7, c] = min(a0, b0) - wide
        C[8, c] = min(a1, b1) - wide
        C[9, c] = min(a2, b2) - wide
        C[10, c] = max(a0, b0) + wide
        C[11, c] = max(a1, b1) + wide
        C[12, c] = max(a2, b2) + wide
        C[13, c], C[14, c], C[15, c] = b0 - a0, b1 - a1, b2 - a2


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _place_multi(q: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
                 T: np.ndarray) -> None:
    """Joint frames ``T`` (n, 12) of an arm with universal or ball joints at ``q`` (``nq``).

    Each joint is stepped by the kinematics kernels' ``_step_any`` (its row of ``F`` holds the
    whole row of the compiled tree), so the frames are those of the forward kinematics.
    """
    par = I[H_PAR]
    t = np.empty((3, 4))
    for j in range(I[H_N]):
        p = I[par + j]
        for r in range(3):
            for c in range(4):
                t[r, c] = (1.0 if r == c else 0.0) if p < 0 else T[p, 4 * r + c]
        _step_any(t, F[j], q)
        for r in range(3):
            for c in range(4):
                T[j, 4 * r + c] = t[r, c]


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _place(q: np.ndarray, F: np.ndarray, I: np.ndarray, T: np.ndarray,  # noqa: E741
           C: np.ndarray) -> None:
    """Joint frames ``T`` (n, 12: 3x4 row-major) and world capsules ``C`` (:data:`CW`, k) at ``q``.

    ``C`` per capsule (column): ends a, b, radius, bounding box (lower corner, upper corner), b - a.
    For arms of 1-DOF joints (:func:`_place_any` places the others).
    """
    n = I[H_N]
    par = I[H_PAR]
    for j in range(n):
        p = I[par + j]
        if p < 0:
            t = (1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0)
        else:
            t = (T[p, 0], T[p, 1], T[p, 2], T[p, 3], T[p, 4], T[p, 5], T[p, 6], T[p, 7],
                 T[p, 8], T[p, 9], T[p, 10], T[p, 11])
        r = (F[j, 0], F[j, 1], F[j, 2], F[j, 3], F[j, 4], F[j, 5], F[j, 6], F[j, 7], F[j, 8],
             F[j, 9], F[j, 10], F[j, 11], F[j, 12], F[j, 13], F[j, 14], F[j, 15])
        u = _frame_step(t, r, q[j])
        T[j, 0], T[j, 1], T[j, 2], T[j, 3] = u[0], u[1], u[2], u[3]
        T[j, 4], T[j, 5], T[j, 6], T[j, 7] = u[4], u[5], u[6], u[7]
        T[j, 8], T[j, 9], T[j, 10], T[j, 11] = u[8], u[9], u[10], u[11]
    _place_capsules(F, I, T, C)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _place_any(q: np.ndarray, F: np.ndarray, I: np.ndarray, T: np.ndarray,  # noqa: E741
               C: np.ndarray) -> None:
    """:func:`_place` for an arm with universal or ball joints (``q`` of ``nq`` entries)."""
    _place_multi(q, F, I, T)
    _place_capsules(F, I, T, C)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _scratch(I: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,  # noqa: E741
                                     np.ndarray]:
    """Room for a check, in one allocation.

    Returns:
        ``T`` joint frames (n, 12), ``C`` placed capsules (:data:`CW`, k), ``O`` obstacle
        bounding boxes (6, m), ``L`` lower bounds (max(k, m)).
    """
    n, k, m = max(I[H_N], 1), max(I[H_K], 1), max(I[H_O], 1)
    nl = max(k, m)
    buf = np.empty(n * 12 + (CW + 1) * k + 7 * m)
    at = n * 12
    T = buf[:at].reshape((n, 12))
    C = buf[at:at + CW * k].reshape((CW, k))
    at += CW * k
    O = buf[at:at + 6 * m].reshape((6, m))  # noqa: E741
    at += 6 * m
    return T, C, O, buf[at:at + nl]


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _obstacle_boxes(F: np.ndarray, I: np.ndarray, O: np.ndarray) -> None:  # noqa: E741
    """The obstacles' bounding boxes into ``O`` (6, m) (the table's empty: it is checked apart)."""
    obs0, kinds = I[H_OBS], I[H_OK]
    for o in range(I[H_O]):
        for i in range(6):
            if I[kinds + o] == K_TABLE:
                O[i, o] = _INF if i < 3 else -_INF
            else:
                O[i, o] = F[obs0 + o, AABB + i]


# ---- distances between primitives -------------------------------------------------------------
@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _clamp01(x: float) -> float:
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _seg_seg(p0: float, p1: float, p2: float, d0: float, d1: float, d2: float,
             r0: float, r1: float, r2: float, e0: float, e1: float, e2: float) -> float:
    """Distance between segments ``p + s d`` and ``r + t e``, s, t in [0, 1] [m]."""
    w0, w1, w2 = p0 - r0, p1 - r1, p2 - r2
    a = d0 * d0 + d1 * d1 + d2 * d2
    e = e0 * e0 + e1 * e1 + e2 * e2
    f = e0 * w0 + e1 * w1 + e2 * w2
    eps = 1e-18
    if a <= eps and e <= eps:
        s = 0.0
        t = 0.0
    elif a <= eps:
        s = 0.0
        t = _clamp01(f / e)
    else:
        c = d0 * w0 + d1 * w1 + d2 * w2
        if e <= eps:
            t = 0.0
            s = _clamp01(-c / a)
        else:
            b = d0 * e0 + d1 * e1 + d2 * e2
            den = a * e - b * b
            s = _clamp01((b * f - c * e) / den) if den > eps * a * e + eps else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = _clamp01(-c / a)
            elif t > 1.0:
                t = 1.0
                s = _clamp01((b - c) / a)
    x0 = w0 + s * d0 - t * e0
    x1 = w1 + s * d1 - t * e1
    x2 = w2 + s * d2 - t * e2
    return math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _seg_point(a0: float, a1: float, a2: float, d0: float, d1: float, d2: float,
               x0: float, x1: float, x2: float) -> float:
    """Distance from point ``x`` to the segment ``a + s d`` [m]."""
    w0, w1, w2 = x0 - a0, x1 - a1, x2 - a2
    dd = d0 * d0 + d1 * d1 + d2 * d2
    s = 0.0 if dd <= 1e-18 else _clamp01((w0 * d0 + w1 * d1 + w2 * d2) / dd)
    y0, y1, y2 = w0 - s * d0, w1 - s * d1, w2 - s * d2
    return math.sqrt(y0 * y0 + y1 * y1 + y2 * y2)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _excess(x: float, h: float) -> float:
    """How far ``x`` lies outside ``[-h, h]``, signed (0 inside)."""
    if x > h:
        return x - h
    if x < -h:
        return x + h
    return 0.0


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _box_gap_sq(u: tuple[float, float, float], v: tuple[float, float, float],
                h: tuple[float, float, float], t: float) -> float:
    """Squared distance from the point ``u + t v`` to the box ``[-h, h]`` [m^2]."""
    g0 = _excess(u[0] + t * v[0], h[0])
    g1 = _excess(u[1] + t * v[1], h[1])
    g2 = _excess(u[2] + t * v[2], h[2])
    return g0 * g0 + g1 * g1 + g2 * g2


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _box_slope(u: tuple[float, float, float], v: tuple[float, float, float],
               h: tuple[float, float, float], t: float) -> float:
    """Half the derivative of :func:`_box_gap_sq` in ``t`` (continuous, non-decreasing)."""
    return (_excess(u[0] + t * v[0], h[0]) * v[0] + _excess(u[1] + t * v[1], h[1]) * v[1]
            + _excess(u[2] + t * v[2], h[2]) * v[2])


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _box_min_gap_sq(u: tuple[float, float, float], v: tuple[float, float, float],
                    h: tuple[float, float, float]) -> float:
    """The least squared distance from the segment ``u + t v``, t in [0, 1], to the box.

    The squared gap is convex, with a continuous non-decreasing derivative, and quadratic
    between the parameters where a coordinate crosses a face plane. The minimum lies where
    the derivative changes sign: between the last such parameter where it is negative and the
    first where it is positive, on one quadratic piece, minimised in closed form.
    """
    if _box_slope(u, v, h, 0.0) >= 0.0:
        return _box_gap_sq(u, v, h, 0.0)
    if _box_slope(u, v, h, 1.0) <= 0.0:
        return _box_gap_sq(u, v, h, 1.0)
    lo, hi = 0.0, 1.0
    for m in range(6):
        i = m // 2
        if v[i] != 0.0:
            tb = ((1.0 - 2.0 * (m % 2)) * h[i] - u[i]) / v[i]
            if lo < tb < hi:
                sl = _box_slope(u, v, h, tb)
                if sl < 0.0:
                    lo = tb
                elif sl > 0.0:
                    hi = tb
                else:
                    return _box_gap_sq(u, v, h, tb)
    tm = 0.5 * (lo + hi)
    num = 0.0
    den = 0.0
    for i in range(3):
        x = u[i] + tm * v[i]
        if x > h[i]:
            num += (u[i] - h[i]) * v[i]
            den += v[i] * v[i]
        elif x < -h[i]:
            num += (u[i] + h[i]) * v[i]
            den += v[i] * v[i]
    ts = tm if den <= 0.0 else min(max(-num / den, lo), hi)
    return _box_gap_sq(u, v, h, ts)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _box_inside(u: tuple[float, float, float], v: tuple[float, float, float],
                h: tuple[float, float, float], t: float) -> float:
    """``max_i |u_i + t v_i| - h_i``: minus the depth of a point inside the box [m]."""
    return max(max(abs(u[0] + t * v[0]) - h[0], abs(u[1] + t * v[1]) - h[1]),
               abs(u[2] + t * v[2]) - h[2])


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _axis_overlap(u: tuple[float, float, float], v: tuple[float, float, float],
                  h: tuple[float, float, float], n0: float, n1: float, n2: float) -> float:
    """How far the segment must move along the unit axis ``n`` to leave the box [m]."""
    p0 = n0 * u[0] + n1 * u[1] + n2 * u[2]
    p1 = p0 + n0 * v[0] + n1 * v[1] + n2 * v[2]
    rb = h[0] * abs(n0) + h[1] * abs(n1) + h[2] * abs(n2)
    return min(max(p0, p1) + rb, rb - min(p0, p1))


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _box_depth(u: tuple[float, float, float], v: tuple[float, float, float],
               h: tuple[float, float, float]) -> float:
    """Minus the penetration depth of a segment that meets the box (box frame) [m].

    The least translation that separates a segment from a box is along a normal of a face of
    their Minkowski difference: a face normal of the box, or the segment's direction crossed
    with an edge of the box; the depth is the least overlap of the two along those axes.
    """
    best = min(_axis_overlap(u, v, h, 1.0, 0.0, 0.0), _axis_overlap(u, v, h, 0.0, 1.0, 0.0),
               _axis_overlap(u, v, h, 0.0, 0.0, 1.0))
    length = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    for i in range(3):
        # v x e_i
        c0 = 0.0 if i == 0 else (v[2] if i == 1 else -v[1])
        c1 = -v[2] if i == 0 else (0.0 if i == 1 else v[0])
        c2 = v[1] if i == 0 else (-v[0] if i == 1 else 0.0)
        norm = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        if norm > 1e-9 * length:
            best = min(best, _axis_overlap(u, v, h, c0 / norm, c1 / norm, c2 / norm))
    return -best


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _seg_box(a0: float, a1: float, a2: float, d0: float, d1: float, d2: float,
             o: tuple[float, ...], cutoff: float) -> float:
    """Signed distance from the segment ``a + s d`` to the box of obstacle data ``o`` [m].

    Returns the exact value when it is below ``cutoff``, else a lower bound of it that is at
    least ``cutoff`` (the segment's separation from one of the box's slabs).
    """
    w0, w1, w2 = a0 - o[9], a1 - o[10], a2 - o[11]
    u = (o[0] * w0 + o[3] * w1 + o[6] * w2, o[1] * w0 + o[4] * w1 + o[7] * w2,
         o[2] * w0 + o[5] * w1 + o[8] * w2)
    v = (o[0] * d0 + o[3] * d1 + o[6] * d2, o[1] * d0 + o[4] * d1 + o[7] * d2,
         o[2] * d0 + o[5] * d1 + o[8] * d2)
    h = (o[12], o[13], o[14])
    lower = -_INF
    for i in range(3):
        x0, x1 = u[i], u[i] + v[i]
        lower = max(lower, max(min(x0, x1) - h[i], -h[i] - max(x0, x1)))
    if lower >= cutoff:
        return lower
    g = _box_min_gap_sq(u, v, h)
    if g > 0.0:
        return math.sqrt(g)
    return _box_depth(u, v, h)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _cap_obstacle(a0: float, a1: float, a2: float, d0: float, d1: float, d2: float, bz: float,
                  rad: float, kind: int, o: tuple[float, ...], cutoff: float) -> float:
    """Signed distance [m] from a capsule to an obstacle of ``kind`` and data ``o``.

    The capsule is the segment ``a + s d`` with radius ``rad``; ``bz`` is the z of its other
    end. Exact when below ``cutoff``; else possibly a lower bound of it that is at least ``cutoff``.
    """
    if kind == K_TABLE:
        return min(a2, bz) - o[0] - rad
    if kind == K_SPHERE:
        return _seg_point(a0, a1, a2, d0, d1, d2, o[0], o[1], o[2]) - o[3] - rad
    if kind == K_CAPSULE:
        return _seg_seg(a0, a1, a2, d0, d1, d2, o[0], o[1], o[2], o[3] - o[0], o[4] - o[1],
                        o[5] - o[2]) - o[6] - rad
    return _seg_box(a0, a1, a2, d0, d1, d2, o, cutoff + rad) - rad


# ---- pairs ------------------------------------------------------------------------------------
@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _fmax(x: float, y: float) -> float:
    return x if x > y else y


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _scan(C: np.ndarray, F: np.ndarray, I: np.ndarray, O: np.ndarray,  # noqa: E741
          L: np.ndarray, best: float, stop_below: float) -> tuple[float, int, float]:
    """The least slack below ``best`` over the pairs (capsules placed in ``C``).

    Visits the table pairs, then the obstacles capsule by capsule, then the self pairs;
    skips the pairs whose bounding boxes keep them at least ``best`` apart, and stops at the
    first slack below ``stop_below``. ``O`` holds the obstacles' bounding boxes
    (:func:`_obstacle_boxes`), ``L`` is room for the lower bounds of one capsule's pairs.

    Returns:
        ``(slack, pair, distance)``; ``(best, -1, inf)`` when no pair is below ``best``.
    """
    arg = -1
    dist = _INF
    flat = F.reshape(-1)
    alw = I[H_ALW] * F.shape[1]
    pad_scene, pad_self = F[I[H_MISC], 0], F[I[H_MISC], 1]
    k, m, npair = I[H_K], I[H_O], I[H_P]
    obs0, op = I[H_OBS], I[H_OP]
    order = I[H_ORD]
    table = order + k
    scene = table + k
    recs = scene + k * m
    # the table: exact and cheap
    for ci in range(k):
        c = I[order + ci]
        idx = I[table + c]
        if idx < 0:
            continue
        d = min(C[2, c], C[5, c]) - F[obs0 + I[op + 2 * (idx - npair) + 1], 0] - C[6, c]
        pad = pad_scene - flat[alw + idx]
        if d - pad < best:
            best = d - pad
            arg = idx
            dist = d
            if best < stop_below:
                return best, arg, dist
    # the other obstacles, capsule by capsule: bounding boxes for all obstacles at once
    for ci in range(k):
        c = I[order + ci]
        lx, ly, lz, hx, hy, hz = C[7, c], C[8, c], C[9, c], C[10, c], C[11, c], C[12, c]
        for o in range(m):
            L[o] = _fmax(_fmax(_fmax(O[0, o] - hx, lx - O[3, o]),
                               _fmax(O[1, o] - hy, ly - O[4, o])),
                         _fmax(O[2, o] - hz, lz - O[5, o]))
        row = scene + c * m
        for o in range(m):
            if L[o] - pad_scene >= best:  # allowances only lower a pair's padding
                continue
            idx = I[row + o]
            if idx < 0:
                continue
            pad = pad_scene - flat[alw + idx]
            if L[o] - pad >= best:
                continue
            ro = obs0 + o
            ob = (F[ro, 0], F[ro, 1], F[ro, 2], F[ro, 3], F[ro, 4], F[ro, 5], F[ro, 6],
                  F[ro, 7], F[ro, 8], F[ro, 9], F[ro, 10], F[ro, 11], F[ro, 12], F[ro, 13],
                  F[ro, 14])
            d = _cap_obstacle(C[0, c], C[1, c], C[2, c], C[13, c], C[14, c], C[15, c],
                              C[5, c], C[6, c], I[I[H_OK] + o], ob, best + pad)
            if d - pad < best:
                best = d - pad
                arg = idx
                dist = d
                if best < stop_below:
                    return best, arg, dist
    # the self pairs
    for r in range(npair):
        at = recs + 3 * r
        idx, a, b = I[at], I[at + 1], I[at + 2]
        pad = pad_self - flat[alw + idx]
        lower = _fmax(_fmax(_fmax(C[7, b] - C[10, a], C[7, a] - C[10, b]),
                            _fmax(C[8, b] - C[11, a], C[8, a] - C[11, b])),
                      _fmax(C[9, b] - C[12, a], C[9, a] - C[12, b]))
        if lower - pad >= best:
            continue
        d = _seg_seg(C[0, a], C[1, a], C[2, a], C[13, a], C[14, a], C[15, a],
                     C[0, b], C[1, b], C[2, b], C[13, b], C[14, b], C[15, b])
        d = d - C[6, a] - C[6, b]
        if d - pad < best:
            best = d - pad
            arg = idx
            dist = d
            if best < stop_below:
                return best, arg, dist
    return best, arg, dist


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _slacks_placed(C: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
                   enough: np.ndarray, bounded: bool, out: np.ndarray) -> None:
    """Every pair's slack into ``out`` (capsules placed in ``C``).

    Exact, except with ``bounded``: a pair whose bounding boxes already give it a slack of at
    least ``enough[pair]`` gets that lower bound instead.
    """
    flat = F.reshape(-1)
    alw = I[H_ALW] * F.shape[1]
    pad_scene, pad_self = F[I[H_MISC], 0], F[I[H_MISC], 1]
    npair = I[H_P]
    sp, op, obs0, kinds = I[H_SP], I[H_OP], I[H_OBS], I[H_OK]
    for idx in range(npair):
        a, b = I[sp + 2 * idx], I[sp + 2 * idx + 1]
        pad = pad_self - flat[alw + idx]
        if bounded:
            lower = _fmax(_fmax(_fmax(C[7, b] - C[10, a], C[7, a] - C[10, b]),
                                _fmax(C[8, b] - C[11, a], C[8, a] - C[11, b])),
                          _fmax(C[9, b] - C[12, a], C[9, a] - C[12, b]))
            if lower - pad >= enough[idx]:
                out[idx] = lower - pad
                continue
        d = _seg_seg(C[0, a], C[1, a], C[2, a], C[13, a], C[14, a], C[15, a],
                     C[0, b], C[1, b], C[2, b], C[13, b], C[14, b], C[15, b])
        out[idx] = d - C[6, a] - C[6, b] - pad
    for s in range(I[H_S]):
        idx = npair + s
        c, o = I[op + 2 * s], I[op + 2 * s + 1]
        ro = obs0 + o
        kind = I[kinds + o]
        pad = pad_scene - flat[alw + idx]
        if bounded and kind != K_TABLE:
            lower = _fmax(_fmax(_fmax(F[ro, AABB] - C[10, c], C[7, c] - F[ro, AABB + 3]),
                                _fmax(F[ro, AABB + 1] - C[11, c], C[8, c] - F[ro, AABB + 4])),
                          _fmax(F[ro, AABB + 2] - C[12, c], C[9, c] - F[ro, AABB + 5]))
            if lower - pad >= enough[idx]:
                out[idx] = lower - pad
                continue
        ob = (F[ro, 0], F[ro, 1], F[ro, 2], F[ro, 3], F[ro, 4], F[ro, 5], F[ro, 6],
              F[ro, 7], F[ro, 8], F[ro, 9], F[ro, 10], F[ro, 11], F[ro, 12], F[ro, 13],
              F[ro, 14])
        d = _cap_obstacle(C[0, c], C[1, c], C[2, c], C[13, c], C[14, c], C[15, c],
                          C[5, c], C[6, c], kind, ob, _INF)
        out[idx] = d - pad


# ---- checks -----------------------------------------------------------------------------------
@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _min_slack(q: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
               stop_below: float, multi: bool) -> tuple[float, int, float]:
    """:func:`min_slack`, with :func:`_place_any` for ``multi``."""
    T, C, O, L = _scratch(I)  # noqa: E741
    _obstacle_boxes(F, I, O)
    if multi:
        _place_any(q, F, I, T, C)
    else:
        _place(q, F, I, T, C)
    return _scan(C, F, I, O, L, _INF, stop_below)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def min_slack(q: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
              stop_below: float) -> tuple[float, int, float]:
    """The least slack over the checked pairs at ``q``: ``(slack, pair, distance)`` [m].

    Stops at the first pair whose slack is below ``stop_below`` (``-inf``: never). ``pair`` is
    -1 when nothing is checked.
    """
    if q.shape[0] != I[H_N]:  # universal or ball joints: q has more entries than joints
        return _min_slack(q, F, I, stop_below, True)
    return _min_slack(q, F, I, stop_below, False)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _slacks(q: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
            out: np.ndarray, multi: bool) -> None:
    """:func:`slacks`, with :func:`_place_any` for ``multi``."""
    T, C, _, L = _scratch(I)
    if multi:
        _place_any(q, F, I, T, C)
    else:
        _place(q, F, I, T, C)
    _slacks_placed(C, F, I, L, False, out)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def slacks(q: np.ndarray, F: np.ndarray, I: np.ndarray, out: np.ndarray) -> None:  # noqa: E741
    """Every checked pair's slack at ``q`` into ``out`` (self pairs, then scene pairs) [m]."""
    if q.shape[0] != I[H_N]:  # universal or ball joints: q has more entries than joints
        _slacks(q, F, I, out, True)
        return
    _slacks(q, F, I, out, False)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _slacks_batch(qs: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
                  out: np.ndarray, multi: bool) -> None:
    """:func:`slacks_batch`, with :func:`_place_any` for ``multi``."""
    T, C, _, L = _scratch(I)
    for r in range(qs.shape[0]):
        if multi:
            _place_any(qs[r], F, I, T, C)
        else:
            _place(qs[r], F, I, T, C)
        _slacks_placed(C, F, I, L, False, out[r])


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def slacks_batch(qs: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
                 out: np.ndarray) -> None:
    """:func:`slacks` for every row of ``qs`` (N, nq) into ``out`` (N, pairs)."""
    if qs.shape[1] != I[H_N]:  # universal or ball joints: q has more entries than joints
        _slacks_batch(qs, F, I, out, True)
        return
    _slacks_batch(qs, F, I, out, False)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _free_batch(qs: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
                out: np.ndarray, multi: bool) -> None:
    """:func:`free_batch`, with :func:`_place_any` for ``multi``."""
    T, C, O, L = _scratch(I)  # noqa: E741
    _obstacle_boxes(F, I, O)
    for r in range(qs.shape[0]):
        finite = True
        for j in range(qs.shape[1]):
            if not abs(qs[r, j]) < _INF:  # NaN or infinite: not known to be free
                finite = False
        if not finite:
            out[r] = False
            continue
        if multi:
            _place_any(qs[r], F, I, T, C)
        else:
            _place(qs[r], F, I, T, C)
        out[r] = _scan(C, F, I, O, L, 0.0, 0.0)[1] < 0


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def free_batch(qs: np.ndarray, F: np.ndarray, I: np.ndarray,  # noqa: E741
               out: np.ndarray) -> None:
    """``out[r]`` = whether configuration ``qs[r]`` has no pair closer than its padding.

    A row with a NaN or infinite value is not free.
    """
    if qs.shape[1] != I[H_N]:  # universal or ball joints: q has more entries than joints
        _free_batch(qs, F, I, out, True)
        return
    _free_batch(qs, F, I, out, False)


# ---- motions ----------------------------------------------------------------------------------
@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _motion_bounds(F: np.ndarray, I: np.ndarray, step: np.ndarray,  # noqa: E741
                   cap_move: np.ndarray) -> None:
    """``cap_move[c]``: how far any point of capsule ``c`` can travel for joint travels ``step``.

    ``step`` has one entry per tangent entry (``nv``: a universal joint two, a ball joint three).
    """
    k, lev = I[H_K], I[H_LEV]
    for c in range(k):
        s = 0.0
        for j in range(step.shape[0]):
            s += F[lev + c, j] * step[j]
        cap_move[c] = s


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _pair_levers(F: np.ndarray, I: np.ndarray, coef: np.ndarray) -> None:  # noqa: E741
    """``coef[pair, j]``: how fast the pair's shapes can approach per unit travel of joint j.

    A scene pair: the capsule's lever. A self pair: the sum of both capsules' levers, except
    for the joints that carry both capsules (the joints up to where their chains part): those
    move the two together, rigidly, which leaves their distance as it is. Columns are tangent
    entries (``nv``; a joint's first in column 21 of its row of ``F``, its kind in column 16).
    """
    n, npair, lev = coef.shape[1], I[H_P], I[H_LEV]
    sp, op, cb, par = I[H_SP], I[H_OP], I[H_CB], I[H_PAR]
    for idx in range(npair):
        a, b = I[sp + 2 * idx], I[sp + 2 * idx + 1]
        for j in range(n):
            coef[idx, j] = F[lev + a, j] + F[lev + b, j]
        # the joints on both chains: walk up from each body; a joint of b's chain that is on
        # a's chain, and every joint above it, carries both
        jb = I[cb + b]
        while jb >= 0:
            ja = I[cb + a]
            while ja >= 0 and ja != jb:
                ja = I[par + ja]
            if ja == jb:
                break
            jb = I[par + jb]
        while jb >= 0:
            kind = F[jb, 16]
            v0 = int(F[jb, 21])
            for i in range(1 if kind == 0.0 else (2 if kind < 2.5 else 3)):
                coef[idx, v0 + i] = 0.0
            jb = I[par + jb]
    for s in range(I[H_S]):
        c = I[op + 2 * s]
        for j in range(n):
            coef[npair + s, j] = F[lev + c, j]


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _pair_moves(coef: np.ndarray, step: np.ndarray, out: np.ndarray) -> None:
    """``out[pair]``: how far the pair's shapes can approach for joint travels ``step`` [m]."""
    for idx in range(coef.shape[0]):
        s = 0.0
        for j in range(coef.shape[1]):
            s += coef[idx, j] * step[j]
        out[idx] = s


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _worst_uncertified(s0: np.ndarray, s1: np.ndarray, move: np.ndarray) -> int:
    """The pair that the slacks at both ends cannot keep apart over the step, else -1.

    A point's distance to anything changes no faster than the point moves, so a pair whose
    slacks at the two ends add up to at least how far the pair can approach over the step
    (``move``, see :func:`_pair_levers`) keeps a slack >= 0 all along
    (``s(t) >= (s0 + s1 - move) / 2``).
    """
    worst = -1
    wv = 0.0
    for idx in range(s0.shape[0]):
        v = s0[idx] + s1[idx] - move[idx]
        if v < wv:
            wv = v
            worst = idx
    return worst


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _argmin(x: np.ndarray) -> int:
    best = 0
    for i in range(1, x.shape[0]):
        if x[i] < x[best]:
            best = i
    return best


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _segment_first_contact(q0: np.ndarray, q1: np.ndarray, F: np.ndarray,
                           I: np.ndarray,  # noqa: E741
                           resolution: float, multi: bool) -> tuple[float, int, float]:
    """:func:`segment_first_contact`, with :func:`_place_any` for ``multi``."""
    n = q0.shape[0]
    npairs = I[H_P] + I[H_S]
    depth_max = 60
    T, C, _, _ = _scratch(I)
    us = np.empty(depth_max + 2)
    rows = np.empty((depth_max + 2, max(npairs, 1)))
    cur = np.empty(max(npairs, 1))
    cap_move = np.empty(max(I[H_K], 1))
    coef = np.empty((max(npairs, 1), max(n, 1)))
    whole = np.empty(max(npairs, 1))
    move = np.empty(max(npairs, 1))
    step = np.empty(n)
    q = np.empty(n)
    _pair_levers(F, I, coef)
    for j in range(n):
        step[j] = abs(q1[j] - q0[j])
    _pair_moves(coef[:npairs], step, whole)
    # a pair at least as far as it can approach over a piece is certified on every piece
    # inside it whose other end is free: a lower bound of its slack does as well as the value
    if multi:
        _place_any(q0, F, I, T, C)
    else:
        _place(q0, F, I, T, C)
    _slacks_placed(C, F, I, whole, True, cur)
    if npairs > 0:
        a = _argmin(cur[:npairs])
        if cur[a] < 0.0:
            return 0.0, a, cur[a]
    u_lo = 0.0
    top = 0
    us[0] = 1.0
    if multi:
        _place_any(q1, F, I, T, C)
    else:
        _place(q1, F, I, T, C)
    _slacks_placed(C, F, I, whole, True, rows[0])
    while top >= 0:
        u_hi = us[top]
        hi = rows[top]
        frac = u_hi - u_lo
        for j in range(n):
            step[j] = abs(q1[j] - q0[j]) * frac
        for i in range(npairs):
            move[i] = whole[i] * frac
        w = _worst_uncertified(cur[:npairs], hi[:npairs], move[:npairs])
        a = _argmin(hi[:npairs]) if npairs > 0 else 0
        touching = npairs > 0 and hi[a] < 0.0
        if not touching and w < 0:  # the piece lo-hi is free: go on from hi
            u_lo = u_hi
            for i in range(npairs):
                cur[i] = hi[i]
            top -= 1
            continue
        _motion_bounds(F, I, step, cap_move)
        big = 0.0
        for c in range(I[H_K]):
            big = max(big, cap_move[c])
        if top == depth_max or big < resolution:
            if touching:
                return u_hi, a, hi[a]
            return u_hi, w, hi[w]
        um = 0.5 * (u_lo + u_hi)
        for j in range(n):
            q[j] = q0[j] + um * (q1[j] - q0[j])
        top += 1
        us[top] = um
        # the new sample only ends pieces inside lo-hi: bound by how far pairs approach over it
        if multi:
            _place_any(q, F, I, T, C)
        else:
            _place(q, F, I, T, C)
        _slacks_placed(C, F, I, move, True, rows[top])
    return -1.0, -1, 0.0


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def segment_first_contact(q0: np.ndarray, q1: np.ndarray, F: np.ndarray,
                          I: np.ndarray,  # noqa: E741
                          resolution: float) -> tuple[float, int, float]:
    """The first contact on the straight joint-space line ``q0``-``q1``, checked continuously.

    The line is straight in ``q`` (``q0 + u (q1 - q0)``): for arms without ball joints (the
    model checks a ball joint's shortest arc by samples instead). The line is bisected until
    every piece is certified free (see :func:`_worst_uncertified`) or a piece shorter than
    ``resolution`` [m of capsule travel] is not: then its end is reported as the contact (its
    slack may be a hair above 0: a pair touching its padding).

    Returns:
        ``(u, pair, slack)``: the fraction of the line [0-1] of the first contact, the pair and
        its slack there [m]; ``u = -1`` when the whole line is free.
    """
    if q0.shape[0] != I[H_N]:  # universal or ball joints: q has more entries than joints
        return _segment_first_contact(q0, q1, F, I, resolution, True)
    return _segment_first_contact(q0, q1, F, I, resolution, False)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _samples_first_problem(qs: np.ndarray, step: np.ndarray, F: np.ndarray,
                           I: np.ndarray, multi: bool,  # noqa: E741
                           ) -> tuple[int, int, int, float]:
    """:func:`samples_first_problem`, with :func:`_place_any` for ``multi``."""
    npairs = I[H_P] + I[H_S]
    n = step.shape[1]
    T, C, _, _ = _scratch(I)
    prev = np.empty(max(npairs, 1))
    cur = np.empty(max(npairs, 1))
    coef = np.empty((max(npairs, 1), max(n, 1)))
    move = np.empty(max(npairs, 1))
    enough = np.empty(max(npairs, 1))
    _pair_levers(F, I, coef)
    # a pair at least as far as it can approach over the longest step is certified on every
    # step whose other end is free: a lower bound of its slack does as well as the value
    longest = np.zeros(n)
    for r in range(step.shape[0]):
        for j in range(n):
            longest[j] = max(longest[j], step[r, j])
    _pair_moves(coef[:npairs], longest, enough)
    for r in range(qs.shape[0]):
        if multi:
            _place_any(qs[r], F, I, T, C)
        else:
            _place(qs[r], F, I, T, C)
        _slacks_placed(C, F, I, enough, True, cur)
        if npairs > 0:
            a = _argmin(cur[:npairs])
            if cur[a] < 0.0:
                return 1, r, a, cur[a]
        if r > 0:
            _pair_moves(coef[:npairs], step[r - 1], move)
            w = _worst_uncertified(prev[:npairs], cur[:npairs], move[:npairs])
            if w >= 0:
                return 2, r - 1, w, min(prev[w], cur[w])
        for i in range(npairs):
            prev[i] = cur[i]
    return 0, -1, -1, 0.0


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def samples_first_problem(qs: np.ndarray, step: np.ndarray, F: np.ndarray,
                          I: np.ndarray,  # noqa: E741
                          ) -> tuple[int, int, int, float]:
    """The first sample in contact or step not certified free along sampled motion.

    Args:
        qs: ``(N, nq)`` samples.
        step: ``(N - 1, nv)``: per step an upper bound of each tangent entry's travel
            between the samples (the length of its path, not just the difference; a ball
            joint's: of each component of its angular velocity in its moved frame).
        F: Packed floats.
        I: Packed integers.

    Returns:
        ``(status, i, pair, slack)``: status 0 all free and certified; 1 sample ``i`` is in
        contact (``pair`` and its ``slack``); 2 the step from sample ``i`` to ``i + 1`` is not
        certified by its end samples (``pair`` is the one in doubt).
    """
    if qs.shape[1] != I[H_N]:  # universal or ball joints: q has more entries than joints
        return _samples_first_problem(qs, step, F, I, True)
    return _samples_first_problem(qs, step, F, I, False)


_ks.finish(globals())


def __getattr__(name: str) -> Any:
    """A kernel: numba is imported and the kernels compiled when the first one is read."""
    return _ks.getattr(name)


def interpreted(name: str) -> Callable[..., Any]:
    """Kernel ``name`` run by the Python interpreter (no numba; the same results)."""
    return _ks.interpreted(name)
