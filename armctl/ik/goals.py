"""What an end effector must reach: the seed's four IK goal types.

* :class:`PositionGoal`: position only (3 DOF).
* :class:`OrientationGoal`: orientation only (3 DOF).
* :class:`DirectionGoal`: position plus one unit direction of a tool axis (5 DOF), the natural
  goal for 5-joint arms such as the SO-101.
* :class:`PoseGoal`: full position and orientation (6 DOF).

Each goal names its frame (``None``: the arm's tool frame), a weight and a tolerance. Whether a
goal is met is decided by :meth:`Goal.errors` on the pose computed by forward kinematics, the same
way for every solver.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.spatial import orthonormalize

__all__ = [
    "DirectionGoal",
    "Goal",
    "GoalLike",
    "OrientationGoal",
    "PoseGoal",
    "PositionGoal",
    "Tolerance",
    "as_goals",
    "as_unit3",
    "as_vec3",
]

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Tolerance:
    """How close counts as reached.

    Attributes:
        position: Largest position error in [m].
        rotation: Largest rotation (or direction) error in [rad].
    """

    position: float = 1e-5
    rotation: float = 1e-4

    def __post_init__(self) -> None:
        if not (self.position > 0 and self.rotation > 0):
            raise InputError(f"tolerances must be positive, got position={self.position} m, "
                             f"rotation={self.rotation} rad")


def as_vec3(value: npt.ArrayLike, what: str) -> Array:
    """A read-only ``(3,)`` float vector; ``what`` names it in the error."""
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{what} must be 3 finite numbers, got {np.asarray(value).tolist()}")
    arr.setflags(write=False)
    return arr


def as_unit3(value: npt.ArrayLike, what: str) -> Array:
    """A read-only unit ``(3,)`` vector (normalised); ``what`` names it in the error."""
    arr = np.array(as_vec3(value, what))
    n = float(np.linalg.norm(arr))
    if n < 1e-9:
        raise InputError(f"{what} must not be the zero vector")
    arr /= n
    arr.setflags(write=False)
    return arr


def _rotation(value: npt.ArrayLike, what: str) -> Array:
    arr = np.array(value, dtype=float)
    if arr.shape != (3, 3) or not np.all(np.isfinite(arr)):
        raise InputError(f"{what} must be a 3x3 rotation matrix")
    if np.abs(arr @ arr.T - np.eye(3)).max() > 1e-6 or np.linalg.det(arr) < 0:
        raise InputError(f"{what} is not a rotation matrix (R R^T != I or det < 0)")
    out = orthonormalize(arr)
    out.setflags(write=False)
    return out


def _angle(a: Array, b: Array) -> float:
    """Angle between two unit vectors [rad], accurate at 0 and pi."""
    return float(math.atan2(np.linalg.norm(np.cross(a, b)), float(a @ b)))


def _rotation_angle(r_target: Array, r_current: Array) -> float:
    """Angle of the rotation between two orientations [rad], accurate near 0."""
    d = r_target @ r_current.T
    s = np.array([d[2, 1] - d[1, 2], d[0, 2] - d[2, 0], d[1, 0] - d[0, 1]])
    c = (d[0, 0] + d[1, 1] + d[2, 2] - 1.0) / 2.0
    return float(math.atan2(np.linalg.norm(s) / 2.0, c))


@dataclass(frozen=True)
class Goal:
    """Base of the goal types.

    Attributes:
        frame: The frame that must reach the goal; the arm's tool frame when ``None``.
        weight: Relative weight when several goals compete (> 0).
        tolerance: When the goal counts as reached.
    """

    frame: str | None = field(default=None, kw_only=True)
    weight: float = field(default=1.0, kw_only=True)
    tolerance: Tolerance = field(default=Tolerance(), kw_only=True)

    #: Number of constrained task-space dimensions (3, 5 or 6).
    dof: int = field(default=0, init=False, repr=False)
    #: Whether the goal constrains the position.
    has_position: bool = field(default=False, init=False, repr=False)
    #: Whether the goal constrains (part of) the orientation.
    has_rotation: bool = field(default=False, init=False, repr=False)

    def __post_init__(self) -> None:
        if not self.weight > 0:
            raise InputError(f"a goal's weight must be positive, got {self.weight}")

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:
        """Position error [m] and rotation error [rad] of a frame pose against this goal.

        Args:
            pose: ``(4, 4)`` pose of the goal's frame.

        Returns:
            ``(position_error, rotation_error)``; 0.0 for a part the goal does not constrain.
        """
        raise NotImplementedError

    def reached(self, pose: npt.ArrayLike) -> bool:
        """Whether the pose meets the goal within its tolerance."""
        dp, dr = self.errors(pose)
        return dp <= self.tolerance.position and dr <= self.tolerance.rotation


@dataclass(frozen=True)
class PositionGoal(Goal):
    """Reach a position (3 DOF). ``position``: target in the base frame [m]."""

    position: Array

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "position", as_vec3(self.position, "goal position"))
        object.__setattr__(self, "dof", 3)
        object.__setattr__(self, "has_position", True)

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:  # noqa: D102
        p = np.asarray(pose)[:3, 3]
        return float(np.linalg.norm(self.position - p)), 0.0


@dataclass(frozen=True)
class OrientationGoal(Goal):
    """Reach an orientation (3 DOF). ``rotation``: target ``(3, 3)`` in the base frame."""

    rotation: Array

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "rotation", _rotation(self.rotation, "goal rotation"))
        object.__setattr__(self, "dof", 3)
        object.__setattr__(self, "has_rotation", True)

    @classmethod
    def from_axes(cls, x_axis: npt.ArrayLike, z_axis: npt.ArrayLike, *, frame: str | None = None,
                  weight: float = 1.0, tolerance: Tolerance = Tolerance()) -> OrientationGoal:
        """The orientation given by two orthogonal unit vectors (the seed's form).

        Args:
            x_axis: Target direction of the frame's x axis in the base frame.
            z_axis: Target direction of the frame's z axis (orthogonal to ``x_axis``).
            frame: The goal's frame (``None``: the tool frame).
            weight: Relative weight.
            tolerance: When the goal counts as reached.
        """
        x, z = as_unit3(x_axis, "x axis"), as_unit3(z_axis, "z axis")
        if abs(float(x @ z)) > 1e-6:
            raise InputError("the two orientation vectors must be orthogonal")
        rot = np.column_stack([x, np.cross(z, x), z])
        return cls(rot, frame=frame, weight=weight, tolerance=tolerance)

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:  # noqa: D102
        return 0.0, _rotation_angle(self.rotation, np.asarray(pose)[:3, :3])


@dataclass(frozen=True)
class DirectionGoal(Goal):
    """Reach a position and point one tool axis along a direction (5 DOF).

    Attributes:
        position: Target position in the base frame [m].
        direction: Unit direction in the base frame that the tool axis must point along.
        axis: The tool axis, in the goal frame's own coordinates (default: its z axis).
    """

    position: Array
    direction: Array
    axis: Array = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "position", as_vec3(self.position, "goal position"))
        object.__setattr__(self, "direction", as_unit3(self.direction, "goal direction"))
        object.__setattr__(self, "axis", as_unit3(self.axis, "tool axis"))
        object.__setattr__(self, "dof", 5)
        object.__setattr__(self, "has_position", True)
        object.__setattr__(self, "has_rotation", True)

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:  # noqa: D102
        m = np.asarray(pose)
        return (float(np.linalg.norm(self.position - m[:3, 3])),
                _angle(m[:3, :3] @ self.axis, self.direction))


@dataclass(frozen=True)
class PoseGoal(Goal):
    """Reach a full pose (6 DOF). ``pose``: target ``(4, 4)`` in the base frame."""

    pose: Array

    def __post_init__(self) -> None:
        super().__post_init__()
        arr = np.array(self.pose, dtype=float)
        if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
            raise InputError(f"a pose goal needs a 4x4 transform, got shape {arr.shape}")
        out = np.eye(4)
        out[:3, :3] = _rotation(arr[:3, :3], "goal pose rotation")
        out[:3, 3] = arr[:3, 3]
        out.setflags(write=False)
        object.__setattr__(self, "pose", out)
        object.__setattr__(self, "dof", 6)
        object.__setattr__(self, "has_position", True)
        object.__setattr__(self, "has_rotation", True)

    @property
    def position(self) -> Array:
        """Target position [m]."""
        return self.pose[:3, 3]

    @property
    def rotation(self) -> Array:
        """Target rotation ``(3, 3)``."""
        return self.pose[:3, :3]

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:  # noqa: D102
        m = np.asarray(pose)
        return (float(np.linalg.norm(self.pose[:3, 3] - m[:3, 3])),
                _rotation_angle(self.pose[:3, :3], m[:3, :3]))


GoalLike = Goal | npt.ArrayLike | Sequence[Goal]


def as_goals(goal: GoalLike, tolerance: Tolerance | None = None) -> tuple[Goal, ...]:
    """Normalise what a user passes as a goal: one goal, several, or a ``(4, 4)`` pose array.

    Args:
        goal: A :class:`Goal`, a sequence of goals, or a ``(4, 4)`` pose (a :class:`PoseGoal`
            for the tool frame).
        tolerance: Tolerance for a goal built here from a pose array.

    Returns:
        A non-empty tuple of goals.

    Raises:
        InputError: For anything else, or two goals on the same frame.
    """
    if isinstance(goal, Goal):
        goals: tuple[Goal, ...] = (goal,)
    elif isinstance(goal, (list, tuple)) and goal and all(isinstance(g, Goal) for g in goal):
        goals = tuple(goal)
    else:
        arr = np.asarray(goal, dtype=float) if not isinstance(goal, (list, tuple)) or goal else None
        if arr is None or arr.shape != (4, 4):
            raise InputError("a goal must be a Goal object, a sequence of them, or a 4x4 pose "
                             f"array; got {type(goal).__name__}")
        goals = (PoseGoal(arr, tolerance=tolerance or Tolerance()),)
    frames = [g.frame for g in goals]
    if len(set(frames)) != len(frames):
        raise InputError("two goals name the same frame; combine them into one goal")
    return goals
