"""Compiled secondary objectives for the null space and their gradients.

They are the secondary criteria of the lecture's redundancy step (L. Kavan, *Metody skeletální
animace*, 2002): ``dz`` in ``dq = J^+ dx + (I - J^+ J) dz`` descends them.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from armctl.ik._residual import NJIT
from armctl.kinematics._kernels import fk_into, fk_jacobian_into

# null-space weights ``nsw``: posture, joint-limit avoidance, keep-out spheres, manipulability
NS_POSTURE, NS_LIMITS, NS_SPHERES, NS_MANIP = 0, 1, 2, 3


@nb.njit(**NJIT)
def _manipulability(q: np.ndarray, jd: np.ndarray, fd: np.ndarray, paths: np.ndarray, f: int,
                    pose: np.ndarray, jg: np.ndarray, a: np.ndarray) -> float:
    """``sqrt(det(J J^T))`` (or ``J^T J`` when the arm has fewer than 6 joints) of frame ``f``."""
    fk_jacobian_into(q, jd, fd, paths, f, pose, jg)
    n = q.shape[0]
    k = min(6, n)
    for i in range(k):
        for j in range(i + 1):
            s = 0.0
            if n >= 6:
                for c in range(n):
                    s += jg[i, c] * jg[j, c]
            else:
                for r in range(6):
                    s += jg[r, i] * jg[r, j]
            a[i, j] = s
            a[j, i] = s
    det = 1.0
    for j in range(k):  # Cholesky pivots
        s = a[j, j]
        for p in range(j):
            s -= a[j, p] * a[j, p]
        if s <= 0.0:
            return 0.0
        d = math.sqrt(s)
        a[j, j] = d
        det *= d
        for i in range(j + 1, k):
            s = a[i, j]
            for p in range(j):
                s -= a[i, p] * a[j, p]
            a[i, j] = s / d
    return det


@nb.njit(**NJIT)
def ns_objective(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray,
                 fd: np.ndarray, paths: np.ndarray, nsw: np.ndarray, pref: np.ndarray,
                 spheres: np.ndarray, mframe: int, pose: np.ndarray, jg: np.ndarray,
                 a: np.ndarray) -> float:
    """The secondary objective ``h(q)`` to minimise in the null space.

    ``h = w_p |q - q_pref|^2 / 2 + w_l sum((q - mid) / half_range)^2 / 2
    + w_s sum_spheres max(0, r - |p - c|)^2 / 2 - w_m sqrt(det(J J^T))``.
    """
    h = 0.0
    n = q.shape[0]
    if nsw[NS_POSTURE] != 0.0:
        s = 0.0
        for i in range(n):
            s += (q[i] - pref[i]) ** 2
        h += nsw[NS_POSTURE] * 0.5 * s
    if nsw[NS_LIMITS] != 0.0:
        s = 0.0
        for i in range(n):
            if math.isfinite(lower[i]) and math.isfinite(upper[i]) and upper[i] > lower[i]:
                s += ((q[i] - 0.5 * (lower[i] + upper[i])) / (0.5 * (upper[i] - lower[i]))) ** 2
        h += nsw[NS_LIMITS] * 0.5 * s
    if nsw[NS_SPHERES] != 0.0:
        s = 0.0
        for k in range(spheres.shape[0]):
            fk_into(q, jd, fd, paths, int(spheres[k, 0]), pose)
            d = math.sqrt((pose[0, 3] - spheres[k, 1]) ** 2 + (pose[1, 3] - spheres[k, 2]) ** 2
                          + (pose[2, 3] - spheres[k, 3]) ** 2)
            if d < spheres[k, 4]:
                s += (spheres[k, 4] - d) ** 2
        h += nsw[NS_SPHERES] * 0.5 * s
    if nsw[NS_MANIP] != 0.0:
        h -= nsw[NS_MANIP] * _manipulability(q, jd, fd, paths, mframe, pose, jg, a)
    return h


@nb.njit(**NJIT)
def _ns_gradient(q: np.ndarray, lower: np.ndarray, upper: np.ndarray, jd: np.ndarray,
                 fd: np.ndarray, paths: np.ndarray, nsw: np.ndarray, pref: np.ndarray,
                 spheres: np.ndarray, mframe: int, pose: np.ndarray, jg: np.ndarray,
                 a: np.ndarray, grad: np.ndarray) -> None:
    """Gradient of :func:`ns_objective` (analytic, finite differences for manipulability)."""
    n = q.shape[0]
    for i in range(n):
        grad[i] = 0.0
        if nsw[NS_POSTURE] != 0.0:
            grad[i] += nsw[NS_POSTURE] * (q[i] - pref[i])
        if nsw[NS_LIMITS] != 0.0 and math.isfinite(lower[i]) and math.isfinite(upper[i]) \
                and upper[i] > lower[i]:
            half = 0.5 * (upper[i] - lower[i])
            grad[i] += nsw[NS_LIMITS] * (q[i] - 0.5 * (lower[i] + upper[i])) / (half * half)
    if nsw[NS_SPHERES] != 0.0:
        for k in range(spheres.shape[0]):
            fk_jacobian_into(q, jd, fd, paths, int(spheres[k, 0]), pose, jg)
            d0 = pose[0, 3] - spheres[k, 1]
            d1 = pose[1, 3] - spheres[k, 2]
            d2 = pose[2, 3] - spheres[k, 3]
            d = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
            if d < spheres[k, 4] and d > 1e-12:
                f = -nsw[NS_SPHERES] * (spheres[k, 4] - d) / d
                for c in range(n):
                    grad[c] += f * (jg[0, c] * d0 + jg[1, c] * d1 + jg[2, c] * d2)
    if nsw[NS_MANIP] != 0.0:
        qq = q.copy()
        h = 1e-6
        for c in range(n):
            qq[c] = q[c] + h
            mp = _manipulability(qq, jd, fd, paths, mframe, pose, jg, a)
            qq[c] = q[c] - h
            mm = _manipulability(qq, jd, fd, paths, mframe, pose, jg, a)
            qq[c] = q[c]
            grad[c] -= nsw[NS_MANIP] * (mp - mm) / (2.0 * h)


