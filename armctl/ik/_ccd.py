"""Compiled cyclic coordinate descent: the closed-form angle per joint.

The step follows the CCD derivation of the lecture (L. Kavan, *Metody skeletální animace*, 2002).
CCD has forms for position, orientation, direction and pose goals; other kinds (look-at)
contribute nothing here, and the solver registry refuses them for ``ccd`` and ``ccd-jt``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from armctl.ik._residual import DIRECTION, NJIT, ORIENTATION, POSE, has_position
from armctl.kinematics._kernels import _step, fk_into


@nb.njit(**NJIT)
def ccd_coefficients(w: np.ndarray, o: np.ndarray, gt: np.ndarray, gd: np.ndarray,
                     gw: np.ndarray, mask: np.ndarray, j: int, pose: np.ndarray,
                     rho2: float, w1: float = 1.0) -> tuple[float, float, float]:
    """``k1, k2, k3`` of ``g(t) = k1 (1 - cos t) + k2 cos t + k3 sin t`` for revolute joint ``j``.

    ``g`` is the lecture's objective ``w1 g1 + w2 g2`` summed over the goals that ``j`` moves:
    ``g1`` the dot product of the joint-to-goal and rotated joint-to-effector vectors, ``g2`` the
    sum over the constrained axes of goal-axis . rotated current axis; ``w1`` is the goal weight
    times ``w1`` (1 by default) and ``w2`` the goal weight times ``rho2`` [m^2]. Rotating a
    vector ``a`` about the unit axis ``w`` by ``t`` (Rodrigues) gives
    ``b . R a = (w.a)(w.b)(1 - cos t) + (a.b) cos t + b.(w x a) sin t``.
    """
    k1 = 0.0
    k2 = 0.0
    k3 = 0.0
    for g in range(gt.shape[0]):
        if mask[g, j] == 0:
            continue
        t = gt[g]
        p = pose[g]
        for part in range(4):
            # part 0: position; 1-3: orientation axes (all three for orientation/pose goals,
            # the tool axis for a direction goal)
            if part == 0:
                if not has_position(t) or w1 == 0.0:
                    continue
                wt = gw[g] * w1
                a0, a1, a2 = p[0, 3] - o[0], p[1, 3] - o[1], p[2, 3] - o[2]
                b0, b1, b2 = gd[g, 0] - o[0], gd[g, 1] - o[1], gd[g, 2] - o[2]
            elif t == ORIENTATION or t == POSE:
                c = part - 1
                wt = gw[g] * rho2
                a0, a1, a2 = p[0, c], p[1, c], p[2, c]
                b0, b1, b2 = gd[g, 3 + c], gd[g, 6 + c], gd[g, 9 + c]
            elif t == DIRECTION and part == 1:
                wt = gw[g] * rho2
                ax = gd[g, 15:18]
                a0 = p[0, 0] * ax[0] + p[0, 1] * ax[1] + p[0, 2] * ax[2]
                a1 = p[1, 0] * ax[0] + p[1, 1] * ax[1] + p[1, 2] * ax[2]
                a2 = p[2, 0] * ax[0] + p[2, 1] * ax[1] + p[2, 2] * ax[2]
                b0, b1, b2 = gd[g, 12], gd[g, 13], gd[g, 14]
            else:
                continue
            wa = w[0] * a0 + w[1] * a1 + w[2] * a2
            wb = w[0] * b0 + w[1] * b1 + w[2] * b2
            k1 += wt * wa * wb
            k2 += wt * (a0 * b0 + a1 * b1 + a2 * b2)
            # b . (w x a)
            k3 += wt * (b0 * (w[1] * a2 - w[2] * a1) + b1 * (w[2] * a0 - w[0] * a2)
                        + b2 * (w[0] * a1 - w[1] * a0))
    return k1, k2, k3


@nb.njit(**NJIT)
def ccd_angle(k1: float, k2: float, k3: float, lo: float, hi: float) -> float:
    """The turn ``t`` in ``[lo, hi]`` that maximises ``k1 (1 - cos t) + k2 cos t + k3 sin t``.

    Unconstrained, ``dg/dt = 0`` gives ``tan t = k3 / (k2 - k1)``; of the two roots the maximum
    is ``atan2(k3, k2 - k1)``. ``g`` has a single maximum on the circle, so when no copy of it
    (``+- 2 pi``) lies in ``[lo, hi]`` the better end of the interval is the constrained maximum.
    """
    t = math.atan2(k3, k2 - k1)
    for cand in (t, t - 2.0 * math.pi, t + 2.0 * math.pi):
        if lo <= cand <= hi:
            return cand
    glo = k1 * (1.0 - math.cos(lo)) + k2 * math.cos(lo) + k3 * math.sin(lo)
    ghi = k1 * (1.0 - math.cos(hi)) + k2 * math.cos(hi) + k3 * math.sin(hi)
    return lo if glo >= ghi else hi


@nb.njit(**NJIT)
def joint_frames(q: np.ndarray, jd: np.ndarray, parent: np.ndarray, world: np.ndarray) -> None:
    """World 3x4 frame of every joint after its motion, ``world`` ``(n, 3, 4)``."""
    for j in range(jd.shape[0]):
        p = parent[j]
        for i in range(3):
            for k in range(4):
                if p < 0:
                    world[j, i, k] = 1.0 if i == k else 0.0
                else:
                    world[j, i, k] = world[p, i, k]
        _step(world[j], jd[j], q[j])


@nb.njit(**NJIT)
def _ccd_sweep(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray,
               parent: np.ndarray, fd: np.ndarray, paths: np.ndarray, gf: np.ndarray,
               gt: np.ndarray, gd: np.ndarray, gw: np.ndarray, mask: np.ndarray, rho2: float,
               world: np.ndarray, pose: np.ndarray, w1: float = 1.0) -> None:
    """One CCD sweep over the joints from the tips to the base.

    ``w1`` and ``rho2`` [m^2] weight the position and orientation terms (:func:`ccd_coefficients`);
    a prismatic joint slides for the position alone, so not at all when ``w1`` is 0.

    Joints are visited in decreasing index; parents come first in the joint order, so turning
    joint ``j`` never moves the axis of a joint visited later, and the goal poses are updated
    in closed form after each turn.
    """
    n = q.shape[0]
    joint_frames(q, jd, parent, world)
    for g in range(gf.shape[0]):
        fk_into(q, jd, fd, paths, gf[g], pose[g])
    w = np.empty(3)
    o = np.empty(3)
    for j in range(n - 1, -1, -1):
        ax = jd[j, 12:15]
        for i in range(3):
            w[i] = world[j, i, 0] * ax[0] + world[j, i, 1] * ax[1] + world[j, i, 2] * ax[2]
            o[i] = world[j, i, 3]
        if jd[j, 15] > 0.5:  # prismatic: the closed-form least-squares slide along w
            if w1 == 0.0:
                continue
            num = 0.0
            den = 0.0
            for g in range(gf.shape[0]):
                if mask[g, j] == 0 or not has_position(gt[g]):
                    continue
                num += gw[g] * (w[0] * (gd[g, 0] - pose[g, 0, 3])
                                + w[1] * (gd[g, 1] - pose[g, 1, 3])
                                + w[2] * (gd[g, 2] - pose[g, 2, 3]))
                den += gw[g]
            if den == 0.0:
                continue
            t = min(max(num / den, lower[j] - q[j]), upper[j] - q[j])
            q[j] += t
            for g in range(gf.shape[0]):
                if mask[g, j] != 0:
                    for i in range(3):
                        pose[g, i, 3] += t * w[i]
            continue
        k1, k2, k3 = ccd_coefficients(w, o, gt, gd, gw, mask, j, pose, rho2, w1)
        # a joint that cannot change the objective (e.g. a roll axis through the goal point of
        # a position goal) has k2 - k1 = k3 = 0 up to round-off: leave it where it is
        if math.hypot(k3, k2 - k1) <= 1e-12 * (abs(k1) + abs(k2) + abs(k3)) + 1e-300:
            continue
        t = ccd_angle(k1, k2, k3, lower[j] - q[j], upper[j] - q[j])
        if t == 0.0:
            continue
        q[j] += t
        c = math.cos(t)
        s = math.sin(t)
        v = 1.0 - c
        x, y, z = w[0], w[1], w[2]
        r00, r01, r02 = c + x * x * v, x * y * v - z * s, x * z * v + y * s
        r10, r11, r12 = y * x * v + z * s, c + y * y * v, y * z * v - x * s
        r20, r21, r22 = z * x * v - y * s, z * y * v + x * s, c + z * z * v
        for g in range(gf.shape[0]):
            if mask[g, j] == 0:
                continue
            p = pose[g]
            for col in range(4):
                if col == 3:
                    a0, a1, a2 = p[0, 3] - o[0], p[1, 3] - o[1], p[2, 3] - o[2]
                else:
                    a0, a1, a2 = p[0, col], p[1, col], p[2, col]
                b0 = r00 * a0 + r01 * a1 + r02 * a2
                b1 = r10 * a0 + r11 * a1 + r12 * a2
                b2 = r20 * a0 + r21 * a1 + r22 * a2
                if col == 3:
                    b0 += o[0]
                    b1 += o[1]
                    b2 += o[2]
                p[0, col], p[1, col], p[2, col] = b0, b1, b2


