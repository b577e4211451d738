"""General goals for the NLP solver: planes, half-spaces, combinations, and keep-out.

The lecture (L. Kavan, *Metody skeletální animace*, 2002) names planes, half-spaces and their
combinations as the general goals that IK as non-linear programming admits (as do J. Zhao and
N. I. Badler, *Inverse Kinematics Positioning Using Nonlinear Programming for Highly Articulated
Figures*, ACM Transactions on Graphics, 1994).

Every constraint is a frozen dataclass that is either *hard* (``weight=None``: success requires
it to hold within ``tolerance``) or *soft* (``weight`` > 0: its squared violation is added to
the cost). Point constraints act on the origin of ``frame`` (``None``: the tool frame); keep-out
constraints (:mod:`armctl.ik.nlp.keep_out`) act on every moving link.

Each constraint knows its violation by forward kinematics (:meth:`Constraint.violation`, the
truth that decides success) and how to write itself as rows ``g(q, p) <= 0`` or ``g = 0`` of a
CasADi problem whose numbers ``p`` are parameters (:meth:`Constraint.rows`), so a new target
never rebuilds the problem.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from armctl.errors import InputError
from armctl.ik.goals import as_unit3, as_vec3
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = [
    "AxisInCone",
    "Constraint",
    "InBox",
    "InHalfSpace",
    "InSphere",
    "OnLine",
    "OnPlane",
    "Segment",
]


#: A capsule in the base frame: its ends ``a``, ``b`` as CasADi expressions, its radius and its
#: (constant) length [m].
Segment = tuple[Any, Any, float, float]


def _positive(value: float, what: str) -> float:
    if not (math.isfinite(value) and value > 0):
        raise InputError(f"{what} must be a positive number, got {value}")
    return float(value)


@dataclass(frozen=True)
class Constraint:
    """Base of the constraint types.

    Attributes:
        frame: The frame whose origin (or axis) is constrained; the tool frame when ``None``.
            Keep-out constraints ignore it.
        weight: ``None`` for a hard constraint; a positive weight makes it a cost term.
        tolerance: Largest violation that counts as holding [m] ([rad] for cones).
    """

    frame: str | None = field(default=None, kw_only=True)
    weight: float | None = field(default=None, kw_only=True)
    tolerance: float = field(default=1e-5, kw_only=True)

    #: Short name used in messages and goals files.
    kind: ClassVar[str] = ""
    #: Whether the rows are equalities (else inequalities ``g <= 0``).
    equality: ClassVar[bool] = False
    #: Whether the rows act on the arm's capsules rather than on a frame.
    on_links: ClassVar[bool] = False

    def __post_init__(self) -> None:
        if self.on_links and self.frame is not None:
            raise InputError(f"a {self.kind} constraint acts on every moving link, not on a "
                             f"frame; remove frame={self.frame!r}")
        if self.weight is not None:
            _positive(self.weight, f"the weight of a {self.kind} constraint")
        _positive(self.tolerance, f"the tolerance of a {self.kind} constraint")

    @property
    def hard(self) -> bool:
        """Whether success requires this constraint."""
        return self.weight is None

    def params(self) -> Array:
        """The numbers that the CasADi rows take as parameters."""
        raise NotImplementedError

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:
        """The constraint as a column of CasADi expressions.

        Args:
            ca: The ``casadi`` module.
            rot: Rotation ``(3, 3)`` of the frame.
            pos: Position ``(3, 1)`` of the frame [m].
            segments: The arm's capsules with this constraint's ``link_radius`` (keep-out).
            p: Parameter symbols, laid out as :meth:`params`.

        Returns:
            ``g`` with ``g = 0`` (equality) or ``g <= 0``, in [m] or unitless for cones.
        """
        raise NotImplementedError

    def violation(self, model: KinematicModel, q: Array) -> float:
        """How far ``q`` is from satisfying the constraint, by forward kinematics (0: holds)."""
        raise NotImplementedError

    def describe(self, model: KinematicModel) -> str:
        """A short human-readable name, e.g. ``"on plane (frame tool, hard)"``."""
        where = "links" if self.on_links else f"frame {self.frame or model.tool}"
        mode = "hard" if self.hard else f"weight {self.weight:g}"
        return f"{self.kind} ({where}, {mode})"

    def structure(self) -> tuple[object, ...]:
        """What fixes the shape of the CasADi problem (everything but the numbers)."""
        return (type(self).__name__, None if self.on_links else self.frame, self.hard,
                len(self.params()))


def _position(model: KinematicModel, q: Array, frame: str | None) -> Array:
    return np.asarray(model.fk(q, frame)[:3, 3])


@dataclass(frozen=True)
class OnPlane(Constraint):
    """The frame origin lies on a plane through ``point`` [m] with unit ``normal``."""

    point: Array
    normal: Array
    kind: ClassVar[str] = "on plane"
    equality: ClassVar[bool] = True

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "point", as_vec3(self.point, "plane point"))
        object.__setattr__(self, "normal", as_unit3(self.normal, "plane normal"))

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([self.point, self.normal])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        return ca.dot(p[3:6], pos - p[0:3])

    def violation(self, model: KinematicModel, q: Array) -> float:  # noqa: D102
        return abs(float(self.normal @ (_position(model, q, self.frame) - self.point)))


@dataclass(frozen=True)
class InHalfSpace(Constraint):
    """The frame origin lies on the side of a plane that ``normal`` points to.

    Attributes:
        point: A point on the boundary plane [m].
        normal: Unit normal pointing into the allowed half-space.
    """

    point: Array
    normal: Array
    kind: ClassVar[str] = "in half-space"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "point", as_vec3(self.point, "half-space point"))
        object.__setattr__(self, "normal", as_unit3(self.normal, "half-space normal"))

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([self.point, self.normal])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        return -ca.dot(p[3:6], pos - p[0:3])

    def violation(self, model: KinematicModel, q: Array) -> float:  # noqa: D102
        return max(0.0, -float(self.normal @ (_position(model, q, self.frame) - self.point)))


@dataclass(frozen=True)
class OnLine(Constraint):
    """The frame origin lies on the line through ``point`` [m] along unit ``direction``."""

    point: Array
    direction: Array
    kind: ClassVar[str] = "on line"
    equality: ClassVar[bool] = True

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "point", as_vec3(self.point, "line point"))
        object.__setattr__(self, "direction", as_unit3(self.direction, "line direction"))

    def _basis(self) -> tuple[Array, Array]:
        d = self.direction
        helper = np.eye(3)[int(np.argmin(np.abs(d)))]
        u = np.cross(d, helper)
        u /= np.linalg.norm(u)
        return u, np.cross(d, u)

    def params(self) -> Array:  # noqa: D102
        u, v = self._basis()
        return np.concatenate([self.point, u, v])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        d = pos - p[0:3]
        return ca.vertcat(ca.dot(p[3:6], d), ca.dot(p[6:9], d))

    def violation(self, model: KinematicModel, q: Array) -> float:  # noqa: D102
        d = _position(model, q, self.frame) - self.point
        return float(np.linalg.norm(d - (d @ self.direction) * self.direction))


@dataclass(frozen=True)
class InBox(Constraint):
    """The frame origin lies in an axis-aligned box ``lower <= p <= upper`` [m] (base frame)."""

    lower: Array
    upper: Array
    kind: ClassVar[str] = "in box"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "lower", as_vec3(self.lower, "box lower corner"))
        object.__setattr__(self, "upper", as_vec3(self.upper, "box upper corner"))
        if np.any(self.lower > self.upper):
            raise InputError(f"box lower corner {self.lower.tolist()} exceeds the upper corner "
                             f"{self.upper.tolist()}; swap the offending values")

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([self.lower, self.upper])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        return ca.vertcat(p[0:3] - pos, pos - p[3:6])

    def violation(self, model: KinematicModel, q: Array) -> float:  # noqa: D102
        x = _position(model, q, self.frame)
        return float(max(0.0, float(np.max(self.lower - x)), float(np.max(x - self.upper))))


@dataclass(frozen=True)
class InSphere(Constraint):
    """The frame origin lies within ``radius`` [m] of ``center`` [m]."""

    center: Array
    radius: float
    kind: ClassVar[str] = "in sphere"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "center", as_vec3(self.center, "sphere centre"))
        object.__setattr__(self, "radius", _positive(self.radius, "sphere radius [m]"))

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([self.center, [self.radius]])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        # (|x - c|^2 - r^2) / 2r: smooth, and the distance outside the sphere to first order
        return (ca.sumsqr(pos - p[0:3]) - p[3] ** 2) / (2 * p[3])

    def violation(self, model: KinematicModel, q: Array) -> float:  # noqa: D102
        x = _position(model, q, self.frame)
        return max(0.0, float(np.linalg.norm(x - self.center)) - self.radius)


@dataclass(frozen=True)
class AxisInCone(Constraint):
    """A tool axis points within ``half_angle`` [rad] of ``direction``.

    Attributes:
        direction: Unit direction of the cone's axis in the base frame.
        half_angle: Half the cone's opening angle [rad], in (0, pi].
        axis: The tool axis in the frame's own coordinates (default: its z axis).
    """

    direction: Array
    half_angle: float
    axis: Array = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    tolerance: float = field(default=1e-4, kw_only=True)
    kind: ClassVar[str] = "axis in cone"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "direction", as_unit3(self.direction, "cone direction"))
        object.__setattr__(self, "axis", as_unit3(self.axis, "tool axis"))
        if not 0 < self.half_angle <= math.pi:
            raise InputError(f"a cone's half angle must be in (0, pi] rad, got {self.half_angle}")

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([self.direction, self.axis, [math.cos(self.half_angle)]])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        return p[6] - ca.dot(p[0:3], rot @ p[3:6])

    def violation(self, model: KinematicModel, q: Array) -> float:  # noqa: D102
        a = model.fk(q, self.frame)[:3, :3] @ self.axis
        angle = math.atan2(float(np.linalg.norm(np.cross(a, self.direction))),
                           float(a @ self.direction))
        return max(0.0, angle - self.half_angle)
