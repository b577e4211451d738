"""Keep-out zones: no moving link may enter a sphere or a box.

The links are covered by capsules (:func:`armctl.kinematics.capsules.arm_capsules`, the same ones
``armctl.render`` draws); each constraint has one CasADi row per capsule (or per capsule sample
for boxes) and measures its violation exactly from forward kinematics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from armctl.errors import InputError
from armctl.ik.goals import as_vec3
from armctl.ik.nlp.constraints import Constraint, Segment, _positive
from armctl.kinematics.capsules import (
    arm_capsules,
    segment_box_distance,
    segment_point_distance,
    world_segments,
)
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["KeepOutBox", "KeepOutSphere"]


@dataclass(frozen=True)
class _KeepOut(Constraint):
    """What the keep-out zones share: they act on the capsules of every moving link.

    ``link_radius`` [m] is the capsule radius of the default shapes of links without geometry
    (``None``: scaled with the arm; see :func:`armctl.kinematics.capsules.arm_capsules`).
    """

    link_radius: float | None = field(default=None, kw_only=True)
    on_links: ClassVar[bool] = True

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.link_radius is not None:
            _positive(self.link_radius, "link radius [m]")

    def structure(self) -> tuple[object, ...]:
        return (*super().structure(), self.link_radius)

    def depth(self, a: Array, b: Array, radius: float) -> float:
        """How deep a capsule ``a``-``b`` of ``radius`` [m] reaches into the zone [m] (< 0: out)."""
        raise NotImplementedError

    def violation(self, model: KinematicModel, q: Array) -> float:
        caps = arm_capsules(model, self.link_radius)
        a, b = world_segments(model, q, caps)
        return max([0.0, *(self.depth(a[k], b[k], c.radius) for k, c in enumerate(caps))])


@dataclass(frozen=True)
class KeepOutSphere(_KeepOut):
    """No moving link (capsule) enters a sphere of ``radius`` [m] around ``center`` [m].

    ``link_radius`` [m]: see :class:`_KeepOut`.
    """

    center: Array
    radius: float
    kind: ClassVar[str] = "keep out of sphere"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "center", as_vec3(self.center, "keep-out centre"))
        object.__setattr__(self, "radius", _positive(self.radius, "keep-out radius [m]"))

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([self.center, [self.radius]])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        c, r = p[0:3], p[3]
        out = []
        for a, b, rc, length in segments:
            d = b - a
            if length < 1e-9:
                dist2 = ca.sumsqr(a - c)
            else:
                t = ca.fmin(ca.fmax(ca.dot(c - a, d) / (ca.sumsqr(d) + 1e-12), 0), 1)
                dist2 = ca.sumsqr(a + t * d - c)
            # ((r + rc)^2 - dist^2) / 2(r + rc): the penetration depth to first order
            out.append(((r + rc) ** 2 - dist2) / (2 * (r + rc)))
        return ca.vertcat(*out) if out else ca.SX(0, 1)

    def depth(self, a: Array, b: Array, radius: float) -> float:  # noqa: D102
        return radius + self.radius - segment_point_distance(a, b, self.center)


@dataclass(frozen=True)
class KeepOutBox(_KeepOut):
    """No moving link (capsule) enters an axis-aligned box ``lower``-``upper`` [m] (base frame).

    In the CasADi problem each capsule is sampled at points no farther apart than its radius,
    and each point keeps the radius plus half the spacing from the box, which guarantees the
    whole capsule stays out; the violation is computed exactly. ``link_radius`` [m]: see
    :class:`_KeepOut`.
    """

    lower: Array
    upper: Array
    kind: ClassVar[str] = "keep out of box"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "lower", as_vec3(self.lower, "keep-out box lower corner"))
        object.__setattr__(self, "upper", as_vec3(self.upper, "keep-out box upper corner"))
        if np.any(self.lower >= self.upper):
            raise InputError(f"keep-out box lower corner {self.lower.tolist()} must be below the "
                             f"upper corner {self.upper.tolist()} on every axis")

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([(self.lower + self.upper) / 2, (self.upper - self.lower) / 2])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        centre, half = p[0:3], p[3:6]
        out = []
        for a, b, rc, length in segments:
            d = b - a
            n = max(2, math.ceil(length / max(rc, 1e-3)) + 1) if length > 1e-9 else 1
            spacing = length / (n - 1) if n > 1 else 0.0
            for k in range(n):
                x = a if n == 1 else a + (k / (n - 1)) * d
                e = ca.fabs(x - centre) - half
                outside = ca.sqrt(ca.sumsqr(ca.fmax(e, 0)) + 1e-12) - 1e-6
                inside = ca.fmin(ca.mmax(e), 0)
                out.append(rc + spacing / 2 - (outside + inside))
        return ca.vertcat(*out) if out else ca.SX(0, 1)

    def depth(self, a: Array, b: Array, radius: float) -> float:  # noqa: D102
        return radius - segment_box_distance(a, b, self.lower, self.upper)
