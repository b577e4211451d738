"""Goals and models as the flat arrays the compiled solvers use (see :mod:`armctl.ik._engine`)."""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.ik import _engine as E
from armctl.ik.goals import DirectionGoal, Goal, OrientationGoal, PoseGoal, PositionGoal
from armctl.kinematics.model import KinematicModel

__all__ = ["GoalArrays", "ModelArrays", "goal_row", "model_arrays", "pack_goals", "seed_state"]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class ModelArrays:
    """The packed model plus what the solvers derive from it once.

    Attributes:
        lower: Lower limits, C-contiguous [rad]/[m].
        upper: Upper limits.
        reach: An upper bound of the distance from the base to any frame [m].
        continuous: Joints without position limits (wrapped into [-pi, pi] in answers).
    """

    lower: Array
    upper: Array
    reach: float
    continuous: npt.NDArray[np.bool_]


_MODELS: weakref.WeakKeyDictionary[KinematicModel, ModelArrays] = weakref.WeakKeyDictionary()


def model_arrays(model: KinematicModel) -> ModelArrays:
    """The cached :class:`ModelArrays` of a model."""
    got = _MODELS.get(model)
    if got is None:
        jd, fd = model._jd, model._fd
        reach = float(np.linalg.norm(jd[:, [3, 7, 11]], axis=1).sum())
        reach += float(np.linalg.norm(fd[:, [3, 7, 11]], axis=1).max(initial=0.0))
        prismatic = jd[:, 15] > 0.5
        if prismatic.any():
            span = np.where(np.isfinite(model.upper - model.lower), model.upper - model.lower, 0)
            reach += float(np.abs(span[prismatic]).sum())
        got = ModelArrays(np.array(model.lower, dtype=float),
                          np.array(model.upper, dtype=float), max(reach, 1e-3),
                          ~(np.isfinite(model.lower) & np.isfinite(model.upper)))
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


def goal_row(goal: Goal) -> Array:
    """The 18 numbers of one goal's target (layout in :mod:`armctl.ik._engine`)."""
    row = np.zeros(18)
    row[17] = 1.0  # default tool axis z
    if isinstance(goal, PositionGoal):
        row[0:3] = goal.position
    elif isinstance(goal, OrientationGoal):
        row[3:12] = goal.rotation.ravel()
    elif isinstance(goal, DirectionGoal):
        row[0:3] = goal.position
        row[12:15] = goal.direction
        row[15:18] = goal.axis
    elif isinstance(goal, PoseGoal):
        row[0:3] = goal.pose[:3, 3]
        row[3:12] = goal.pose[:3, :3].ravel()
    else:
        raise InputError(f"the numerical solvers do not handle goals of type {type(goal).__name__}")
    return row


_TYPES: dict[type, int] = {PositionGoal: E.POSITION, OrientationGoal: E.ORIENTATION,
                           DirectionGoal: E.DIRECTION, PoseGoal: E.POSE}


def goal_type(goal: Goal) -> int:
    """The engine's code of a goal's type."""
    code = _TYPES.get(type(goal))
    if code is not None:
        return code
    for cls, c in _TYPES.items():  # subclasses
        if isinstance(goal, cls):
            return c
    raise InputError(f"the numerical solvers do not handle goals of type {type(goal).__name__}")


_MASKS: weakref.WeakKeyDictionary[KinematicModel, dict[int, npt.NDArray[np.int64]]] = (
    weakref.WeakKeyDictionary())


def _mask_row(model: KinematicModel, f: int) -> npt.NDArray[np.int64]:
    rows = _MASKS.setdefault(model, {})
    row = rows.get(f)
    if row is None:
        row = np.zeros(model.dof, dtype=np.int64)
        path = model._paths[f]
        row[path[path >= 0]] = 1
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
