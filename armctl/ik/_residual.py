"""Compiled residuals of the IK goals: errors, stacked residual vector and Jacobian.

Goals are packed into flat arrays by :mod:`armctl.ik._pack`:

* ``gf`` ``(G,)``: frame index of each goal.
* ``gt`` ``(G,)``: goal kind (:class:`armctl.ik.goals.GoalKind`; :data:`POSITION`,
  :data:`ORIENTATION`, :data:`DIRECTION`, :data:`POSE`, :data:`LOOK_AT` here).
* ``gd`` ``(G, 18)``: the targets, as :meth:`armctl.ik.goals.Goal.packed` writes them: target
  position or point (0-2), target rotation row-major (3-11), target direction (12-14), tool axis
  in the goal frame's coordinates (15-17).
* ``gw`` ``(G,)``: goal weights; ``gtol`` ``(G, 2)``: position [m] and rotation [rad] tolerance.
* ``mask`` ``(G, n)``: 1 where joint ``j`` moves goal ``g``'s frame.

The residual of a goal stacks its position error ``p_target - p`` (3 rows, Jacobian rows
``J_v``) and its orientation part: the rotation vector of ``R_target R^T`` (3 rows, ``J_w``) for
orientation and pose goals, or ``d_target - a`` for a direction goal, where ``a`` is the current
tool axis in the base frame, with the columns ``w_i x a`` (zero for prismatic joints) of the
lecture (L. Kavan, *Metody skeletální animace*, 2002).
A look-at goal has no position rows; its 3 rows are ``u - a`` with ``u`` the unit vector from the
frame's origin to the point (distance ``r``), with columns ``w_i x a + (I - u u^T) v_i / r``
(``v_i`` the origin's velocity column of ``J_v``). Rows are scaled by ``sqrt(weight)``,
orientation rows also by the method's rotation weight ``rw`` [m/rad].

Each goal kind is one branch of :func:`goal_error`, :func:`kind_rows` and :func:`_residual`
(docs/ik-goals.md, "Adding a goal type").
"""

from __future__ import annotations

import math
from typing import Any

import numba as nb
import numpy as np

from armctl.ik.goals import GoalKind, use_compiled_checks
from armctl.kinematics._kernels import fk_into, fk_jacobian_into

#: numba options shared by the IK kernels
NJIT: dict[str, Any] = {"cache": True, "nogil": True, "error_model": "numpy"}

#: The goal kinds as the kernels see them (compile-time constants)
POSITION = int(GoalKind.POSITION)
ORIENTATION = int(GoalKind.ORIENTATION)
DIRECTION = int(GoalKind.DIRECTION)
POSE = int(GoalKind.POSE)
LOOK_AT = int(GoalKind.LOOK_AT)


@nb.njit(inline="always", **NJIT)
def has_position(t: int) -> bool:
    """Whether goals of kind ``t`` constrain the frame's position (3 position rows)."""
    return t == POSITION or t == DIRECTION or t == POSE


@nb.njit(inline="always", **NJIT)
def _tool_axis(gd: np.ndarray, pose: np.ndarray) -> tuple[float, float, float]:
    """The goal's tool axis (``gd[15:18]``, frame coordinates) in the base frame."""
    return (pose[0, 0] * gd[15] + pose[0, 1] * gd[16] + pose[0, 2] * gd[17],
            pose[1, 0] * gd[15] + pose[1, 1] * gd[16] + pose[1, 2] * gd[17],
            pose[2, 0] * gd[15] + pose[2, 1] * gd[16] + pose[2, 2] * gd[17])


@nb.njit(inline="always", **NJIT)
def _angle(a0: float, a1: float, a2: float, b0: float, b1: float, b2: float) -> float:
    """Angle between two vectors [rad] (any lengths), accurate at 0 and pi."""
    c0 = a1 * b2 - a2 * b1
    c1 = a2 * b0 - a0 * b2
    c2 = a0 * b1 - a1 * b0
    return math.atan2(math.sqrt(c0 * c0 + c1 * c1 + c2 * c2), a0 * b0 + a1 * b1 + a2 * b2)


@nb.njit(inline="always", **NJIT)
def _relative_rotation(gd: np.ndarray, pose: np.ndarray) -> tuple[float, float, float, float,
                                                                  float, float, float, float,
                                                                  float]:
    """``d = R_target @ R^T`` for the goal row ``gd`` and a frame pose, row-major."""
    return (gd[3] * pose[0, 0] + gd[4] * pose[0, 1] + gd[5] * pose[0, 2],
            gd[3] * pose[1, 0] + gd[4] * pose[1, 1] + gd[5] * pose[1, 2],
            gd[3] * pose[2, 0] + gd[4] * pose[2, 1] + gd[5] * pose[2, 2],
            gd[6] * pose[0, 0] + gd[7] * pose[0, 1] + gd[8] * pose[0, 2],
            gd[6] * pose[1, 0] + gd[7] * pose[1, 1] + gd[8] * pose[1, 2],
            gd[6] * pose[2, 0] + gd[7] * pose[2, 1] + gd[8] * pose[2, 2],
            gd[9] * pose[0, 0] + gd[10] * pose[0, 1] + gd[11] * pose[0, 2],
            gd[9] * pose[1, 0] + gd[10] * pose[1, 1] + gd[11] * pose[1, 2],
            gd[9] * pose[2, 0] + gd[10] * pose[2, 1] + gd[11] * pose[2, 2])


@nb.njit(**NJIT)
def _rotation_error(gd: np.ndarray, pose: np.ndarray, out: np.ndarray, k: int, s: float) -> None:
    """``out[k:k+3] = s * log(R_target R^T)`` (rotation vector, base frame) [rad]."""
    d00, d01, d02, d10, d11, d12, d20, d21, d22 = _relative_rotation(gd, pose)
    v0 = d21 - d12
    v1 = d02 - d20
    v2 = d10 - d01
    sn = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    c = (d00 + d11 + d22 - 1.0) / 2.0
    ang = math.atan2(sn / 2.0, c)
    if ang < 1e-9:
        f = 0.5
    elif ang < math.pi - 1e-6:
        f = ang / sn
    else:  # near pi: the axis from the symmetric part, the sign from the skew part
        d = np.empty((3, 3))
        d[0, 0], d[0, 1], d[0, 2] = d00, d01, d02
        d[1, 0], d[1, 1], d[1, 2] = d10, d11, d12
        d[2, 0], d[2, 1], d[2, 2] = d20, d21, d22
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
    if has_position(t):
        x = gd[0] - pose[0, 3]
        y = gd[1] - pose[1, 3]
        z = gd[2] - pose[2, 3]
        dp = math.sqrt(x * x + y * y + z * z)
    if t == ORIENTATION or t == POSE:
        d00, d01, d02, d10, d11, d12, d20, d21, d22 = _relative_rotation(gd, pose)
        v0 = d21 - d12
        v1 = d02 - d20
        v2 = d10 - d01
        c = (d00 + d11 + d22 - 1.0) / 2.0
        dr = math.atan2(math.sqrt(v0 * v0 + v1 * v1 + v2 * v2) / 2.0, c)
    elif t == DIRECTION:
        a0, a1, a2 = _tool_axis(gd, pose)
        dr = _angle(a0, a1, a2, gd[12], gd[13], gd[14])
    elif t == LOOK_AT:
        a0, a1, a2 = _tool_axis(gd, pose)
        x = gd[0] - pose[0, 3]
        y = gd[1] - pose[1, 3]
        z = gd[2] - pose[2, 3]
        if x * x + y * y + z * z < 1e-24:  # the frame at the point: no direction
            dr = math.pi
        else:
            dr = _angle(a0, a1, a2, x, y, z)
    return dp, dr


@nb.njit(**NJIT)
def goal_errors_many(t: int, gd: np.ndarray, pose: np.ndarray, out: np.ndarray) -> None:
    """:func:`goal_error` of one goal kind for ``N`` targets and frame poses.

    ``gd`` ``(N, 18)`` holds the targets, ``pose`` ``(N, 4, 4)`` the frame poses; ``out``
    ``(N, 2)`` receives the position [m] and rotation [rad] errors.
    """
    for i in range(gd.shape[0]):
        dp, dr = goal_error(t, gd[i], pose[i])
        out[i, 0] = dp
        out[i, 1] = dr


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


@nb.njit(inline="always", **NJIT)
def kind_rows(t: int) -> int:
    """Rows of the residual of one goal of kind ``t``."""
    return 6 if (t == DIRECTION or t == POSE) else 3


@nb.njit(**NJIT)
def n_rows(gt: np.ndarray) -> int:
    """Rows of the stacked residual."""
    m = 0
    for g in range(gt.shape[0]):
        m += kind_rows(gt[g])
    return m


@nb.njit(**NJIT)
def _residual(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, gf: np.ndarray,
              gt: np.ndarray, gd: np.ndarray, gw: np.ndarray, rw: float, pose: np.ndarray,
              jg: np.ndarray, e: np.ndarray, jac: np.ndarray, with_jac: bool) -> float:
    """Fill ``e`` (and ``jac`` when ``with_jac``) and the goal poses; return ``E = |e|^2 / 2``.

    ``rw`` [m/rad] scales the orientation rows against the position rows.
    """
    n = jg.shape[1]  # the tangent length (== len(q) for 1-DOF joints)
    r = 0
    for g in range(gf.shape[0]):
        if with_jac:
            fk_jacobian_into(q, jd, fd, paths, gf[g], pose[g], jg)
        else:
            fk_into(q, jd, fd, paths, gf[g], pose[g])
        s = math.sqrt(gw[g])
        t = gt[g]
        p = pose[g]
        if has_position(t):
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
            a0, a1, a2 = _tool_axis(gd[g], p)
            e[r] = sr * (gd[g, 12] - a0)
            e[r + 1] = sr * (gd[g, 13] - a1)
            e[r + 2] = sr * (gd[g, 14] - a2)
            if with_jac:  # the lecture's column w x v for the direction part
                for c in range(n):
                    wx, wy, wz = jg[3, c], jg[4, c], jg[5, c]
                    jac[r, c] = sr * (wy * a2 - wz * a1)
                    jac[r + 1, c] = sr * (wz * a0 - wx * a2)
                    jac[r + 2, c] = sr * (wx * a1 - wy * a0)
            r += 3
        elif t == LOOK_AT:
            a0, a1, a2 = _tool_axis(gd[g], p)
            x = gd[g, 0] - p[0, 3]
            y = gd[g, 1] - p[1, 3]
            z = gd[g, 2] - p[2, 3]
            dist = max(math.sqrt(x * x + y * y + z * z), 1e-12)
            u0, u1, u2 = x / dist, y / dist, z / dist
            e[r] = sr * (u0 - a0)
            e[r + 1] = sr * (u1 - a1)
            e[r + 2] = sr * (u2 - a2)
            if with_jac:  # d(a - u)/dq: w x a for the axis, (I - u u^T) v / r for the line
                for c in range(n):
                    wx, wy, wz = jg[3, c], jg[4, c], jg[5, c]
                    vx, vy, vz = jg[0, c], jg[1, c], jg[2, c]
                    uv = u0 * vx + u1 * vy + u2 * vz
                    jac[r, c] = sr * (wy * a2 - wz * a1 + (vx - u0 * uv) / dist)
                    jac[r + 1, c] = sr * (wz * a0 - wx * a2 + (vy - u1 * uv) / dist)
                    jac[r + 2, c] = sr * (wx * a1 - wy * a0 + (vz - u2 * uv) / dist)
            r += 3
    en = 0.0
    for i in range(r):
        en += e[i] * e[i]
    return 0.5 * en




@nb.njit(**NJIT)
def pose_goal_row(pose: np.ndarray, row: np.ndarray, orthonormal: float) -> bool:
    """Whether a pose goal's ``(4, 4)`` transform needs no repair; if so, its packed targets.

    True when every number is finite, the last row is ``0 0 0 1`` and the rotation has
    ``max |R R^T - I| <= orthonormal`` and a positive determinant (the test of
    :func:`armctl.ik.goals._check_rotation`, the same arithmetic); then ``row`` ``(1, 18)``
    receives :meth:`armctl.ik.goals.PoseGoal.packed`. False for anything else, which the goal's
    Python check then refuses or repairs.
    """
    for i in range(3):
        for j in range(4):
            if not math.isfinite(pose[i, j]):
                return False
    if pose[3, 0] != 0.0 or pose[3, 1] != 0.0 or pose[3, 2] != 0.0 or pose[3, 3] != 1.0:
        return False
    x0, x1, x2 = pose[0, 0], pose[0, 1], pose[0, 2]
    y0, y1, y2 = pose[1, 0], pose[1, 1], pose[1, 2]
    z0, z1, z2 = pose[2, 0], pose[2, 1], pose[2, 2]
    off = max(abs(x0 * x0 + x1 * x1 + x2 * x2 - 1.0), abs(y0 * y0 + y1 * y1 + y2 * y2 - 1.0),
              abs(z0 * z0 + z1 * z1 + z2 * z2 - 1.0), abs(x0 * y0 + x1 * y1 + x2 * y2),
              abs(x0 * z0 + x1 * z1 + x2 * z2), abs(y0 * z0 + y1 * z1 + y2 * z2))
    det = x0 * (y1 * z2 - y2 * z1) - x1 * (y0 * z2 - y2 * z0) + x2 * (y0 * z1 - y1 * z0)
    if not off <= orthonormal or det < 0.0:
        return False
    row[0, 0] = pose[0, 3]
    row[0, 1] = pose[1, 3]
    row[0, 2] = pose[2, 3]
    for i in range(3):
        for j in range(3):
            row[0, 3 + 3 * i + j] = pose[i, j]
    for k in range(12, 17):
        row[0, k] = 0.0
    row[0, 17] = 1.0
    return True


use_compiled_checks(pose_row=pose_goal_row)
