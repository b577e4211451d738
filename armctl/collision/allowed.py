"""The allowed-collision matrix: which link pairs are not checked, found by sampling.

As a robot's setup assistant does, random configurations inside the joint limits are checked
with every pair enabled, and a pair of links (or a link and the table) is left out when it is

* **adjacent**: the two links are joined by a joint (they touch at the joint by design);
* **always** in contact: in at least :data:`ALWAYS_FRACTION` of the samples (their shapes
  overlap whatever the joints do);
* **never** in contact: in none of the samples (no configuration brings them together), and
  a local search from the samples where the pair came closest does not bring it into contact
  either (a pair that touches only in a small region of the joint space, such as the two
  hands of a two-armed robot, is easily missed by uniform samples);
* in contact at one of the arm's named poses (**default**: ``park`` is often folded so that
  the links' capsules, which are larger than the links, overlap; the arm must be able to start
  and end there).

Every other pair is checked. The result is an ordinary
:class:`~armctl.config.scene.CollisionSpec`: ``armctl collisions CONFIG --generate`` prints it
or writes it into the arm's file as its ``collision:`` section, with a reason per pair.
"""

from __future__ import annotations

import logging
import math
import weakref

import numpy as np

from armctl.collision.model import CollisionModel, register_finder, scene_of
from armctl.config.scene import TABLE, AllowedPair, AllowReason, CollisionSpec, SceneSpec
from armctl.kinematics.model import KinematicModel

__all__ = ["ALWAYS_FRACTION", "DEFAULT_SAMPLES", "adjacent_pairs", "allowed_pairs",
           "generate_allowed"]

logger = logging.getLogger(__name__)

#: A pair in contact in at least this fraction of the samples is "always" in contact.
ALWAYS_FRACTION = 0.95
#: Random configurations sampled by default.
DEFAULT_SAMPLES = 20000
#: Local search for a contact of a pair that no sample brought into contact: starts (the
#: samples where the pair came closest), candidates per start and round, rounds.
_SEARCH = (4, 16, 60)


def adjacent_pairs(model: KinematicModel) -> dict[frozenset[str], str]:
    """Link pairs joined by a joint (fixed joints included) -> the joint's name."""
    return {frozenset((j.parent, j.child)): j.name for j in model.spec.joints}


def _bounds(model: KinematicModel) -> tuple[np.ndarray, np.ndarray]:
    lo = np.where(np.isfinite(model.tree.lower), model.tree.lower, -math.pi)
    hi = np.where(np.isfinite(model.tree.upper), model.tree.upper, math.pi)
    return lo, hi


def _sample(model: KinematicModel, count: int, seed: int) -> np.ndarray:
    lo, hi = _bounds(model)
    rng = np.random.default_rng(seed)
    return lo + (hi - lo) * rng.random((count, model.dof))


def _search_contacts(probe: CollisionModel, owner: np.ndarray, cols: list[int],
                     starts: np.ndarray, model: KinematicModel, seed: int) -> set[int]:
    """The pairs (columns) among ``cols`` that a local search brings into contact.

    From each pair's starts ``(len(cols), K, dof)``, random steps inside the joint limits are
    tried; the best is kept when it brings the pair closer, and the step shrinks when none
    does. A pair stops when it is in contact or its steps have shrunk to nothing.
    """
    _, per, rounds = _SEARCH
    lo, hi = _bounds(model)
    rng = np.random.default_rng([seed, 1])
    n = model.dof
    cur = np.array(starts, dtype=float)
    nc, k = cur.shape[:2]
    masks = [owner == c for c in cols]
    sl = probe.slacks_batch(cur.reshape(-1, n)).reshape(nc, k, -1)
    val = np.stack([sl[i][..., masks[i]].min(axis=-1) for i in range(nc)])
    step = np.broadcast_to(0.05 * (hi - lo), cur.shape).copy()
    found: set[int] = set()
    active = np.arange(nc)
    for _ in range(rounds):
        active = active[[int(i) not in found and bool((step[i] > 1e-4 * (hi - lo)).any())
                         for i in active]]
        if not len(active):
            break
        cand = np.clip(cur[active, :, None, :] + step[active, :, None, :]
                       * rng.standard_normal((len(active), k, per, n)), lo, hi)
        tried = probe.slacks_batch(cand.reshape(-1, n)).reshape(len(active), k, per, -1)
        for row, i in enumerate(active):
            v = tried[row][..., masks[i]].min(axis=-1)  # (k, per)
            pick = v.argmin(axis=1)
            best = v[np.arange(k), pick]
            better = best < val[i]
            cur[i][better] = cand[row][np.arange(k), pick][better]
            val[i] = np.minimum(val[i], best)
            step[i][~better] *= 0.7
            if (val[i] < 0.0).any():
                found.add(int(i))
    return {cols[i] for i in found}


def generate_allowed(model: KinematicModel, scene: SceneSpec | None = None, *,
                     samples: int = DEFAULT_SAMPLES, seed: int = 0) -> CollisionSpec:
    """Find the pairs that need no check by sampling random configurations.

    Args:
        model: The arm.
        scene: Its scene (only its table is used: obstacles are always checked); ``None``: the
            arm's scene or the default table.
        samples: How many random configurations (uniform inside the joint limits; continuous
            joints over one turn).
        seed: Random seed (the same seed gives the same matrix).

    Returns:
        The allowed pairs, adjacent first, then always, default and never, each sorted by
        name.
    """
    if samples < 1:
        raise ValueError(f"samples must be >= 1, got {samples}")
    sc = scene_of(model) if scene is None else scene
    probe = CollisionModel(model, SceneSpec(table=sc.table, obstacles=(), padding=0.0),
                           CollisionSpec())
    names = [probe.pair_names(i) for i in range(probe.pair_count)]
    keys = sorted({frozenset((a, b)) for a, b, _ in names}, key=lambda k: sorted(k))
    column = {k: i for i, k in enumerate(keys)}
    owner = np.array([column[frozenset((a, b))] for a, b, _ in names], dtype=np.int64)
    hits = np.zeros(len(keys), dtype=np.int64)
    qs = _sample(model, samples, seed)
    keep = min(_SEARCH[0], samples)
    closest = np.full((keep, len(keys)), np.inf)  # each pair's least slacks so far [m]
    closest_at = np.zeros((keep, len(keys)), dtype=np.int64)  # and their samples
    for start in range(0, samples, 4096):
        sl = probe.slacks_batch(qs[start:start + 4096])
        per_key = np.stack([sl[:, owner == col].min(axis=1) for col in range(len(keys))],
                           axis=1)
        hits += (per_key < 0.0).sum(axis=0)
        vals = np.concatenate([closest, per_key])
        at = np.concatenate([closest_at, np.broadcast_to(
            start + np.arange(len(per_key))[:, None], per_key.shape)])
        pick = np.argsort(vals, axis=0, kind="stable")[:keep]
        closest = np.take_along_axis(vals, pick, axis=0)
        closest_at = np.take_along_axis(at, pick, axis=0)
    adjacent = adjacent_pairs(model)
    posed: dict[frozenset[str], str] = {}
    for pose, values in model.spec.poses.items():
        q = np.array([values.get(j, 0.0) for j in model.joint_names])
        for i in np.flatnonzero(probe.slacks(q) < 0.0):
            a, b, _ = names[int(i)]
            posed.setdefault(frozenset((a, b)), pose)
    unseen = [column[k] for k in keys
              if hits[column[k]] == 0 and k not in adjacent and k not in posed]
    touching = _search_contacts(probe, owner, unseen, qs[closest_at[:, unseen].T], model,
                                seed) if unseen else set()
    for col in sorted(touching):
        logger.info("%s: no contact in %d samples, but a local search found one: checked",
                    " / ".join(sorted(keys[col])), samples)
    out: dict[AllowReason, list[AllowedPair]] = {r: [] for r in AllowReason}
    for key, count in zip(keys, hits, strict=True):
        a, b = sorted(key, key=lambda s: (s == TABLE, s))
        if key in adjacent:
            out[AllowReason.ADJACENT].append(
                AllowedPair(a, b, AllowReason.ADJACENT, f"joined by joint {adjacent[key]!r}"))
        elif count >= ALWAYS_FRACTION * samples:
            out[AllowReason.ALWAYS].append(AllowedPair(
                a, b, AllowReason.ALWAYS, f"in contact in {100.0 * count / samples:.1f} % of "
                f"{samples} samples"))
        elif key in posed:
            out[AllowReason.DEFAULT].append(AllowedPair(
                a, b, AllowReason.DEFAULT, f"in contact at pose {posed[key]!r}"))
        elif count == 0 and column[key] not in touching:
            out[AllowReason.NEVER].append(
                AllowedPair(a, b, AllowReason.NEVER, f"no contact in {samples} samples"))
    pairs = tuple(p for r in (AllowReason.ADJACENT, AllowReason.ALWAYS, AllowReason.DEFAULT,
                              AllowReason.NEVER)
                  for p in sorted(out[r], key=lambda p: (p.a, p.b)))
    return CollisionSpec(pairs, samples)


_GENERATED: weakref.WeakKeyDictionary[KinematicModel, dict[float | None, CollisionSpec]] = (
    weakref.WeakKeyDictionary())


def allowed_pairs(model: KinematicModel, scene: SceneSpec) -> CollisionSpec:
    """The arm's matrix: its ``collision:`` section, else one generated (once per arm and table).

    Args:
        model: The arm.
        scene: The scene in force (its table decides the table pairs of a generated matrix).
    """
    if model.spec.collision is not None:
        return model.spec.collision
    height = None if scene.table is None else scene.table.height
    per_model = _GENERATED.setdefault(model, {})
    if height not in per_model:
        logger.info("arm %r has no collision: section; sampling %d configurations for its "
                    "allowed-collision matrix ('armctl collisions CONFIG --generate --write' "
                    "stores one)", model.name, DEFAULT_SAMPLES)
        per_model[height] = generate_allowed(model, scene)
    return per_model[height]


register_finder(allowed_pairs)
