"""Goals and models as the flat arrays the compiled solvers use (see :mod:`armctl.ik._engine`)."""

from __future__ import annotations

import math
import os
import random
import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.ik import _engine as E
from armctl.ik.goals import Goal
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["GoalArrays", "ModelArrays", "goal_kernel", "goal_row", "goal_structure",
           "model_arrays", "pack_goals", "seed_state", "seed_value"]


@dataclass(frozen=True)
class ModelArrays:
    """The packed model plus what the solvers derive from it once.

    Attributes:
        lower: Lower limits, C-contiguous [rad]/[m].
        upper: Upper limits.
        continuous: Joints without position limits (wrapped into [-pi, pi] in answers).
        kernel: The ``arm`` argument of :func:`armctl.ik._engine.solve`: the limits and the
            model's compiled tree (``joints``, ``parent``, ``frames``, ``paths``).
        wraps: Whether any joint is continuous.
    """

    lower: Array
    upper: Array
    continuous: npt.NDArray[np.bool_]
    kernel: E.ArmGroup
    wraps: bool


_MODELS: weakref.WeakKeyDictionary[KinematicModel, ModelArrays] = weakref.WeakKeyDictionary()


def model_arrays(model: KinematicModel) -> ModelArrays:
    """The cached :class:`ModelArrays` of a model."""
    got = _MODELS.get(model)
    if got is None:
        lower = np.array(model.lower, dtype=float)
        upper = np.array(model.upper, dtype=float)
        tree = model.tree
        continuous = ~(np.isfinite(lower) & np.isfinite(upper))
        got = ModelArrays(lower, upper, continuous,
                          (lower, upper, tree.joints, tree.parent, tree.frames, tree.paths),
                          bool(continuous.any()))
        _MODELS[model] = got
    return got


@dataclass(frozen=True)
class GoalArrays:
    """Goals packed for :func:`armctl.ik._engine.solve` (see its module docstring)."""

    gf: npt.NDArray[np.int64]
    gt: npt.NDArray[np.int64]
    gd: Array
    gw: Array
    gtol: Array
    mask: npt.NDArray[np.int64]

    @property
    def kernel(self) -> E.GoalGroup:
        """The ``goals`` argument of :func:`armctl.ik._engine.solve`."""
        return self.gf, self.gt, self.gd, self.gw, self.gtol, self.mask


def goal_row(goal: Goal) -> Array:
    """The 18 numbers of one goal's targets (layout in :mod:`armctl.ik._residual`)."""
    return goal.packed()


def goal_type(goal: Goal) -> int:
    """The kernels' code of a goal's kind."""
    return int(goal.kind)


#: One goal set's structure: per goal its frame name, kind, weight and tolerances.
_Key = tuple[tuple[str | None, int, float, float, float], ...]
#: Arrays: ``(gf, gt, gw, gtol, mask)``.
_Structure = tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], Array, Array,
                   npt.NDArray[np.int64]]
#: per model: the packed structure of the goal sets solved recently
_STRUCTURES: weakref.WeakKeyDictionary[KinematicModel, dict[_Key, _Structure]] = (
    weakref.WeakKeyDictionary())
_MAX_STRUCTURES = 256  # per model; the cache starts afresh when full


def goal_structure(model: KinematicModel, goals: Sequence[Goal]) -> _Structure:
    """The arrays of the goals that do not depend on their targets (cached per model).

    The arrays are shared between calls: the kernels only read them.
    """
    key = tuple([(g.frame, g.kind, g.weight, g.tolerance.position, g.tolerance.rotation)
                 for g in goals])
    cache = _STRUCTURES.get(model)
    if cache is None:
        cache = _STRUCTURES[model] = {}
    got = cache.get(key)
    if got is None:
        frames = [model.frame_index(goal.frame) for goal in goals]  # unknown frames raise
        mask = np.zeros((len(goals), model.dof), dtype=np.int64)
        for i, f in enumerate(frames):
            mask[i, model.tree.chain(f)] = 1
        got = (np.array(frames, dtype=np.int64),
               np.array([goal_type(goal) for goal in goals], dtype=np.int64),
               np.array([goal.weight for goal in goals], dtype=float),
               np.array([(g.tolerance.position, g.tolerance.rotation) for g in goals],
                        dtype=float),
               mask)
        if len(cache) >= _MAX_STRUCTURES:
            cache.clear()
        cache[key] = got
    return got


def goal_kernel(model: KinematicModel, goals: Sequence[Goal]) -> E.GoalGroup:
    """The ``goals`` argument of :func:`armctl.ik._engine.solve`.

    What :func:`pack_goals` holds, without the record around it (one object less per call);
    raises InputError for an unknown frame.
    """
    gf, gt, gw, gtol, mask = goal_structure(model, goals)
    gd = np.array(goals[0].packed(), dtype=float, ndmin=2) if len(goals) == 1 else np.array(
        [goal_row(goal) for goal in goals], dtype=float)
    return gf, gt, gd, gw, gtol, mask


def pack_goals(model: KinematicModel, goals: Sequence[Goal]) -> GoalArrays:
    """Pack goals; raises InputError for an unknown frame."""
    return GoalArrays(*goal_kernel(model, goals))


#: Fresh seeds for ``seed=None`` (seeded from the operating system; again in a forked child,
#: so that worker processes do not share their restarts).
_ENTROPY = random.Random()
if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_ENTROPY.seed)


def _seed_bits(seed: int | None) -> int:
    """The 64 bits of the engine's RNG state for a seed (``None``: fresh entropy)."""
    if seed is None:
        return _ENTROPY.getrandbits(64)
    return (int(seed) * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & (2**64 - 1)


def seed_state(seed: int | None) -> npt.NDArray[np.uint64]:
    """The engine's RNG state for a seed (``None``: fresh entropy)."""
    return np.array([_seed_bits(seed)], dtype=np.uint64)


_SIGNED: dict[int, int] = {}  # seed -> seed_value(seed), for the few seeds callers use


def seed_value(seed: int | None) -> int:
    """:func:`seed_state`'s 64 bits as a signed integer (a compiled kernel's ``int64``)."""
    got = _SIGNED.get(seed) if seed is not None else None
    if got is None:
        bits = _seed_bits(seed)
        got = bits - 2**64 if bits >= 2**63 else bits
        if seed is not None and len(_SIGNED) < 64:
            _SIGNED[seed] = got
    return got


def wrap_continuous(q: Array, continuous: npt.NDArray[np.bool_]) -> Array:
    """``q`` with the joints that have no limits wrapped into [-pi, pi)."""
    if continuous.any():  # callers that know the arm has none skip the call
        q = q.copy()
        q[continuous] = (q[continuous] + math.pi) % (2.0 * math.pi) - math.pi
    return q
