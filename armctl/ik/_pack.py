"""Goals and models as the flat arrays the compiled solvers use (see :mod:`armctl.ik._engine`)."""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.ik import _engine as E
from armctl.ik.goals import Goal
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["GoalArrays", "ModelArrays", "goal_row", "model_arrays", "pack_goals", "seed_state"]


@dataclass(frozen=True)
class ModelArrays:
    """The packed model plus what the solvers derive from it once.

    Attributes:
        lower: Lower limits, C-contiguous [rad]/[m].
        upper: Upper limits.
        continuous: Joints without position limits (wrapped into [-pi, pi] in answers).
        kernel: The ``arm`` argument of :func:`armctl.ik._engine.solve`: the limits and the
            model's compiled tree (``joints``, ``parent``, ``frames``, ``paths``).
    """

    lower: Array
    upper: Array
    continuous: npt.NDArray[np.bool_]
    kernel: E.ArmGroup


_MODELS: weakref.WeakKeyDictionary[KinematicModel, ModelArrays] = weakref.WeakKeyDictionary()


def model_arrays(model: KinematicModel) -> ModelArrays:
    """The cached :class:`ModelArrays` of a model."""
    got = _MODELS.get(model)
    if got is None:
        lower = np.array(model.lower, dtype=float)
        upper = np.array(model.upper, dtype=float)
        tree = model.tree
        got = ModelArrays(lower, upper, ~(np.isfinite(lower) & np.isfinite(upper)),
                          (lower, upper, tree.joints, tree.parent, tree.frames, tree.paths))
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


_MASKS: weakref.WeakKeyDictionary[KinematicModel, dict[int, npt.NDArray[np.int64]]] = (
    weakref.WeakKeyDictionary())


def _mask_row(model: KinematicModel, f: int) -> npt.NDArray[np.int64]:
    rows = _MASKS.setdefault(model, {})
    row = rows.get(f)
    if row is None:
        row = np.zeros(model.dof, dtype=np.int64)
        row[model.tree.chain(f)] = 1
        rows[f] = row
    return row


def pack_goals(model: KinematicModel, goals: Sequence[Goal]) -> GoalArrays:
    """Pack goals; raises InputError for an unknown frame or goal type."""
    frames = [model.frame_index(goal.frame) for goal in goals]
    return GoalArrays(
        np.array(frames, dtype=np.int64),
        np.array([goal_type(goal) for goal in goals], dtype=np.int64),
        np.array([goal_row(goal) for goal in goals]),
        np.array([goal.weight for goal in goals], dtype=float),
        np.array([(g.tolerance.position, g.tolerance.rotation) for g in goals], dtype=float),
        np.array([_mask_row(model, f) for f in frames]),
    )


def seed_state(seed: int | None) -> npt.NDArray[np.uint64]:
    """The engine's RNG state for a seed (``None``: fresh entropy)."""
    if seed is None:
        value = int(np.random.SeedSequence().entropy) & (2**64 - 1)  # type: ignore[arg-type]
    else:
        value = (int(seed) * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & (2**64 - 1)
    return np.array([value], dtype=np.uint64)


def wrap_continuous(q: Array, continuous: npt.NDArray[np.bool_]) -> Array:
    """``q`` with the joints that have no limits wrapped into [-pi, pi)."""
    if continuous.any():
        q = q.copy()
        q[continuous] = (q[continuous] + math.pi) % (2.0 * math.pi) - math.pi
    return q
