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
from armctl.config.schema import JointType
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
    rng = np.random.default_rng(seed)
    if model.multi_dof_joints:  # a ball joint's rotation uniform inside its cone and twist
        return np.asarray(model.sample(rng, count), dtype=float)
    lo, hi = _bounds(model)
    return lo + (hi - lo) * rng.random((count, model.dof))


def _tangent_span(model: KinematicModel) -> np.ndarray:
    """Per tangent entry the width of its range: the limits, a full turn for a ball joint."""
    lo, hi = _bounds(model)
    out = np.empty(model.nv)
    for j, jtype in enumerate(model.joint_types):
        qs, vs = model.q_index(j), model.v_index(j)
        out[vs] = 2.0 * math.pi if jtype is JointType.BALL else (hi - lo)[qs]
    return out


def _quat_batch_exp_mul(quat: np.ndarray, rotvec: np.ndarray) -> np.ndarray:
    """``quat ⊗ exp(rotvec)`` row by row ``(..., 4)``, normalised with ``w >= 0``."""
    angle = np.linalg.norm(rotvec, axis=-1, keepdims=True)
    half = 0.5 * angle
    scale = np.where(angle > 1e-8, np.sin(half) / np.maximum(angle, 1e-300), 0.5)
    bw = np.cos(half)[..., 0]
    bx, by, bz = np.moveaxis(rotvec * scale, -1, 0)
    aw, ax, ay, az = np.moveaxis(quat, -1, 0)
    out = np.stack([aw * bw - ax * bx - ay * by - az * bz,
                    aw * bx + ax * bw + ay * bz - az * by,
                    aw * by - ax * bz + ay * bw + az * bx,
                    aw * bz + ax * by - ay * bx + az * bw], axis=-1)
    out /= np.linalg.norm(out, axis=-1, keepdims=True)
    return np.where(out[..., :1] < 0.0, -out, out)


def _moved(model: KinematicModel, cur: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Configurations ``cur`` ``(..., nq)`` moved by tangent steps ``step`` ``(..., nv)``.

    Kept inside the limits: clipped, a ball joint's rotation projected into its cone and twist.
    """
    lo, hi = _bounds(model)
    if not model.multi_dof_joints:
        return np.clip(cur + step, lo, hi)
    out = np.empty(cur.shape)
    balls = []
    for j, jtype in enumerate(model.joint_types):
        qs, vs = model.q_index(j), model.v_index(j)
        if jtype is JointType.BALL:
            out[..., qs] = _quat_batch_exp_mul(cur[..., qs], step[..., vs])
            balls.append(j)
        else:
            out[..., qs] = np.clip(cur[..., qs] + step[..., vs], lo[qs], hi[qs])
    flat = out.reshape(-1, model.nq)
    outside = np.zeros(len(flat), dtype=bool)
    for j in balls:
        spec = model.spec.joint(model.joint_names[j])
        swing, twist = _swing_twist_batch(flat[:, model.q_index(j)], np.asarray(spec.axis))
        outside |= (swing > spec.swing) | (twist < spec.limits.lower) | (
            twist > spec.limits.upper)
    for r in np.flatnonzero(outside):
        flat[r] = model.clip(flat[r])
    return out


def _swing_twist_batch(quat: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Swing [0, pi] and twist [-pi, pi] angles [rad] of unit quaternions ``(N, 4)``.

    About the unit axis ``a``: ``sin(swing / 2) = |v x a|`` and the twist ``2 atan2(v . a, w)``
    (``v`` the vector part), the split ``q = swing ⊗ twist``.
    """
    w, v = quat[:, 0], quat[:, 1:]
    along = v @ axis
    across = np.linalg.norm(np.cross(v, axis), axis=1)
    swing = 2.0 * np.arcsin(np.minimum(across, 1.0))
    twist = 2.0 * np.arctan2(along, w)
    twist = np.where(twist > math.pi, twist - 2.0 * math.pi, twist)
    twist = np.where(twist < -math.pi, twist + 2.0 * math.pi, twist)
    return swing, twist


def _search_contacts(probe: CollisionModel, owner: np.ndarray, cols: list[int],
                     starts: np.ndarray, model: KinematicModel, seed: int) -> set[int]:
    """The pairs (columns) among ``cols`` that a local search brings into contact.

    From each pair's starts ``(len(cols), K, nq)``, random steps inside the joint limits are
    tried (in the tangent space, ``nv``: a ball joint turns by a random rotation vector); the
    best is kept when it brings the pair closer, and the step shrinks when none does. A pair
    stops when it is in contact or its steps have shrunk to nothing.
    """
    _, per, rounds = _SEARCH
    span = _tangent_span(model)
    rng = np.random.default_rng([seed, 1])
    n, nv = model.nq, model.nv
    cur = np.array(starts, dtype=float)
    nc, k = cur.shape[:2]
    masks = [owner == c for c in cols]
    sl = probe.slacks_batch(cur.reshape(-1, n)).reshape(nc, k, -1)
    val = np.stack([sl[i][..., masks[i]].min(axis=-1) for i in range(nc)])
    step = np.broadcast_to(0.05 * span, (nc, k, nv)).copy()
    found: set[int] = set()
    active = np.arange(nc)
    for _ in range(rounds):
        active = active[[int(i) not in found and bool((step[i] > 1e-4 * span).any())
                         for i in active]]
        if not len(active):
            break
        cand = _moved(model, np.broadcast_to(cur[active, :, None, :], (len(active), k, per, n)),
                      step[active, :, None, :] * rng.standard_normal((len(active), k, per, nv)))
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
        q = (model.named_pose(pose) if model.multi_dof_joints else
             np.array([values.get(j, 0.0) for j in model.joint_names]))
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
