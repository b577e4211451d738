"""Compiled (numba) kernels for forward kinematics and geometric Jacobians.

numba compiles them when the first one is read from this module (see
:mod:`armctl.kinematics._lazy_kernels`); :func:`interpreted` runs them without numba.

The tree is packed into flat arrays by :func:`armctl.kinematics.compiled_tree.compile_tree`
(:class:`~armctl.kinematics.compiled_tree.CompiledTree` documents each array and names its
columns); the kernels take them as plain arguments:

* ``jd`` ``(n, 22)``: :attr:`CompiledTree.joints`: per actuated joint, rows 0-2 of the constant
  transform from the parent joint's frame (or the base) to this joint's frame before its motion
  (12 numbers, row-major 3x4), then the unit axis (3), 1.0 for prismatic / 0.0 for other
  joints, the kind (0 1-DOF, 2 universal, 3 ball), a universal joint's second axis (3), and the
  joint's first index into ``q`` and into tangent vectors (Jacobian columns).
* ``parent`` ``(n,)``: :attr:`CompiledTree.parent`: the index of the parent actuated joint, -1
  for the base.
* ``fd`` ``(m, 12)``: :attr:`CompiledTree.frames`: per named frame, its constant 3x4 offset from
  its anchor joint's frame.
* ``anchor`` ``(m,)``: :attr:`CompiledTree.anchor`: the joint carrying each frame, -1 for the base.
* ``paths`` ``(m, n)``: :attr:`CompiledTree.paths`: per frame, the joints from the base to its
  anchor, padded with -1.

A joint's frame after its motion is ``T_parent @ pre @ M(q)`` where ``M`` is a rotation about the
axis (revolute) or a translation along it (prismatic), two rotations about the two axes
(universal), or the rotation of a unit quaternion (ball). A 1-DOF joint is stepped by
:func:`_step` alone, as fast as before multi-DOF joints existed; the others by
:func:`_step_multi`. A ball joint's three Jacobian columns are ``[w_k x r; w_k]`` for the three
axes ``w_k`` of its moved frame (its tangent is the angular velocity in that frame), a universal
joint's two those of its two axes: the column form of the lecture (L. Kavan, *Metody
skeletální animace*, 2002), singular nowhere.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from armctl.kinematics._lazy_kernels import KernelSet

_ks = KernelSet(__name__)


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _step(t: np.ndarray, row: np.ndarray, qj: float) -> None:
    """``t = t @ pre @ M(qj)`` in place; ``t`` is a 3x4 block."""
    # a = t @ pre
    a00 = t[0, 0] * row[0] + t[0, 1] * row[4] + t[0, 2] * row[8]
    a01 = t[0, 0] * row[1] + t[0, 1] * row[5] + t[0, 2] * row[9]
    a02 = t[0, 0] * row[2] + t[0, 1] * row[6] + t[0, 2] * row[10]
    a10 = t[1, 0] * row[0] + t[1, 1] * row[4] + t[1, 2] * row[8]
    a11 = t[1, 0] * row[1] + t[1, 1] * row[5] + t[1, 2] * row[9]
    a12 = t[1, 0] * row[2] + t[1, 1] * row[6] + t[1, 2] * row[10]
    a20 = t[2, 0] * row[0] + t[2, 1] * row[4] + t[2, 2] * row[8]
    a21 = t[2, 0] * row[1] + t[2, 1] * row[5] + t[2, 2] * row[9]
    a22 = t[2, 0] * row[2] + t[2, 1] * row[6] + t[2, 2] * row[10]
    p0 = t[0, 3] + t[0, 0] * row[3] + t[0, 1] * row[7] + t[0, 2] * row[11]
    p1 = t[1, 3] + t[1, 0] * row[3] + t[1, 1] * row[7] + t[1, 2] * row[11]
    p2 = t[2, 3] + t[2, 0] * row[3] + t[2, 1] * row[7] + t[2, 2] * row[11]
    x, y, z = row[12], row[13], row[14]
    if row[15] > 0.5:  # prismatic: translate along the axis
        t[0, 0], t[0, 1], t[0, 2] = a00, a01, a02
        t[1, 0], t[1, 1], t[1, 2] = a10, a11, a12
        t[2, 0], t[2, 1], t[2, 2] = a20, a21, a22
        t[0, 3] = p0 + (a00 * x + a01 * y + a02 * z) * qj
        t[1, 3] = p1 + (a10 * x + a11 * y + a12 * z) * qj
        t[2, 3] = p2 + (a20 * x + a21 * y + a22 * z) * qj
        return
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
    t[0, 0] = a00 * r00 + a01 * r10 + a02 * r20
    t[0, 1] = a00 * r01 + a01 * r11 + a02 * r21
    t[0, 2] = a00 * r02 + a01 * r12 + a02 * r22
    t[1, 0] = a10 * r00 + a11 * r10 + a12 * r20
    t[1, 1] = a10 * r01 + a11 * r11 + a12 * r21
    t[1, 2] = a10 * r02 + a11 * r12 + a12 * r22
    t[2, 0] = a20 * r00 + a21 * r10 + a22 * r20
    t[2, 1] = a20 * r01 + a21 * r11 + a22 * r21
    t[2, 2] = a20 * r02 + a21 * r12 + a22 * r22
    t[0, 3] = p0
    t[1, 3] = p1
    t[2, 3] = p2


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _axis_rotation(x: float, y: float, z: float, angle: float) -> tuple[
        float, float, float, float, float, float, float, float, float]:
    """The rotation matrix (row-major, 9 numbers) by ``angle`` about the unit axis ``x, y, z``."""
    c = math.cos(angle)
    s = math.sin(angle)
    v = 1.0 - c
    return (c + x * x * v, x * y * v - z * s, x * z * v + y * s,
            y * x * v + z * s, c + y * y * v, y * z * v - x * s,
            z * x * v - y * s, z * y * v + x * s, c + z * z * v)


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _step_multi(t: np.ndarray, row: np.ndarray, q: np.ndarray) -> None:
    """``t = t @ pre @ M`` in place for a universal or ball joint; ``q`` the whole vector."""
    a00 = t[0, 0] * row[0] + t[0, 1] * row[4] + t[0, 2] * row[8]
    a01 = t[0, 0] * row[1] + t[0, 1] * row[5] + t[0, 2] * row[9]
    a02 = t[0, 0] * row[2] + t[0, 1] * row[6] + t[0, 2] * row[10]
    a10 = t[1, 0] * row[0] + t[1, 1] * row[4] + t[1, 2] * row[8]
    a11 = t[1, 0] * row[1] + t[1, 1] * row[5] + t[1, 2] * row[9]
    a12 = t[1, 0] * row[2] + t[1, 1] * row[6] + t[1, 2] * row[10]
    a20 = t[2, 0] * row[0] + t[2, 1] * row[4] + t[2, 2] * row[8]
    a21 = t[2, 0] * row[1] + t[2, 1] * row[5] + t[2, 2] * row[9]
    a22 = t[2, 0] * row[2] + t[2, 1] * row[6] + t[2, 2] * row[10]
    p0 = t[0, 3] + t[0, 0] * row[3] + t[0, 1] * row[7] + t[0, 2] * row[11]
    p1 = t[1, 3] + t[1, 0] * row[3] + t[1, 1] * row[7] + t[1, 2] * row[11]
    p2 = t[2, 3] + t[2, 0] * row[3] + t[2, 1] * row[7] + t[2, 2] * row[11]
    k = int(row[20])
    if row[16] > 2.5:  # ball: the rotation of the quaternion q[k:k+4] (normalised here)
        w, x, y, z = q[k], q[k + 1], q[k + 2], q[k + 3]
        s = 2.0 / (w * w + x * x + y * y + z * z)
        r00 = 1.0 - s * (y * y + z * z)
        r01 = s * (x * y - z * w)
        r02 = s * (x * z + y * w)
        r10 = s * (x * y + z * w)
        r11 = 1.0 - s * (x * x + z * z)
        r12 = s * (y * z - x * w)
        r20 = s * (x * z - y * w)
        r21 = s * (y * z + x * w)
        r22 = 1.0 - s * (x * x + y * y)
    else:  # universal: about the first axis, then about the second in the moved frame
        b00, b01, b02, b10, b11, b12, b20, b21, b22 = _axis_rotation(
            row[12], row[13], row[14], q[k])
        c00, c01, c02, c10, c11, c12, c20, c21, c22 = _axis_rotation(
            row[17], row[18], row[19], q[k + 1])
        r00 = b00 * c00 + b01 * c10 + b02 * c20
        r01 = b00 * c01 + b01 * c11 + b02 * c21
        r02 = b00 * c02 + b01 * c12 + b02 * c22
        r10 = b10 * c00 + b11 * c10 + b12 * c20
        r11 = b10 * c01 + b11 * c11 + b12 * c21
        r12 = b10 * c02 + b11 * c12 + b12 * c22
        r20 = b20 * c00 + b21 * c10 + b22 * c20
        r21 = b20 * c01 + b21 * c11 + b22 * c21
        r22 = b20 * c02 + b21 * c12 + b22 * c22
    t[0, 0] = a00 * r00 + a01 * r10 + a02 * r20
    t[0, 1] = a00 * r01 + a01 * r11 + a02 * r21
    t[0, 2] = a00 * r02 + a01 * r12 + a02 * r22
    t[1, 0] = a10 * r00 + a11 * r10 + a12 * r20
    t[1, 1] = a10 * r01 + a11 * r11 + a12 * r21
    t[1, 2] = a10 * r02 + a11 * r12 + a12 * r22
    t[2, 0] = a20 * r00 + a21 * r10 + a22 * r20
    t[2, 1] = a20 * r01 + a21 * r11 + a22 * r21
    t[2, 2] = a20 * r02 + a21 * r12 + a22 * r22
    t[0, 3] = p0
    t[1, 3] = p1
    t[2, 3] = p2


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _step_any(t: np.ndarray, row: np.ndarray, q: np.ndarray) -> None:
    """``t = t @ pre @ M`` for any joint kind, reading the joint's entries of ``q``."""
    if row[16] == 0.0:
        _step(t, row, q[int(row[20])])
    else:
        _step_multi(t, row, q)


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _nv(jd: np.ndarray) -> int:
    """The length of a tangent vector: the last joint's first column plus its DOF."""
    n = jd.shape[0]
    if n == 0:
        return 0
    kind = jd[n - 1, 16]
    return int(jd[n - 1, 21]) + (1 if kind == 0.0 else (2 if kind < 2.5 else 3))


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _record_axes(t: np.ndarray, row: np.ndarray, q: np.ndarray, w: np.ndarray, o: np.ndarray,
                 pris: np.ndarray, cols: np.ndarray, c: int) -> int:
    """Store the world axes, origin, kind and column of the joint just stepped from slot ``c``.

    Returns the next free slot: ``c`` plus the joint's DOF. ``t`` is the joint's frame after
    its motion: a 1-DOF joint's axis is fixed by its own motion; a ball joint's axes are the
    three columns of ``t``; a universal joint's second axis is ``t @ a2``, its first
    ``t @ R(a2, -q2) @ a1`` (the first axis does not move with the first turn).
    """
    kind = row[16]
    v = int(row[21])
    if kind == 0.0:
        _record_axis(t, row, w, o, c)
        pris[c] = row[15]
        cols[c] = v
        return c + 1
    dof = 3 if kind > 2.5 else 2
    for i in range(dof):
        o[c + i, 0] = t[0, 3]
        o[c + i, 1] = t[1, 3]
        o[c + i, 2] = t[2, 3]
        pris[c + i] = 0.0
        cols[c + i] = v + i
    if dof == 3:
        for i in range(3):
            w[c + i, 0] = t[0, i]
            w[c + i, 1] = t[1, i]
            w[c + i, 2] = t[2, i]
        return c + 3
    x, y, z = row[17], row[18], row[19]
    w[c + 1, 0] = t[0, 0] * x + t[0, 1] * y + t[0, 2] * z
    w[c + 1, 1] = t[1, 0] * x + t[1, 1] * y + t[1, 2] * z
    w[c + 1, 2] = t[2, 0] * x + t[2, 1] * y + t[2, 2] * z
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = _axis_rotation(x, y, z, -q[int(row[20]) + 1])
    a0 = m00 * row[12] + m01 * row[13] + m02 * row[14]
    a1 = m10 * row[12] + m11 * row[13] + m12 * row[14]
    a2 = m20 * row[12] + m21 * row[13] + m22 * row[14]
    w[c, 0] = t[0, 0] * a0 + t[0, 1] * a1 + t[0, 2] * a2
    w[c, 1] = t[1, 0] * a0 + t[1, 1] * a1 + t[1, 2] * a2
    w[c, 2] = t[2, 0] * a0 + t[2, 1] * a1 + t[2, 2] * a2
    return c + 2


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _apply_offset(t: np.ndarray, off: np.ndarray, out: np.ndarray) -> None:
    """``out = [t; 0 0 0 1] @ [off; 0 0 0 1]`` with ``out`` 4x4."""
    for i in range(3):
        t0, t1, t2 = t[i, 0], t[i, 1], t[i, 2]
        out[i, 0] = t0 * off[0] + t1 * off[4] + t2 * off[8]
        out[i, 1] = t0 * off[1] + t1 * off[5] + t2 * off[9]
        out[i, 2] = t0 * off[2] + t1 * off[6] + t2 * off[10]
        out[i, 3] = t[i, 3] + t0 * off[3] + t1 * off[7] + t2 * off[11]
    out[3, 0] = 0.0
    out[3, 1] = 0.0
    out[3, 2] = 0.0
    out[3, 3] = 1.0


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _identity34(t: np.ndarray) -> None:
    for i in range(3):
        for k in range(4):
            t[i, k] = 1.0 if i == k else 0.0


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _record_axis(t: np.ndarray, row: np.ndarray, w: np.ndarray, o: np.ndarray, i: int) -> None:
    """Store the world axis and origin of the joint just stepped (row ``i`` of ``w``, ``o``).

    The axis is fixed by the joint's own motion, so the frame after the step gives it.
    """
    x, y, z = row[12], row[13], row[14]
    w[i, 0] = t[0, 0] * x + t[0, 1] * y + t[0, 2] * z
    w[i, 1] = t[1, 0] * x + t[1, 1] * y + t[1, 2] * z
    w[i, 2] = t[2, 0] * x + t[2, 1] * y + t[2, 2] * z
    o[i, 0] = t[0, 3]
    o[i, 1] = t[1, 3]
    o[i, 2] = t[2, 3]


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _fill_columns(pose: np.ndarray, w: np.ndarray, o: np.ndarray, cols: np.ndarray,
                  prismatic: np.ndarray, depth: int, jac: np.ndarray) -> None:
    """Jacobian columns ``[w x (p - o); w]`` (revolute) or ``[w; 0]`` (prismatic), others 0."""
    jac[:, :] = 0.0
    ex, ey, ez = pose[0, 3], pose[1, 3], pose[2, 3]
    for i in range(depth):
        j = cols[i]
        wx, wy, wz = w[i, 0], w[i, 1], w[i, 2]
        if prismatic[i] > 0.5:
            jac[0, j] = wx
            jac[1, j] = wy
            jac[2, j] = wz
        else:
            rx, ry, rz = ex - o[i, 0], ey - o[i, 1], ez - o[i, 2]
            jac[0, j] = wy * rz - wz * ry
            jac[1, j] = wz * rx - wx * rz
            jac[2, j] = wx * ry - wy * rx
            jac[3, j] = wx
            jac[4, j] = wy
            jac[5, j] = wz


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def fk_into(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, f: int,
            out: np.ndarray) -> None:
    """Pose of frame ``f`` written into ``out`` (4x4)."""
    if q.shape[0] != jd.shape[0]:  # a multi-DOF joint has several entries
        _fk_multi(q, jd, fd, paths, f, out)  # kept out of line: the 1-DOF loop stays small
        return
    t = np.empty((3, 4))
    _identity34(t)
    path = paths[f]
    for k in range(path.shape[0]):
        j = path[k]
        if j < 0:
            break
        _step(t, jd[j], q[j])
    _apply_offset(t, fd[f], out)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _fk_multi(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, f: int,
              out: np.ndarray) -> None:
    """:func:`fk_into` for an arm with universal or ball joints."""
    t = np.empty((3, 4))
    _identity34(t)
    path = paths[f]
    for k in range(path.shape[0]):
        j = path[k]
        if j < 0:
            break
        _step_any(t, jd[j], q)
    _apply_offset(t, fd[f], out)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def fk(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, f: int) -> np.ndarray:
    """Pose ``(4, 4)`` of frame ``f`` at joint vector ``q``."""
    out = np.empty((4, 4))
    fk_into(q, jd, fd, paths, f, out)
    return out


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _fk_jacobian_one(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, f: int,
                     pose: np.ndarray, jac: np.ndarray) -> None:
    """:func:`fk_jacobian_into` for an arm of 1-DOF joints (``q[j]`` is joint ``j``'s value)."""
    n = jd.shape[0]
    t = np.empty((3, 4))
    _identity34(t)
    path = paths[f]
    w = np.empty((n, 3))
    o = np.empty((n, 3))
    prismatic = np.empty(n)
    depth = 0
    for k in range(path.shape[0]):
        j = path[k]
        if j < 0:
            break
        _step(t, jd[j], q[j])
        _record_axis(t, jd[j], w, o, k)
        prismatic[k] = jd[j, 15]
        depth += 1
    _apply_offset(t, fd[f], pose)
    _fill_columns(pose, w, o, path, prismatic, depth, jac)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def fk_jacobian_into(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, f: int,
                     pose: np.ndarray, jac: np.ndarray) -> None:
    """Pose (4x4) and geometric Jacobian (6 x nv, rows [linear; angular]) of frame ``f``."""
    if q.shape[0] == jd.shape[0]:  # 1-DOF joints only: the lean path
        _fk_jacobian_one(q, jd, fd, paths, f, pose, jac)
        return
    _fk_jacobian_multi(q, jd, fd, paths, f, pose, jac)  # out of line: the lean path stays small


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def _fk_jacobian_multi(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray,
                       f: int, pose: np.ndarray, jac: np.ndarray) -> None:
    """:func:`fk_jacobian_into` for an arm with universal or ball joints."""
    n = 3 * jd.shape[0]
    t = np.empty((3, 4))
    _identity34(t)
    path = paths[f]
    w = np.empty((n, 3))
    o = np.empty((n, 3))
    prismatic = np.empty(n)
    cols = np.empty(n, dtype=np.int64)
    depth = 0
    for k in range(path.shape[0]):
        j = path[k]
        if j < 0:
            break
        _step_any(t, jd[j], q)
        depth = _record_axes(t, jd[j], q, w, o, prismatic, cols, depth)
    _apply_offset(t, fd[f], pose)
    _fill_columns(pose, w, o, cols, prismatic, depth, jac)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def jacobian(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray,
             f: int) -> np.ndarray:
    """Geometric Jacobian ``(6, nv)`` of frame ``f``."""
    pose = np.empty((4, 4))
    jac = np.empty((6, _nv(jd)))
    fk_jacobian_into(q, jd, fd, paths, f, pose, jac)
    return jac


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def fk_batch(qs: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray,
             f: int) -> np.ndarray:
    """Poses ``(N, 4, 4)`` of frame ``f`` for joint vectors ``qs`` ``(N, nq)``."""
    out = np.empty((qs.shape[0], 4, 4))
    for i in range(qs.shape[0]):
        fk_into(qs[i], jd, fd, paths, f, out[i])
    return out


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def jacobian_batch(qs: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray,
                   f: int) -> np.ndarray:
    """Jacobians ``(N, 6, nv)`` of frame ``f`` for joint vectors ``qs`` ``(N, nq)``."""
    out = np.empty((qs.shape[0], 6, _nv(jd)))
    pose = np.empty((4, 4))
    for i in range(qs.shape[0]):
        fk_jacobian_into(qs[i], jd, fd, paths, f, pose, out[i])
    return out


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def fk_all(q: np.ndarray, jd: np.ndarray, parent: np.ndarray, anchor: np.ndarray,
           fd: np.ndarray) -> np.ndarray:
    """Poses ``(m, 4, 4)`` of every named frame; ``anchor[f]`` is the frame's joint or -1."""
    n = jd.shape[0]
    one = q.shape[0] == n  # 1-DOF joints only
    world = np.empty((n + 1, 3, 4))  # slot n holds the base (identity)
    _identity34(world[n])
    for j in range(n):
        p = parent[j]
        src = world[n] if p < 0 else world[p]
        for i in range(3):
            for k in range(4):
                world[j, i, k] = src[i, k]
        if one:
            _step(world[j], jd[j], q[j])
        else:
            _step_any(world[j], jd[j], q)
    out = np.empty((fd.shape[0], 4, 4))
    for f in range(fd.shape[0]):
        a = anchor[f]
        _apply_offset(world[n] if a < 0 else world[a], fd[f], out[f])
    return out


# ---- per-frame chain layout, for single calls from Python (fewer arguments to dispatch) -------
# ``rows`` (k + 1, 16): the jd rows of the k joints from the base to the frame's anchor, then the
# frame's 3x4 offset in the first 12 entries of the last row; ``idx`` (k,): those joints' indices.


@_ks.kernel(cache=True, nogil=True, error_model="numpy", inline="always")
def _chain_one(rows: np.ndarray, idx: np.ndarray, k: int) -> bool:
    """Whether the ``k`` joints of a chain take the lean 1-DOF path.

    True when they are 1-DOF joints whose entries of ``q`` and of the tangent are at their own
    joint index (every joint of an arm of 1-DOF joints).
    """
    for i in range(k):
        if rows[i, 16] != 0.0 or rows[i, 20] != idx[i] or rows[i, 21] != idx[i]:
            return False
    return True


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def chain_fk(q: np.ndarray, rows: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Pose ``(4, 4)`` of the frame described by ``rows``/``idx``."""
    t = np.empty((3, 4))
    _identity34(t)
    k = idx.shape[0]
    if _chain_one(rows, idx, k):
        for i in range(k):
            _step(t, rows[i], q[idx[i]])
    else:
        for i in range(k):
            _step_any(t, rows[i], q)
    out = np.empty((4, 4))
    _apply_offset(t, rows[k], out)
    return out


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def chain_fk_jacobian_into(q: np.ndarray, rows: np.ndarray, idx: np.ndarray, pose: np.ndarray,
                           jac: np.ndarray) -> None:
    """Pose (4x4) and geometric Jacobian (6 x dof) of the frame described by ``rows``/``idx``."""
    t = np.empty((3, 4))
    _identity34(t)
    k = idx.shape[0]
    if _chain_one(rows, idx, k):  # 1-DOF joints only: the lean path
        w1 = np.empty((k, 3))
        o1 = np.empty((k, 3))
        for i in range(k):
            _step(t, rows[i], q[idx[i]])
            _record_axis(t, rows[i], w1, o1, i)
        _apply_offset(t, rows[k], pose)
        _fill_columns(pose, w1, o1, idx, rows[:, 15], k, jac)
        return
    w = np.empty((3 * k, 3))
    o = np.empty((3 * k, 3))
    pris = np.empty(3 * k)
    cols = np.empty(3 * k, dtype=np.int64)
    c = 0
    for i in range(k):
        _step_any(t, rows[i], q)
        c = _record_axes(t, rows[i], q, w, o, pris, cols, c)
    _apply_offset(t, rows[k], pose)
    _fill_columns(pose, w, o, cols, pris, c, jac)


@_ks.kernel(cache=True, nogil=True, error_model="numpy")
def chain_jacobian(q: np.ndarray, rows: np.ndarray, idx: np.ndarray, nv: int) -> np.ndarray:
    """Geometric Jacobian ``(6, nv)`` of the frame described by ``rows``/``idx``."""
    pose = np.empty((4, 4))
    jac = np.empty((6, nv))
    chain_fk_jacobian_into(q, rows, idx, pose, jac)
    return jac


_ks.finish(globals())


def __getattr__(name: str) -> Any:
    """A kernel: numba is imported and the kernels compiled when the first one is read."""
    return _ks.getattr(name)


def interpreted(name: str) -> Callable[..., Any]:
    """Kernel ``name`` run by the Python interpreter: same results, nothing to load."""
    return _ks.interpreted(name)
