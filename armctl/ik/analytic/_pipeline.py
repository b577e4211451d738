"""The whole pose solve of a 6R family in one compiled call (the hot path of ``ik_all``)."""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from armctl.ik.analytic._families import spherical_wrist, three_parallel
from armctl.ik.analytic._polish import POSE, assemble, distinct_rows
from armctl.ik.analytic._search import CAPACITY, one_pair
from armctl.ik.analytic.general6r import general6r

#: Family codes of :func:`pose6`.
SPHERICAL, PARALLEL, PAIR, GENERAL = 0, 1, 2, 3


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _candidates(code: int, inverted: bool, h: np.ndarray, o: np.ndarray, m: np.ndarray,
                joints: np.ndarray, sign: np.ndarray, q_ref: np.ndarray, goal: np.ndarray
                ) -> tuple[np.ndarray, int, bool]:
    """The family solver's raw candidates for ``goal`` (inverted with the chain if it is).

    Returns:
        ``(raw, n, singular)``: the first ``n`` rows of ``raw`` ``(CAPACITY, 7)`` are the
        candidates in solver-chain joints, and whether the goal is at a singularity.
    """
    buf = np.empty(22)  # the target pose and the reference in one allocation
    target = buf[0:16].reshape((4, 4))
    for i in range(4):
        for j in range(4):
            target[i, j] = goal[i, j] if i < 3 else (1.0 if j == 3 else 0.0)
    if inverted:
        for i in range(3):
            for j in range(3):
                target[i, j] = goal[j, i]
        for i in range(3):
            target[i, 3] = -(goal[0, i] * goal[0, 3] + goal[1, i] * goal[1, 3]
                             + goal[2, i] * goal[2, 3])
    ref = buf[16:22]
    for c in range(6):
        ref[c] = sign[c] * q_ref[joints[c]]
    raw = np.empty((CAPACITY, 7))
    if code == SPHERICAL:
        n, singular = spherical_wrist(h, o, m, target, ref, raw)
    elif code == PARALLEL:
        n, singular = three_parallel(h, o, m, target, ref, raw)
    elif code == PAIR:
        n, singular = one_pair(h, o, m, target, ref, raw)
    else:
        n, singular = general6r(h, o, m, target, ref, raw)
    return raw, n, singular


@nb.njit(cache=True, nogil=True, error_model="numpy")
def pose6(code: int, inverted: bool, h: np.ndarray, o: np.ndarray, m: np.ndarray,
          joints: np.ndarray, sign: np.ndarray, cols: np.ndarray, is_col: np.ndarray,
          q_ref: np.ndarray, goal: np.ndarray, jd: np.ndarray, fd: np.ndarray,
          paths: np.ndarray, f: int, tol: float, lower: np.ndarray,
          upper: np.ndarray, variants: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """Every solution of a pose goal for a 6R chain of a family.

    Args:
        code: :data:`SPHERICAL`, :data:`PARALLEL`, :data:`PAIR` or :data:`GENERAL`.
        inverted: Whether ``h, o, m`` describe the inverted chain (the goal is inverted too).
        h: ``(6, 3)`` axes of the solver chain.
        o: ``(6, 3)`` points on them [m].
        m: ``(4, 4)`` its tool pose at the zero configuration.
        joints: Model joint index of each solver-chain joint.
        sign: Sign of each solver-chain joint.
        cols: The solved joints.
        is_col: ``(dof,)`` mask of ``cols``.
        q_ref: ``(dof,)`` reference configuration [rad].
        goal: ``(4, 4)`` target pose of the frame.
        jd: Packed joints of the model.
        fd: Packed frames of the model.
        paths: Joint paths of the model's frames.
        f: The goal frame's index.
        tol: Acceptance tolerance [m] and [rad].
        lower: Lower joint limits.
        upper: Upper joint limits.
        variants: Every 2 pi variant as a row, or one row per solution (see :func:`assemble`).

    Returns:
        ``(q, within_limits, errors, singular)`` as :func:`assemble` plus the singular flag.
    """
    raw, n, singular = _candidates(code, inverted, h, o, m, joints, sign, q_ref, goal)
    z = np.zeros(3)
    q, inside, errs, _ = assemble(raw, n, joints, sign, cols, is_col, q_ref, POSE, goal,
                                  goal[:3, 3].copy(), z, z, jd, fd, paths, f, tol, lower, upper,
                                  variants)
    return q, inside, errs, singular


#: Status codes of :func:`pose6_distinct` (``(result >> 1) & 7``).
OK, NOT_FINITE, NOT_ROTATION, NEEDS_CLEANUP, BAD_REF, OVERFLOW = 0, 1, 2, 3, 4, 5
#: :func:`pose6_distinct`'s result is ``count << COUNT_SHIFT | status << 1 | singular``.
COUNT_SHIFT = 4


@nb.njit(cache=True, nogil=True, error_model="numpy")
def pose6_distinct(arm: np.ndarray, q_ref: np.ndarray, goal: np.ndarray, tol: float,
                   rows: np.ndarray, inside: np.ndarray) -> int:
    """The distinct solutions of a pose goal for a 6R chain of a family, in one call.

    The goal is checked first (finite, a rotation matrix); then the family's closed form,
    and :func:`armctl.ik.analytic._polish.distinct_rows`: each candidate checked on the
    model's FK and polished, duplicates (closer than 1e-6 rad on every joint, modulo 2 pi)
    merged, each solution's solved joints at their 2 pi variants inside the limits nearest to
    ``q_ref`` (the wrapped value when there is none there), nearest to ``q_ref`` first. Nearby
    distinct solutions are all kept. Everything about the arm comes in one flat array and the
    answer goes into two arrays of the caller, with one integer back (one compiled call with
    few arguments and no array handed back: the call itself, and each array passed or
    returned, is a good part of the time).

    Args:
        arm: The arm's constants, flattened (:func:`pack6`): first its integers (their bits in
            float64 slots): ``[number of integers, code, inverted, frame index, number of solved
            joints k, joint rows, joint columns, frame rows, frame columns, path columns, chain
            joints (6), solved joints (k), joint paths of the frames, mask of the solved joints
            (dof)]``, then its reals: axes ``h`` (18), points ``o`` (18), tool pose ``m``
            (16), signs (6), the lower and upper joint limits (dof each), the packed joints and
            the packed frames of the model.
        q_ref: ``(dof,)`` reference configuration [rad].
        goal: ``(4, 4)`` target pose (its last row is ignored).
        tol: Acceptance tolerance [m] and [rad].
        rows: ``(cap, dof + 2)`` receives each solution's joints and its position [m] and
            rotation [rad] errors, nearest to ``q_ref`` first.
        inside: ``(cap,)`` receives whether each lies inside the limits.

    Returns:
        ``count << COUNT_SHIFT | status << 1 | singular``: the number of solutions (the first
        rows of ``rows`` and ``inside``), the status (:data:`OK`, :data:`NOT_FINITE`,
        :data:`NOT_ROTATION`, :data:`NEEDS_CLEANUP` for a rotation that is off by more than
        round-off and must be orthonormalised first, :data:`BAD_REF` for a ``q_ref`` with NaN
        or inf, :data:`OVERFLOW` when the family gave more candidates than ``cap``: nothing
        was written) and whether the goal is at a singularity.
    """
    dof = q_ref.shape[0]
    status = OK
    for j in range(dof):
        if not math.isfinite(q_ref[j]):
            status = BAD_REF
    for i in range(3):
        for j in range(4):
            if not math.isfinite(goal[i, j]):
                status = NOT_FINITE
    if status == OK:
        dev = 0.0
        for i in range(3):
            for j in range(3):
                s = goal[i, 0] * goal[j, 0] + goal[i, 1] * goal[j, 1] + goal[i, 2] * goal[j, 2]
                dev = max(dev, abs(s - (1.0 if i == j else 0.0)))
        det = (goal[0, 0] * (goal[1, 1] * goal[2, 2] - goal[1, 2] * goal[2, 1])
               - goal[0, 1] * (goal[1, 0] * goal[2, 2] - goal[1, 2] * goal[2, 0])
               + goal[0, 2] * (goal[1, 0] * goal[2, 1] - goal[1, 1] * goal[2, 0]))
        if dev > 1e-6 or det < 0.0:
            status = NOT_ROTATION
        elif dev > 1e-14:
            status = NEEDS_CLEANUP
    if status != OK:
        return status << 1
    ni = arm[0:1].view(np.int64)[0]
    i64 = arm[0:ni].view(np.int64)  # views: no copies
    f64 = arm[ni:]
    h = f64[0:18].reshape((6, 3))
    o = f64[18:36].reshape((6, 3))
    m = f64[36:52].reshape((4, 4))
    sign = f64[52:58]
    lower = f64[58:58 + dof]
    upper = f64[58 + dof:58 + 2 * dof]
    code, inverted, f, k = i64[1], i64[2] != 0, i64[3], i64[4]
    nj, jw, nf, fw, pw = i64[5], i64[6], i64[7], i64[8], i64[9]
    at = 58 + 2 * dof
    jd = f64[at:at + nj * jw].reshape((nj, jw))
    at += nj * jw
    fd = f64[at:at + nf * fw].reshape((nf, fw))
    joints = i64[10:16]
    cols = i64[16:16 + k]
    at = 16 + k + nf * pw
    paths = i64[16 + k:at].reshape((nf, pw))
    is_col = i64[at:at + dof]
    raw, n, singular = _candidates(code, inverted, h, o, m, joints, sign, q_ref, goal)
    if n > rows.shape[0] or n > inside.shape[0]:
        return OVERFLOW << 1
    count = distinct_rows(raw, n, joints, sign, cols, is_col, q_ref, goal, jd, fd, paths, f,
                          tol, lower, upper, rows, inside)
    return count << COUNT_SHIFT | OK << 1 | (1 if singular else 0)


def pack6(h: np.ndarray, o: np.ndarray, m: np.ndarray, sign: np.ndarray, lower: np.ndarray,
          upper: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, code: int,
          inverted: bool, f: int, joints: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The flat array of an arm's constants that :func:`pose6_distinct` takes.

    Args:
        h: ``(6, 3)`` axes of the solver chain.
        o: ``(6, 3)`` points on them [m].
        m: ``(4, 4)`` its tool pose at the zero configuration.
        sign: ``(6,)`` sign of each solver-chain joint.
        lower: Lower joint limits of the model.
        upper: Upper joint limits of the model.
        jd: Packed joints of the model.
        fd: Packed frames of the model.
        paths: Joint paths of the model's frames.
        code: :data:`SPHERICAL`, :data:`PARALLEL`, :data:`PAIR` or :data:`GENERAL`.
        inverted: Whether the chain is inverted.
        f: The goal frame's index.
        joints: Model joint index of each solver-chain joint.
        cols: The solved joints.
    """
    f64 = np.concatenate([np.ravel(h), np.ravel(o), np.ravel(m), np.ravel(sign), lower, upper,
                          np.ravel(jd), np.ravel(fd)]).astype(np.float64)
    mask = np.zeros(lower.shape[0], dtype=np.int64)
    mask[cols] = 1
    i64 = np.concatenate([[0, code, int(inverted), f, len(cols), jd.shape[0], jd.shape[1],
                           fd.shape[0], fd.shape[1], paths.shape[1]], joints, cols,
                          np.ravel(paths), mask]).astype(np.int64)
    i64[0] = len(i64)
    return np.ascontiguousarray(np.concatenate([i64.view(np.float64), f64]))
