"""Compiled residuals of the IK goals: errors, stacked residual vector and Jacobian.

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
Rows are scaled by ``sqrt(weight)``, orientation rows also by the method's rotation weight
``rw`` [m/rad].
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np

from armctl.kinematics._kernels import fk_into, fk_jacobian_into

#: numba options shared by the IK kernels
NJIT: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}

POSITION, ORIENTATION, DIRECTION, POSE = 0, 1, 2, 3


@nb.njit(inline="always", **NJIT)
def _relative_rotation(gd: np.ndarray, pose: np.ndarray, d: np.ndarray) -> None:
    """``d = R_target @ R^T`` for the goal row ``gd`` and a frame pose."""
    for i in range(3):
        for j in range(3):
            d[i, j] = (gd[3 + 3 * i] * pose[j, 0] + gd[4 + 3 * i] * pose[j, 1]
                       + gd[5 + 3 * i] * pose[j, 2])


@nb.njit(**NJIT)
def _rotation_error(gd: np.ndarray, pose: np.ndarray, out: np.ndarray, k: int, s: float) -> None:
    """``out[k:k+3] = s * log(R_target R^T)`` (rotation vector, base frame) [rad]."""
    d = np.empty((3, 3))
    _relative_rotation(gd, pose, d)
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


@nb.njit(**NJIT)
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
        _relative_rotation(gd, pose, d)
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


@nb.njit(**NJIT)
def _all_met(gt: np.ndarray, gd: np.ndarray, gtol: np.ndarray, pose: np.ndarray,
             margin: float) -> bool:
    for g in range(gt.shape[0]):
        dp, dr = goal_error(gt[g], gd[g], pose[g])
        if dp > gtol[g, 0] * margin or dr > gtol[g, 1] * margin:
            return False
    return True


@nb.njit(**NJIT)
def _max_errors(gt: np.ndarray, gd: np.ndarray, pose: np.ndarray) -> tuple[float, float]:
    mp = 0.0
    mr = 0.0
    for g in range(gt.shape[0]):
        dp, dr = goal_error(gt[g], gd[g], pose[g])
        mp = max(mp, dp)
        mr = max(mr, dr)
    return mp, mr


@nb.njit(**NJIT)
def n_rows(gt: np.ndarray) -> int:
    """Rows of the stacked residual."""
    m = 0
    for g in range(gt.shape[0]):
        m += 3 if (gt[g] == POSITION or gt[g] == ORIENTATION) else 6
    return m


@nb.njit(**NJIT)
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


