"""6R chains with only one pair of meeting axes (5 and 6): a 1-D search over joint 4.

For a fixed ``q4`` the point ``w`` where axes 5 and 6 meet is placed by joints 1-3 in closed
form (:func:`pos3`, up to four branches); axes 5 and 6 can then produce the remaining rotation
``R56 = (R1 R2 R3 R4)^T Rg`` only if ``h5 . R56 h6 = h5 . h6``. That scalar residual is sampled
over a grid of ``q4``; every sign change along a branch (branches are matched between samples by
nearest joint values) is refined by regula falsi, local minima of the residual's magnitude by
golden-section search (double roots), the ends of branches by bisection; ``q5``, ``q6`` follow by
subproblem 1. A root closer than a grid step to another one on the same branch, or on a branch
that jumps between samples, can be missed: unlike the closed forms this search is not proven
complete. The candidates are polished and checked on the exact FK like every other family.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from armctl.ik.analytic._families import pos3
from armctl.ik.analytic._subproblems import dot, mm, mmt, mtm, mtv, mv, rot, rotv, sp1, wrap

#: Grid samples of joint 4 over one turn.
SAMPLES = 512
#: Largest number of candidates kept (before polishing and merging duplicates).
CAPACITY = 64


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _branches(h: np.ndarray, o: np.ndarray, rg: np.ndarray, target: np.ndarray, t4: float,
              ref: np.ndarray, sols: np.ndarray, res: np.ndarray) -> int:
    """Joints 1-3 for ``q4 = t4`` (``sols`` rows) and the residual of each branch (``res``)."""
    w = o[4]
    wq = o[3] + rotv(h[3], t4, w - o[3])
    n, _ = pos3(h, o, wq, target, ref, sols)
    r4 = rot(h[3], t4)
    c56 = dot(h[4], h[5])
    for b in range(n):
        r123 = mm(mm(rot(h[0], sols[b, 0]), rot(h[1], sols[b, 1])), rot(h[2], sols[b, 2]))
        r56 = mtm(mm(r123, r4), rg)
        res[b] = dot(h[4], mv(r56, h[5])) - c56
    return n


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _gap(a: np.ndarray, b: np.ndarray) -> float:
    g = 0.0
    for i in range(3):
        g = max(g, abs(wrap(a[i] - b[i])))
    return g


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _nearest(sols: np.ndarray, n: int, q: np.ndarray) -> int:
    best, bi = 1e300, -1
    for b in range(n):
        g = _gap(sols[b], q)
        if g < best:
            best, bi = g, b
    return bi


@nb.njit(cache=True, nogil=True, error_model="numpy")
def _refine(h: np.ndarray, o: np.ndarray, rg: np.ndarray, target: np.ndarray, ref: np.ndarray,
            a_t: float, b_t: float, lo_q: np.ndarray, hi_q: np.ndarray, ea: float,
            eb: float, best: np.ndarray) -> float:
    """Regula falsi (Illinois) for the residual's root on one branch in ``[a_t, b_t]``.

    The branch is followed by nearest joint values. Returns ``q4``; ``best`` receives q1-3.
    """
    tmp = np.empty((4, 3))
    tmp_e = np.empty(4)
    guess = np.empty(3)
    lo = lo_q.copy()
    hi = hi_q.copy()
    t = a_t
    best[:] = lo
    side = 0
    for _ in range(30):
        if eb == ea:
            break
        t_prev = t
        t = (a_t * eb - b_t * ea) / (eb - ea)
        f = (t - a_t) / (b_t - a_t) if b_t != a_t else 0.0
        for i in range(3):
            guess[i] = lo[i] + f * wrap(hi[i] - lo[i])
        kk = _branches(h, o, rg, target, t, ref, tmp, tmp_e)
        bi = _nearest(tmp, kk, guess)
        if bi < 0:
            break
        et = tmp_e[bi]
        best[:] = tmp[bi]
        if abs(et) < 1e-15 or abs(b_t - a_t) < 1e-14 or abs(t - t_prev) < 1e-13:
            break  # the polish on the exact FK takes it from here
        if et * ea < 0.0:
            b_t, eb, hi[:] = t, et, tmp[bi]
            if side == -1:
                ea *= 0.5
            side = -1
        else:
            a_t, ea, lo[:] = t, et, tmp[bi]
            if side == 1:
                eb *= 0.5
            side = 1
    return t


@nb.njit(cache=True, nogil=True, error_model="numpy")
def one_pair(h: np.ndarray, o: np.ndarray, m: np.ndarray, goal: np.ndarray, ref: np.ndarray,
             out: np.ndarray) -> tuple[int, bool]:
    """6R chain whose axes 5 and 6 meet in ``o[4]`` (and no other family): 1-D search.

    Args:
        h: ``(6, 3)`` axes.
        o: ``(6, 3)`` points on them (``o[4] = o[5]`` the meeting point) [m].
        m: ``(4, 4)`` tool pose at the zero configuration.
        goal: ``(4, 4)`` target pose.
        ref: ``(6,)`` representatives for continua [rad].
        out: ``(CAPACITY, >=6)`` receives the candidates.

    Returns:
        ``(count, singular)``.
    """
    rg = mmt(goal, m)
    wt = mtv(m, o[4] - m[:3, 3])
    target = mv(goal, wt) + goal[:3, 3]
    step = 2.0 * math.pi / SAMPLES
    grid_q = np.empty((SAMPLES + 1, 4, 3))
    grid_e = np.empty((SAMPLES + 1, 4))
    grid_n = np.empty(SAMPLES + 1, dtype=np.int64)
    tmp = np.empty((4, 3))
    tmp_e = np.empty(4)
    for k in range(SAMPLES + 1):
        t4 = -math.pi + k * step
        grid_n[k] = _branches(h, o, rg, target, t4, ref, tmp, tmp_e)
        for b in range(grid_n[k]):
            grid_q[k, b] = tmp[b]
            grid_e[k, b] = tmp_e[b]
    n = 0
    singular = False
    roots = np.empty(CAPACITY)
    rq = np.empty((CAPACITY, 3))
    nr = 0
    best = np.empty(3)
    # 1. where a branch is born or ends between two samples, its part beyond the last sample is
    #    searched too: bisect on the branch count for the boundary, then look for a sign change
    #    between the boundary and the sample on the side where the branch exists
    for k in range(SAMPLES):
        if grid_n[k] == grid_n[k + 1]:
            continue
        a_t, b_t = -math.pi + k * step, -math.pi + (k + 1) * step
        more_at_a = grid_n[k] > grid_n[k + 1]
        fewer = min(grid_n[k], grid_n[k + 1])
        for _ in range(42):  # down to about 1e-14 rad
            t = 0.5 * (a_t + b_t)
            kk = _branches(h, o, rg, target, t, ref, tmp, tmp_e)
            if (kk > fewer) == more_at_a:
                a_t = t
            else:
                b_t = t
        t_in = a_t if more_at_a else b_t
        ks = k if more_at_a else k + 1  # the sample on the side where the branches exist
        t_s = -math.pi + ks * step
        kk = _branches(h, o, rg, target, t_in, ref, tmp, tmp_e)
        for b in range(kk):
            if nr >= CAPACITY:
                break
            twin = False
            for b2 in range(b):
                if _gap(tmp[b2], tmp[b]) < 1e-4:
                    twin = True
            if twin:
                continue  # born together with an earlier branch: the same start
            if abs(tmp_e[b]) < 1e-9:
                roots[nr] = t_in
                rq[nr] = tmp[b]
                nr += 1
                continue
            # branches born together at a fold start from the same point, so the sample's branch
            # that continues this one is ambiguous: try every one with the opposite sign
            for c in range(grid_n[ks]):
                if tmp_e[b] * grid_e[ks, c] > 0.0 or nr >= CAPACITY:
                    continue
                t = _refine(h, o, rg, target, ref, t_in, t_s, tmp[b].copy(),
                            grid_q[ks, c].copy(), tmp_e[b], grid_e[ks, c], best)
                roots[nr] = t
                rq[nr] = best
                nr += 1
    # 2. sign changes along a branch between two samples
    for k in range(SAMPLES):
        for b in range(grid_n[k]):
            c = _nearest(grid_q[k + 1], grid_n[k + 1], grid_q[k, b])
            if c < 0 or _gap(grid_q[k + 1, c], grid_q[k, b]) > 0.5:
                continue  # the branch ends here (workspace boundary) or jumps
            e0, e1 = grid_e[k, b], grid_e[k + 1, c]
            if e0 == 0.0 and k > 0:
                continue  # counted as the end of the previous interval
            if e0 * e1 > 0.0 or nr >= CAPACITY:
                continue
            t = _refine(h, o, rg, target, ref, -math.pi + k * step, -math.pi + (k + 1) * step,
                        grid_q[k, b].copy(), grid_q[k + 1, c].copy(), e0, e1, best)
            roots[nr] = t
            rq[nr] = best
            nr += 1
    # 3. roots where the residual touches zero without changing sign (double roots): local
    #    minima of |residual| along a branch, minimised by golden-section search
    g = 0.5 * (math.sqrt(5.0) - 1.0)
    for k in range(1, SAMPLES):
        for b in range(grid_n[k]):
            cp = _nearest(grid_q[k - 1], grid_n[k - 1], grid_q[k, b])
            cn = _nearest(grid_q[k + 1], grid_n[k + 1], grid_q[k, b])
            if cp < 0 or cn < 0 or nr >= CAPACITY:
                continue
            ep, ek, en = grid_e[k - 1, cp], grid_e[k, b], grid_e[k + 1, cn]
            if ep * ek <= 0.0 or ek * en <= 0.0:
                continue  # a sign change: found in step 2
            if not (abs(ek) <= abs(ep) and abs(ek) <= abs(en) and abs(ek) < 0.05):
                continue
            curv = ep - 2.0 * ek + en  # the parabola through the three samples
            if curv == 0.0:
                continue
            vertex = ek - (en - ep) ** 2 / (8.0 * curv)
            if vertex * ek > 0.0 and abs(vertex) > 0.1 * abs(ek):
                continue  # its minimum stays clearly away from zero
            lo_t, hi_t = -math.pi + (k - 1) * step, -math.pi + (k + 1) * step
            qk = grid_q[k, b].copy()
            for _ in range(45):
                t1 = hi_t - g * (hi_t - lo_t)
                t2 = lo_t + g * (hi_t - lo_t)
                kk = _branches(h, o, rg, target, t1, ref, tmp, tmp_e)
                b1 = _nearest(tmp, kk, qk)
                f1 = abs(tmp_e[b1]) if b1 >= 0 else 1e300
                kk = _branches(h, o, rg, target, t2, ref, tmp, tmp_e)
                b2 = _nearest(tmp, kk, qk)
                f2 = abs(tmp_e[b2]) if b2 >= 0 else 1e300
                if f1 < f2:
                    hi_t = t2
                else:
                    lo_t = t1
            t = 0.5 * (lo_t + hi_t)
            kk = _branches(h, o, rg, target, t, ref, tmp, tmp_e)
            bi = _nearest(tmp, kk, qk)
            if bi >= 0 and abs(tmp_e[bi]) < 1e-6:
                roots[nr] = t
                rq[nr] = tmp[bi]
                nr += 1
    # 4. joints 5 and 6 for every root
    u6 = np.empty(3)
    for r in range(min(nr, out.shape[0])):
        t = roots[r]
        best = rq[r]
        r4 = rot(h[3], t)
        r123 = mm(mm(rot(h[0], best[0]), rot(h[1], best[1])), rot(h[2], best[2]))
        r56 = mtm(mm(r123, r4), rg)
        t5, deg = sp1(h[4], h[5], mv(r56, h[5]), 1e-9)
        if deg:
            t5 = ref[4]
            singular = True
        r6 = mtm(rot(h[4], t5), r56)
        e = np.zeros(3)
        e[np.argmin(np.abs(h[5]))] = 1.0
        cr = np.cross(h[5], e)
        for i in range(3):
            u6[i] = cr[i]
        t6, _ = sp1(h[5], u6, mv(r6, u6), 1e-9)
        out[n, 0], out[n, 1], out[n, 2] = best[0], best[1], best[2]
        out[n, 3], out[n, 4], out[n, 5] = wrap(t), t5, t6
        n += 1
    return n, singular
