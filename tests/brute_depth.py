"""Brute-force penetration depth of a segment in a box, shared by the distance tests.

(A plain module, imported by name like ``armctl_testpaths``.)
"""

from __future__ import annotations

import numpy as np


def segment_box_depth(ends: np.ndarray, half: np.ndarray) -> float:
    """The least translation that takes a segment out of a centred, axis-aligned box, by search.

    Along a unit direction ``n`` the segment (``ends``, ``(2, 3)`` in the box frame) must move
    ``min(max(n.p) + r, r - min(n.p))`` (``r = sum(half |n|)``) to leave the box; the depth is
    the least of that over every direction: dense directions on the sphere, then a shrinking
    random search around the best. Never below the true depth; close above it.
    """
    def overlap(n: np.ndarray) -> np.ndarray:
        n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        p = n @ ends.T
        r = np.abs(n) @ half
        return np.minimum(p.max(axis=-1) + r, r - p.min(axis=-1))

    k = np.arange(40000) + 0.5
    phi = np.arccos(1.0 - 2.0 * k / len(k))
    theta = np.pi * (1.0 + 5.0 ** 0.5) * k
    dirs = np.stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)], 1)
    vals = overlap(dirs)
    best_n, best = dirs[int(np.argmin(vals))], float(vals.min())
    rng = np.random.default_rng(0)
    step = 0.05
    for _ in range(60):
        cand = best_n + step * rng.normal(size=(200, 3))
        v = overlap(cand)
        if float(v.min()) < best:
            best, best_n = float(v.min()), cand[int(np.argmin(v))]
        step *= 0.85
    return best
