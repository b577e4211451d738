"""What an end effector must reach: the goal types, each describing itself.

* :class:`PositionGoal`: position only (3 DOF).
* :class:`OrientationGoal`: orientation only (3 DOF).
* :class:`DirectionGoal`: position plus one unit direction of a tool axis (5 DOF), the natural
  goal for 5-joint arms such as the SO-101.
* :class:`PoseGoal`: full position and orientation (6 DOF).
* :class:`LookAtGoal`: a tool axis points at a point in space (2 DOF), e.g. a wrist camera.

Each goal names its frame (``None``: the arm's tool frame), a weight and a tolerance. Whether a
goal is met is decided by :meth:`Goal.errors` on the pose computed by forward kinematics, the same
way for every solver.

A goal type describes itself, so the code around it (packing for the compiled solvers, the NLP,
goals files, the command line, straight-line moves) needs no list of types: its :class:`GoalKind`
(the code the compiled residual and Jacobian kernels of :mod:`armctl.ik._residual` dispatch on),
its packed targets (:meth:`Goal.packed`), its CasADi residual (:meth:`Goal.nlp_residual`), its
goals-file entry (:meth:`Goal.from_file`, :meth:`Goal.file_fields`), its command-line flags
(:attr:`Goal.cli_arguments`, :meth:`Goal.from_cli`) and its straight-line interpolation
(:meth:`Goal.interpolate`). A new goal type is a class here plus its kernel branch in
:mod:`armctl.ik._residual` (docs/ik-goals.md, "Adding a goal type").
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import IntEnum
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.spatial import (
    make_transform,
    matrix_to_quat,
    matrix_to_rpy,
    orthonormalize,
    quat_to_matrix,
    rpy_to_matrix,
    slerp,
)
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.config.source import Section

__all__ = [
    "CliArgument",
    "CliGoalInput",
    "DirectionGoal",
    "Goal",
    "GoalKind",
    "GoalLike",
    "LookAtGoal",
    "OrientationGoal",
    "PoseGoal",
    "PositionGoal",
    "Tolerance",
    "as_goals",
    "as_unit3",
    "as_vec3",
    "goal_class",
    "goal_classes",
]


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


# Goals are built and checked once per IK call, so the checks below work on plain Python floats
# (``tolist``): for 3 to 16 numbers that is several times faster than NumPy's per-call overhead.

#: Largest |R R^T - I| entry of a rotation accepted as a rotation matrix (else an error).
_ROTATION_TOLERANCE = 1e-6
#: Largest |R R^T - I| entry of a rotation taken as it is; one between this and
#: :data:`_ROTATION_TOLERANCE` is replaced by the nearest rotation matrix.
_ORTHONORMAL = 1e-12


class _CompiledChecks:
    """Compiled forms of the goal checks, registered by the compiled solvers when they load.

    A goal type checks its input in plain Python (this module imports no compiler); once the
    compiled solvers are loaded (:mod:`armctl.ik._residual`), the common case of a check runs
    in one compiled call instead. A compiled check only accepts: for any input it does not
    accept as it is, the Python check runs as before (and raises, or repairs the input).

    Attributes:
        pose_row: ``(pose (4, 4), row (1, 18), orthonormal) -> bool``: True (and ``row`` filled
            with the packed targets) when ``pose`` is finite, its last row is ``0 0 0 1`` and
            its rotation has ``max |R R^T - I| <= orthonormal`` and ``det R > 0``.
    """

    pose_row: Any = None


_COMPILED = _CompiledChecks()


def use_compiled_checks(*, pose_row: Any) -> None:
    """Register the compiled goal checks (see :class:`_CompiledChecks`)."""
    _COMPILED.pose_row = pose_row


def _finite(values: list[float]) -> bool:
    """Whether every number is finite (one sum; each number only when the sum is not finite)."""
    return math.isfinite(sum(values)) or all(math.isfinite(v) for v in values)


def _vec3(value: npt.ArrayLike, what: str) -> Array:
    """A new ``(3,)`` float vector of finite numbers; ``what`` names it in the error."""
    arr = np.array(value, dtype=float).reshape(-1)
    if arr.shape != (3,) or not _finite(arr.tolist()):
        raise InputError(f"{what} must be 3 finite numbers, got {np.asarray(value).tolist()}")
    return arr


def as_vec3(value: npt.ArrayLike, what: str) -> Array:
    """A read-only ``(3,)`` float vector; ``what`` names it in the error."""
    arr = _vec3(value, what)
    arr.setflags(write=False)
    return arr


def as_unit3(value: npt.ArrayLike, what: str) -> Array:
    """A read-only unit ``(3,)`` vector (normalised); ``what`` names it in the error."""
    x, y, z = _vec3(value, what).tolist()
    n = math.hypot(x, y, z)
    if n < 1e-9:
        raise InputError(f"{what} must not be the zero vector")
    arr = np.array([x / n, y / n, z / n])
    arr.setflags(write=False)
    return arr


def _rotation_residual(rows: Sequence[Sequence[float]]) -> tuple[float, float]:
    """``max |R R^T - I|`` and ``det R`` of the 3x3 block at the top left of ``rows``."""
    (x0, x1, x2), (y0, y1, y2), (z0, z1, z2) = rows[0][:3], rows[1][:3], rows[2][:3]
    off = max(abs(x0 * x0 + x1 * x1 + x2 * x2 - 1.0), abs(y0 * y0 + y1 * y1 + y2 * y2 - 1.0),
              abs(z0 * z0 + z1 * z1 + z2 * z2 - 1.0), abs(x0 * y0 + x1 * y1 + x2 * y2),
              abs(x0 * z0 + x1 * z1 + x2 * z2), abs(y0 * z0 + y1 * z1 + y2 * z2))
    det = x0 * (y1 * z2 - y2 * z1) - x1 * (y0 * z2 - y2 * z0) + x2 * (y0 * z1 - y1 * z0)
    return off, det


def _check_rotation(rows: Sequence[Sequence[float]], what: str) -> bool:
    """Raise unless the top-left 3x3 of ``rows`` is a rotation; say if it needs orthonormalising.

    A rotation passes within :data:`_ROTATION_TOLERANCE`. The test is the cheap residual
    ``max |R R^T - I|`` and the sign of the determinant; the projection onto the nearest
    rotation (an SVD) runs only for a matrix that is not orthonormal to round-off already.
    """
    off, det = _rotation_residual(rows)
    if not off <= _ROTATION_TOLERANCE or det < 0:
        raise InputError(f"{what} is not a rotation matrix (R R^T != I or det < 0): largest "
                         f"|R R^T - I| entry {off:.3g} (at most {_ROTATION_TOLERANCE:g}), "
                         f"det {det:.6g}; give an orthonormal matrix with det +1")
    return off > _ORTHONORMAL


def _rotation(value: npt.ArrayLike, what: str) -> Array:
    arr = np.array(value, dtype=float)
    if arr.shape != (3, 3) or not _finite(arr.ravel().tolist()):
        raise InputError(f"{what} must be a 3x3 rotation matrix of finite numbers")
    out = orthonormalize(arr) if _check_rotation(arr.tolist(), what) else arr
    out.setflags(write=False)
    return out


def _angle_lists(a: Sequence[float], b: Sequence[float]) -> float:
    """Angle between two 3-vectors [rad] (unit length for accuracy), accurate at 0 and pi."""
    a0, a1, a2 = a
    b0, b1, b2 = b
    return math.atan2(math.hypot(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0),
                      a0 * b0 + a1 * b1 + a2 * b2)


def _angle(a: Array, b: Array) -> float:
    """Angle between two unit vectors [rad], accurate at 0 and pi."""
    return _angle_lists(a.tolist(), b.tolist())


def _rotation_angle_lists(t: Sequence[Sequence[float]], c: Sequence[Sequence[float]]) -> float:
    """:func:`_rotation_angle` of the top-left 3x3 blocks of two row lists."""
    (t0, t1, t2), (t3, t4, t5), (t6, t7, t8) = t[0][:3], t[1][:3], t[2][:3]
    (c0, c1, c2), (c3, c4, c5), (c6, c7, c8) = c[0][:3], c[1][:3], c[2][:3]
    # d = R_t R_c^T: its skew part and its trace
    d01 = t0 * c3 + t1 * c4 + t2 * c5
    d02 = t0 * c6 + t1 * c7 + t2 * c8
    d10 = t3 * c0 + t4 * c1 + t5 * c2
    d12 = t3 * c6 + t4 * c7 + t5 * c8
    d20 = t6 * c0 + t7 * c1 + t8 * c2
    d21 = t6 * c3 + t7 * c4 + t8 * c5
    tr = (t0 * c0 + t1 * c1 + t2 * c2) + (t3 * c3 + t4 * c4 + t5 * c5) + (
        t6 * c6 + t7 * c7 + t8 * c8)
    return math.atan2(math.hypot(d21 - d12, d02 - d20, d10 - d01) / 2.0, (tr - 1.0) / 2.0)


def _rotation_angle(r_target: Array, r_current: Array) -> float:
    """Angle of the rotation between two orientations [rad], accurate near 0."""
    return _rotation_angle_lists(r_target.tolist(), np.asarray(r_current).tolist())


def _rotate(rows: Sequence[Sequence[float]], v: Sequence[float]) -> tuple[float, float, float]:
    """The top-left 3x3 of ``rows`` times the 3-vector ``v``."""
    v0, v1, v2 = v
    return (rows[0][0] * v0 + rows[0][1] * v1 + rows[0][2] * v2,
            rows[1][0] * v0 + rows[1][1] * v1 + rows[1][2] * v2,
            rows[2][0] * v0 + rows[2][1] * v1 + rows[2][2] * v2)


class GoalKind(IntEnum):
    """The goal types, one number each.

    The number is the code the compiled kernels dispatch on (:mod:`armctl.ik._residual`, CCD,
    the analytic polish); :attr:`label` is how messages name the kind. :func:`goal_class` gives
    the class of a kind.
    """

    POSITION = 0
    ORIENTATION = 1
    DIRECTION = 2
    POSE = 3
    LOOK_AT = 4

    @property
    def label(self) -> str:
        """How messages name goals of this kind (``"position + direction"``, ``"look-at"``)."""
        return goal_class(self).label


@dataclass(frozen=True)
class CliArgument:
    """A command-line flag that a goal type adds to ``armctl ik`` and ``move-to-pose``.

    Attributes:
        flag: The flag, e.g. ``"--look-at"``; its value reaches :meth:`Goal.from_cli` under
            this name (``None`` when the flag is not given).
        metavar: One name per value (``("X", "Y", "Z")`` takes three values; one name: a single
            value).
        help: The help text.
        numbers: Whether the values are finite numbers (else strings, checked by the goal).
        choices: The allowed values of a one-value string flag (empty: any).
        exclusive: Whether the flag excludes ``--rpy`` and ``--quat`` (and the other exclusive
            flags).
        usage: How the "give a goal" message shows the goal type (empty: not shown).
    """

    flag: str
    metavar: tuple[str, ...]
    help: str
    numbers: bool = True
    choices: tuple[str, ...] = ()
    exclusive: bool = False
    usage: str = ""

    @property
    def dest(self) -> str:
        """The flag as a Python name (``"--look-at"`` -> ``"look_at"``)."""
        return self.flag.lstrip("-").replace("-", "_")


@dataclass(frozen=True)
class CliGoalInput:
    """What the command line gave for a goal, as :meth:`Goal.from_cli` receives it.

    Attributes:
        xyz: ``--xyz`` position in the base frame [m], or ``None``.
        rotation: The orientation of ``--rpy`` or ``--quat`` ``(3, 3)``, or ``None``.
        frame: ``--frame`` (``None``: the tool).
        tolerance: From ``--tol-pos`` and ``--tol-rot``.
        values: The goal types' own flags (:attr:`CliArgument.flag`) and their values; ``None``
            for a flag not given.
    """

    xyz: Array | None
    rotation: Array | None
    frame: str | None
    tolerance: Tolerance
    values: Mapping[str, Any] = field(default_factory=dict)

    def value(self, flag: str) -> Any:
        """The value of a goal type's own flag, ``None`` when not given."""
        return self.values.get(flag)

    @property
    def own_flags(self) -> bool:
        """Whether any goal type's own flag was given."""
        return any(v is not None for v in self.values.values())


#: kind -> goal class, filled as the classes are defined (:meth:`Goal.__init_subclass__`)
_KINDS: dict[GoalKind, type[Goal]] = {}


def goal_class(kind: GoalKind | int) -> type[Goal]:
    """The goal class of a kind.

    Raises:
        InputError: For a number that is no registered kind.
    """
    try:
        return _KINDS[GoalKind(kind)]
    except (ValueError, KeyError):
        raise InputError(f"{kind!r} is not a goal kind; known: "
                         f"{', '.join(k.name for k in _KINDS)}") from None


def goal_classes() -> tuple[type[Goal], ...]:
    """Every goal class, in the order of their kinds."""
    return tuple(_KINDS[k] for k in sorted(_KINDS))


_AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def _packed(position: Array | None = None, rotation: Array | None = None,
            direction: Array | None = None, axis: Array | None = None) -> Array:
    """The 18 numbers of a goal's targets (layout: :mod:`armctl.ik._residual`)."""
    row = np.zeros(18)
    row[17] = 1.0  # default tool axis z
    if position is not None:
        row[0:3] = position
    if rotation is not None:
        row[3:12] = rotation.ravel()
    if direction is not None:
        row[12:15] = direction
    if axis is not None:
        row[15:18] = axis
    return row


def _turn(a: Array, b: Array, s: float) -> Array:
    """Unit vector a fraction ``s`` of the way from ``a`` to ``b`` on the great circle."""
    c = float(np.clip(a @ b, -1.0, 1.0))
    angle = math.acos(c)
    if angle < 1e-9:
        return b.copy()
    axis = np.cross(a, b)
    if np.linalg.norm(axis) < 1e-9:  # opposite: any perpendicular axis
        axis = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    axis = axis / np.linalg.norm(axis)
    th = s * angle
    return a * math.cos(th) + np.cross(axis, a) * math.sin(th) + axis * (axis @ a) * (
        1 - math.cos(th))


def _span_angle(a: Array, b: Array) -> float:
    """Angle between two unit vectors [rad] (for sampling; acos is enough)."""
    return math.acos(float(np.clip(a @ b, -1.0, 1.0)))


def _vec(v: npt.ArrayLike) -> list[float]:
    """Plain floats for a file."""
    return [float(x) for x in np.asarray(v, dtype=float).reshape(-1)]


@dataclass(frozen=True)
class Goal:
    """Base of the goal types.

    A goal type is a frozen dataclass deriving from this class that sets the class attributes
    :attr:`kind`, :attr:`label`, :attr:`file_type` and :attr:`file_keys` (and
    :attr:`cli_arguments` if it has command-line flags) and implements the methods that raise
    ``NotImplementedError`` here; defining the class registers its kind (:func:`goal_class`).

    Attributes:
        frame: The frame that must reach the goal; the arm's tool frame when ``None``.
        weight: Relative weight when several goals compete (> 0).
        tolerance: When the goal counts as reached.
    """

    frame: str | None = field(default=None, kw_only=True)
    weight: float = field(default=1.0, kw_only=True)
    tolerance: Tolerance = field(default=Tolerance(), kw_only=True)

    #: Number of constrained task-space dimensions (2 to 6), a constant of the goal type.
    dof: ClassVar[int] = 0
    #: Whether the goal constrains the position.
    has_position: ClassVar[bool] = False
    #: Whether the goal constrains (part of) the orientation.
    has_rotation: ClassVar[bool] = False

    #: The kind: the code of its residual and Jacobian in the compiled kernels.
    kind: ClassVar[GoalKind]
    #: How messages name the kind.
    label: ClassVar[str]
    #: Its ``type`` in a goals file.
    file_type: ClassVar[str]
    #: The keys of its goals-file entry besides type, frame, weight and tolerance:
    #: ``(required, optional)``.
    file_keys: ClassVar[tuple[tuple[str, ...], tuple[str, ...]]] = ((), ())
    #: Command-line flags of its own (``--xyz``, ``--rpy`` and ``--quat`` are shared).
    cli_arguments: ClassVar[tuple[CliArgument, ...]] = ()

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        kind = cls.__dict__.get("kind")
        if kind is None:
            return  # a subclass of a goal type keeps its parent's kind
        known = _KINDS.get(kind)
        if known is not None and known.__qualname__ != cls.__qualname__:
            raise TypeError(f"goal kind {kind.name} belongs to {known.__qualname__} already; "
                            f"give {cls.__qualname__} a kind of its own")
        _KINDS[kind] = cls

    def __post_init__(self) -> None:
        if not self.weight > 0:
            raise InputError(f"a goal's weight must be positive, got {self.weight}")

    # ---- what is reached ---------------------------------------------------------------------
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

    @property
    def target_position(self) -> Array | None:
        """The position the frame must reach [m], or ``None`` when the goal leaves it free."""
        return None

    # ---- the compiled solvers ----------------------------------------------------------------
    def packed(self) -> Array:
        """The goal's 18 target numbers for the compiled kernels.

        The layout (position, rotation, direction, tool axis) is described in
        :mod:`armctl.ik._residual`; the kernel branch of :attr:`kind` reads them.
        """
        raise NotImplementedError

    def packed_row(self) -> Array:
        """:meth:`packed` as a ``(1, 18)`` array that the goal keeps: read it, never write it.

        Built on first use (or while the goal is checked) and kept, so the compiled solvers
        take a goal's targets without building them again.
        """
        row = self.__dict__.get("_row")
        if row is None:
            row = np.array(self.packed(), dtype=float).reshape(1, 18)
            object.__setattr__(self, "_row", row)
        return row

    # ---- the NLP -----------------------------------------------------------------------------
    def nlp_params(self) -> Array:
        """The numbers :meth:`nlp_residual` reads from its parameters (weight excluded)."""
        raise NotImplementedError

    def nlp_residual(self, ca: Any, rot: Any, pos: Any, params: Any, *, position_scale: float,
                     rotation_scale: float) -> Any:
        """The CasADi residual vector whose squared norm the NLP drives to zero.

        Only the structure of ``self`` may be used (a built problem serves every goal of the
        same type and frame); the numbers come from ``params``.

        Args:
            ca: The ``casadi`` module.
            rot: Symbolic ``(3, 3)`` rotation of the goal's frame.
            pos: Symbolic ``(3, 1)`` position of the goal's frame [m].
            params: Symbolic parameters, laid out as :meth:`nlp_params` returns them.
            position_scale: Factor of position residuals [1/m] (1 / the arm's reach).
            rotation_scale: Factor of orientation residuals (orientation scale / reach).
        """
        raise NotImplementedError

    # ---- goals files -------------------------------------------------------------------------
    @classmethod
    def from_file(cls, sec: Section, *, frame: str | None, weight: float,
                  tolerance: Tolerance) -> Goal:
        """The goal of a goals-file entry (its keys already checked against :attr:`file_keys`).

        Args:
            sec: The entry (errors raised through it name the file, key and line).
            frame: Its ``frame``.
            weight: Its ``weight``.
            tolerance: Its ``tolerance``.
        """
        raise NotImplementedError

    def file_fields(self) -> dict[str, Any]:
        """The goal's own keys of its goals-file entry (plain numbers; angles in [rad])."""
        raise NotImplementedError

    # ---- the command line --------------------------------------------------------------------
    @classmethod
    def from_cli(cls, given: CliGoalInput) -> Goal | None:
        """The goal the command line describes, or ``None`` when it describes another type.

        Raises:
            InputError: When this type's flags are given but incomplete or contradictory.
        """
        return None

    # ---- straight-line moves -----------------------------------------------------------------
    def line_span(self, start: Array) -> tuple[float, float] | None:
        """How far a straight line from ``start`` to the goal goes.

        Args:
            start: ``(4, 4)`` pose of the goal's frame at the start.

        Returns:
            ``(distance [m], rotation [rad])`` of the line, or ``None`` when the goal type has
            no straight line.
        """
        return None

    def interpolate(self, start: Array, s: float) -> Goal:
        """The goal at fraction ``s`` in [0, 1] of the straight line from ``start`` to it.

        Raises:
            InputError: For a goal type without a straight line (:meth:`line_span` ``None``).
        """
        raise InputError(f"a straight line is not defined for {self.label} goals")


@dataclass(frozen=True)
class PositionGoal(Goal):
    """Reach a position (3 DOF). ``position``: target in the base frame [m]."""

    position: Array

    kind: ClassVar[GoalKind] = GoalKind.POSITION
    dof: ClassVar[int] = 3
    has_position: ClassVar[bool] = True
    label: ClassVar[str] = "position"
    file_type: ClassVar[str] = "position"
    file_keys: ClassVar[tuple[tuple[str, ...], tuple[str, ...]]] = (("position",), ())

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "position", as_vec3(self.position, "goal position"))

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:  # noqa: D102
        m = np.asarray(pose).tolist()
        x, y, z = self.position.tolist()
        return math.hypot(x - m[0][3], y - m[1][3], z - m[2][3]), 0.0

    @property
    def target_position(self) -> Array:  # noqa: D102
        return self.position

    def packed(self) -> Array:  # noqa: D102
        return _packed(position=self.position)

    def nlp_params(self) -> Array:  # noqa: D102
        return np.array(self.position, dtype=float)

    def nlp_residual(self, ca: Any, rot: Any, pos: Any, params: Any, *,  # noqa: D102
                     position_scale: float, rotation_scale: float) -> Any:
        return (pos - params[0:3]) * position_scale

    @classmethod
    def from_file(cls, sec: Section, *, frame: str | None, weight: float,  # noqa: D102
                  tolerance: Tolerance) -> Goal:
        return cls(np.array(sec.vector("position", 3)), frame=frame, weight=weight,
                   tolerance=tolerance)

    def file_fields(self) -> dict[str, Any]:  # noqa: D102
        return {"position": _vec(self.position)}

    @classmethod
    def from_cli(cls, given: CliGoalInput) -> Goal | None:  # noqa: D102
        if given.xyz is None or given.rotation is not None or given.own_flags:
            return None
        return cls(given.xyz, frame=given.frame, tolerance=given.tolerance)

    def line_span(self, start: Array) -> tuple[float, float]:  # noqa: D102
        return float(np.linalg.norm(self.position - start[:3, 3])), 0.0

    def interpolate(self, start: Array, s: float) -> Goal:  # noqa: D102
        p0 = start[:3, 3]
        return replace(self, position=p0 + s * (self.position - p0))


@dataclass(frozen=True)
class OrientationGoal(Goal):
    """Reach an orientation (3 DOF). ``rotation``: target ``(3, 3)`` in the base frame."""

    rotation: Array

    kind: ClassVar[GoalKind] = GoalKind.ORIENTATION
    dof: ClassVar[int] = 3
    has_rotation: ClassVar[bool] = True
    label: ClassVar[str] = "orientation"
    file_type: ClassVar[str] = "orientation"
    file_keys: ClassVar[tuple[tuple[str, ...], tuple[str, ...]]] = (("rpy",), ())

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "rotation", _rotation(self.rotation, "goal rotation"))

    @classmethod
    def from_axes(cls, x_axis: npt.ArrayLike, z_axis: npt.ArrayLike, *, frame: str | None = None,
                  weight: float = 1.0, tolerance: Tolerance = Tolerance()) -> OrientationGoal:
        """The orientation given by two orthogonal unit vectors.

        This is how the lecture (L. Kavan, *Metody skeletální animace*, 2002) states an
        orientation goal.

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
        return 0.0, _rotation_angle_lists(self.rotation.tolist(), np.asarray(pose).tolist())

    def packed(self) -> Array:  # noqa: D102
        return _packed(rotation=self.rotation)

    def nlp_params(self) -> Array:  # noqa: D102
        return self.rotation.ravel(order="F")

    def nlp_residual(self, ca: Any, rot: Any, pos: Any, params: Any, *,  # noqa: D102
                     position_scale: float, rotation_scale: float) -> Any:
        return rotation_scale * ca.vec(rot - ca.reshape(params[0:9], 3, 3))

    @classmethod
    def from_file(cls, sec: Section, *, frame: str | None, weight: float,  # noqa: D102
                  tolerance: Tolerance) -> Goal:
        return cls(rpy_to_matrix(sec.vector("rpy", 3, angle=True)), frame=frame, weight=weight,
                   tolerance=tolerance)

    def file_fields(self) -> dict[str, Any]:  # noqa: D102
        return {"rpy": _vec(matrix_to_rpy(self.rotation))}

    @classmethod
    def from_cli(cls, given: CliGoalInput) -> Goal | None:  # noqa: D102
        if given.xyz is not None or given.rotation is None or given.own_flags:
            return None
        return cls(given.rotation, frame=given.frame, tolerance=given.tolerance)


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

    kind: ClassVar[GoalKind] = GoalKind.DIRECTION
    dof: ClassVar[int] = 5
    has_position: ClassVar[bool] = True
    has_rotation: ClassVar[bool] = True
    label: ClassVar[str] = "position + direction"
    file_type: ClassVar[str] = "direction"
    file_keys: ClassVar[tuple[tuple[str, ...], tuple[str, ...]]] = (
        ("position", "direction"), ("axis",))
    cli_arguments: ClassVar[tuple[CliArgument, ...]] = (
        CliArgument("--direction", ("AXIS", "DX", "DY", "DZ"),
                    "point the frame's AXIS (x, y or z) along (DX, DY, DZ): a 5-DOF goal",
                    numbers=False, exclusive=True,
                    usage="--xyz X Y Z with --direction AXIS DX DY DZ"),)

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "position", as_vec3(self.position, "goal position"))
        object.__setattr__(self, "direction", as_unit3(self.direction, "goal direction"))
        object.__setattr__(self, "axis", as_unit3(self.axis, "tool axis"))

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:  # noqa: D102
        m = np.asarray(pose).tolist()
        x, y, z = self.position.tolist()
        return (math.hypot(x - m[0][3], y - m[1][3], z - m[2][3]),
                _angle_lists(_rotate(m, self.axis.tolist()), self.direction.tolist()))

    @property
    def target_position(self) -> Array:  # noqa: D102
        return self.position

    def packed(self) -> Array:  # noqa: D102
        return _packed(position=self.position, direction=self.direction, axis=self.axis)

    def nlp_params(self) -> Array:  # noqa: D102
        return np.concatenate([self.position, self.direction, self.axis])

    def nlp_residual(self, ca: Any, rot: Any, pos: Any, params: Any, *,  # noqa: D102
                     position_scale: float, rotation_scale: float) -> Any:
        return ca.vertcat((pos - params[0:3]) * position_scale,
                          rotation_scale * (rot @ params[6:9] - params[3:6]))

    @classmethod
    def from_file(cls, sec: Section, *, frame: str | None, weight: float,  # noqa: D102
                  tolerance: Tolerance) -> Goal:
        axis = sec.vector("axis", 3, (0.0, 0.0, 1.0))
        return cls(np.array(sec.vector("position", 3)), np.array(sec.vector("direction", 3)),
                   np.array(axis), frame=frame, weight=weight, tolerance=tolerance)

    def file_fields(self) -> dict[str, Any]:  # noqa: D102
        return {"position": _vec(self.position), "direction": _vec(self.direction),
                "axis": _vec(self.axis)}

    @classmethod
    def from_cli(cls, given: CliGoalInput) -> Goal | None:  # noqa: D102
        raw = given.value("--direction")
        if raw is None or given.xyz is None:
            return None
        axis_name, *values = raw
        if axis_name.lower() not in _AXES:
            raise InputError(f"--direction: AXIS must be x, y or z, got {axis_name!r}")
        try:
            vec = [float(v) for v in values]
        except ValueError:
            raise InputError(f"--direction: DX DY DZ must be numbers, got {values}") from None
        if not all(math.isfinite(v) for v in vec):
            raise InputError(f"--direction: DX DY DZ must be finite numbers, got {values}")
        if not float(np.linalg.norm(vec)) > 1e-9:
            raise InputError("--direction: the direction DX DY DZ must not be zero")
        return cls(given.xyz, np.array(vec), np.array(_AXES[axis_name.lower()]),
                   frame=given.frame, tolerance=given.tolerance)

    def line_span(self, start: Array) -> tuple[float, float]:  # noqa: D102
        return (float(np.linalg.norm(self.position - start[:3, 3])),
                _span_angle(start[:3, :3] @ self.axis, self.direction))

    def interpolate(self, start: Array, s: float) -> Goal:  # noqa: D102
        p0 = start[:3, 3]
        return replace(self, position=p0 + s * (self.position - p0),
                       direction=_turn(start[:3, :3] @ self.axis, self.direction, s))


@dataclass(frozen=True)
class PoseGoal(Goal):
    """Reach a full pose (6 DOF). ``pose``: target ``(4, 4)`` in the base frame."""

    pose: Array

    kind: ClassVar[GoalKind] = GoalKind.POSE
    dof: ClassVar[int] = 6
    has_position: ClassVar[bool] = True
    has_rotation: ClassVar[bool] = True
    label: ClassVar[str] = "pose"
    file_type: ClassVar[str] = "pose"
    file_keys: ClassVar[tuple[tuple[str, ...], tuple[str, ...]]] = (("position", "rpy"), ())

    def __post_init__(self) -> None:
        if not self.weight > 0:  # Goal.__post_init__, written out (a call costs as much)
            super().__post_init__()
        arr = np.array(self.pose, dtype=float)
        if arr.shape != (4, 4):
            raise InputError(f"a pose goal needs a 4x4 transform, got shape {arr.shape}")
        check = _COMPILED.pose_row
        if check is not None:  # the common case in one compiled call; any other as below
            row = np.empty((1, 18))
            if check(arr, row, _ORTHONORMAL):
                arr.setflags(write=False)
                object.__setattr__(self, "pose", arr)
                object.__setattr__(self, "_row", row)
                return
        rows = arr.tolist()
        if not _finite(rows[0] + rows[1] + rows[2]):
            raise InputError(f"a pose goal needs a 4x4 transform of finite numbers, got {rows}")
        if _check_rotation(rows, "goal pose rotation"):
            arr[:3, :3] = orthonormalize(arr[:3, :3])
        if rows[3] != [0.0, 0.0, 0.0, 1.0]:
            arr[3] = (0.0, 0.0, 0.0, 1.0)  # the last row of a transform, whatever was given
        arr.setflags(write=False)
        object.__setattr__(self, "pose", arr)

    @property
    def position(self) -> Array:
        """Target position [m]."""
        return self.pose[:3, 3]

    @property
    def rotation(self) -> Array:
        """Target rotation ``(3, 3)``."""
        return self.pose[:3, :3]

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:  # noqa: D102
        m = np.asarray(pose).tolist()
        t = self.pose.tolist()
        return (math.hypot(t[0][3] - m[0][3], t[1][3] - m[1][3], t[2][3] - m[2][3]),
                _rotation_angle_lists(t, m))

    @property
    def target_position(self) -> Array:  # noqa: D102
        return self.pose[:3, 3]

    def packed(self) -> Array:  # noqa: D102
        row = self.__dict__.get("_row")
        if row is not None:
            return np.array(row[0])
        r0, r1, r2, _ = self.pose.tolist()
        return np.array([r0[3], r1[3], r2[3], r0[0], r0[1], r0[2], r1[0], r1[1], r1[2],
                         r2[0], r2[1], r2[2], 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])

    def nlp_params(self) -> Array:  # noqa: D102
        return np.concatenate([self.position, self.rotation.ravel(order="F")])

    def nlp_residual(self, ca: Any, rot: Any, pos: Any, params: Any, *,  # noqa: D102
                     position_scale: float, rotation_scale: float) -> Any:
        return ca.vertcat((pos - params[0:3]) * position_scale,
                          rotation_scale * ca.vec(rot - ca.reshape(params[3:12], 3, 3)))

    @classmethod
    def from_file(cls, sec: Section, *, frame: str | None, weight: float,  # noqa: D102
                  tolerance: Tolerance) -> Goal:
        rot = rpy_to_matrix(sec.vector("rpy", 3, angle=True))
        return cls(make_transform(rot, sec.vector("position", 3)), frame=frame, weight=weight,
                   tolerance=tolerance)

    def file_fields(self) -> dict[str, Any]:  # noqa: D102
        return {"position": _vec(self.position), "rpy": _vec(matrix_to_rpy(self.rotation))}

    @classmethod
    def from_cli(cls, given: CliGoalInput) -> Goal | None:  # noqa: D102
        if given.xyz is None or given.rotation is None or given.own_flags:
            return None
        return cls(make_transform(given.rotation, given.xyz), frame=given.frame,
                   tolerance=given.tolerance)

    def line_span(self, start: Array) -> tuple[float, float]:  # noqa: D102
        return (float(np.linalg.norm(self.position - start[:3, 3])),
                _rotation_angle(self.rotation, start[:3, :3]))

    def interpolate(self, start: Array, s: float) -> Goal:  # noqa: D102
        p0 = start[:3, 3]
        quat = slerp(matrix_to_quat(start[:3, :3]), matrix_to_quat(self.rotation), s)
        return replace(self, pose=make_transform(quat_to_matrix(quat),
                                                 p0 + s * (self.position - p0)))


@dataclass(frozen=True)
class LookAtGoal(Goal):
    """Point a tool axis at a point in space (2 DOF), e.g. a wrist camera at an object.

    The error is the angle between the frame's ``axis`` (in the base frame) and the line from the
    frame's origin to ``point``; the position and the roll about the line are left free. With
    the frame's origin at ``point`` the direction is undefined and the error is pi. To fix the
    frame's position too, use a :class:`DirectionGoal` with ``direction = point - position``.

    Attributes:
        point: The point to look at, in the base frame [m].
        axis: The tool axis that must point at it, in the goal frame's own coordinates (default:
            its z axis).
    """

    point: Array
    axis: Array = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    kind: ClassVar[GoalKind] = GoalKind.LOOK_AT
    dof: ClassVar[int] = 2
    has_rotation: ClassVar[bool] = True
    label: ClassVar[str] = "look-at"
    file_type: ClassVar[str] = "look_at"
    file_keys: ClassVar[tuple[tuple[str, ...], tuple[str, ...]]] = (("point",), ("axis",))
    cli_arguments: ClassVar[tuple[CliArgument, ...]] = (
        CliArgument("--look-at", ("X", "Y", "Z"),
                    "point the frame's --axis at the point X Y Z in the base frame [m]: a 2-DOF "
                    "goal (e.g. a wrist camera); the position is left free",
                    exclusive=True, usage="--look-at X Y Z [--axis x|y|z]"),
        CliArgument("--axis", ("AXIS",), "with --look-at: the frame's axis (x, y or z) that "
                    "points at the point (default z)", numbers=False, choices=("x", "y", "z")),
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "point", as_vec3(self.point, "look-at point"))
        object.__setattr__(self, "axis", as_unit3(self.axis, "tool axis"))

    def errors(self, pose: npt.ArrayLike) -> tuple[float, float]:  # noqa: D102
        m = np.asarray(pose).tolist()
        x, y, z = self.point.tolist()
        d = (x - m[0][3], y - m[1][3], z - m[2][3])
        if math.hypot(*d) < 1e-12:
            return 0.0, math.pi
        return 0.0, _angle_lists(_rotate(m, self.axis.tolist()), d)

    def packed(self) -> Array:  # noqa: D102
        return _packed(position=self.point, axis=self.axis)

    def nlp_params(self) -> Array:  # noqa: D102
        return np.concatenate([self.point, self.axis])

    def nlp_residual(self, ca: Any, rot: Any, pos: Any, params: Any, *,  # noqa: D102
                     position_scale: float, rotation_scale: float) -> Any:
        d = params[0:3] - pos
        return rotation_scale * (rot @ params[3:6] - d / ca.sqrt(ca.sumsqr(d) + 1e-12))

    @classmethod
    def from_file(cls, sec: Section, *, frame: str | None, weight: float,  # noqa: D102
                  tolerance: Tolerance) -> Goal:
        return cls(np.array(sec.vector("point", 3)),
                   np.array(sec.vector("axis", 3, (0.0, 0.0, 1.0))), frame=frame, weight=weight,
                   tolerance=tolerance)

    def file_fields(self) -> dict[str, Any]:  # noqa: D102
        return {"point": _vec(self.point), "axis": _vec(self.axis)}

    @classmethod
    def from_cli(cls, given: CliGoalInput) -> Goal | None:  # noqa: D102
        point, axis = given.value("--look-at"), given.value("--axis")
        if point is None:
            if axis is not None:
                raise InputError("--axis names the axis of --look-at; give --look-at X Y Z too")
            return None
        if given.xyz is not None:
            raise InputError("--look-at leaves the position free; give it without --xyz (to "
                             "fix the position too, give --xyz with --direction AXIS DX DY DZ, "
                             "the direction from --xyz to the point)")
        return cls(np.array(point, dtype=float), np.array(_AXES[axis or "z"]),
                   frame=given.frame, tolerance=given.tolerance)

    def line_span(self, start: Array) -> tuple[float, float]:  # noqa: D102
        d = self.point - start[:3, 3]
        n = float(np.linalg.norm(d))
        return 0.0, (_span_angle(start[:3, :3] @ self.axis, d / n) if n > 1e-12 else 0.0)

    def interpolate(self, start: Array, s: float) -> Goal:  # noqa: D102
        # the point looked at moves on the line from the one the axis points at now, at the
        # same distance, to the goal's point
        p0 = start[:3, 3]
        seen = p0 + float(np.linalg.norm(self.point - p0)) * (start[:3, :3] @ self.axis)
        return replace(self, point=seen + s * (self.point - seen))


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
    for g in goals:
        if getattr(type(g), "kind", None) is None:
            raise InputError(f"{type(g).__name__} has no goal kind: derive it from one of "
                             f"{', '.join(c.__name__ for c in goal_classes())}, or give it a "
                             "kind of its own (docs/ik-goals.md, 'Adding a goal type')")
    frames = [g.frame for g in goals]
    if len(set(frames)) != len(frames):
        raise InputError("two goals name the same frame; combine them into one goal")
    return goals
