"""The whole pose solve of a 6R family in one compiled call (the hot path of ``ik_all``)."""

from __future__ import annotations

import numba as nb
import numpy as np

from armctl.ik.analytic._families import spherical_wrist, three_parallel
from armctl.ik.analytic._polish import POSE, assemble
from armctl.ik.analytic._search import CAPACITY, one_pair
from armctl.ik.analytic.general6r import general6r

#: Family codes of :func:`pose6`.
SPHERICAL, PARALLEL, PAIR, GENERAL = 0, 1, 2, 3


@nb.njit(cache=True, nogil=True, error_model="numpy")
def pose6(code: int, inverted: bool, h: np.ndarray, o: np.ndarray, m: np.ndarray,
          joints: np.ndarray, sign: np.ndarray, cols: np.ndarray, is_col: np.ndarray,
          q_ref: np.ndarray, goal: np.ndarray, jd: np.ndarray, fd: np.ndarray,
          paths: np.ndarray, f: int, tol: float, lower: np.ndarray,
          upper: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
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

    Returns:
        ``(q, within_limits, errors, singular)`` as :func:`assemble` plus the singular flag.
    """
    target = goal.copy()
    if inverted:
        for i in range(3):
            for j in range(3):
                target[i, j] = goal[j, i]
        for i in range(3):
            target[i, 3] = -(goal[0, i] * goal[0, 3] + goal[1, i] * goal[1, 3]
                             + goal[2, i] * goal[2, 3])
    ref = np.empty(6)
    for k in range(6):
        ref[k] = sign[k] * q_ref[joints[k]]
    raw = np.empty((CAPACITY, 7))
    if code == SPHERICAL:
        n, singular = spherical_wrist(h, o, m, target, ref, raw)
    elif code == PARALLEL:
        n, singular = three_parallel(h, o, m, target, ref, raw)
    elif code == PAIR:
        n, singular = one_pair(h, o, m, target, ref, raw)
    else:
        n, singular = general6r(h, o, m, target, ref, raw)
    z = np.zeros(3)
    q, inside, errs, _ = assemble(raw, n, joints, sign, cols, is_col, q_ref, POSE, goal,
                                  goal[:3, 3].copy(), z, z, jd, fd, paths, f, tol, lower, upper)
    return q, inside, errs, singular
