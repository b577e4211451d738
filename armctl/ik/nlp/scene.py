"""The scene's obstacles as keep-out constraints: the same shapes the collision checker uses.

:func:`scene_keep_out` turns the scene of a collision checker
(:class:`armctl.collision.CollisionModel`: the table, spheres, boxes, capsules, cylinders and
meshes of its :class:`armctl.config.scene.SceneSpec`) into hard constraints of the NLP solver on
the arm's capsules (:func:`armctl.kinematics.capsules.arm_capsules`, the capsules the checker
uses), each kept the scene's padding away. The obstacles become the checker's primitives: the
table a half-space, a cylinder the capsule around it, a mesh the box around its vertices along
their principal axes. Link-obstacle pairs of the allowed-collision matrix are left out, as the
checker leaves them out.

The rows are exact for the table, spheres and capsules and conservative for boxes (points
sampled along each arm capsule keep half the sampling step more), and keep :data:`MARGIN`
beyond the padding, so an answer that satisfies them is free for the
checker too; :meth:`_SceneZone.violation` is exact. Contacts between the arm's own links are
not constraints: the solver checks its answers with the checker and restarts (see
:mod:`armctl.ik.nlp.solver`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from armctl.collision.primitives import PrimitiveKind, obstacle_primitive
from armctl.config.scene import TABLE, Obstacle
from armctl.errors import InputError
from armctl.ik.goals import as_vec3
from armctl.ik.nlp.constraints import Constraint, Segment
from armctl.ik.nlp.keep_out import _KeepOut
from armctl.kinematics.capsules import (
    arm_capsules,
    segment_box_distance,
    world_segments,
)
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.collision.model import CollisionModel

__all__ = ["MARGIN", "KeepAboveTable", "KeepOutCapsule", "KeepOutOrientedBox", "scene_keep_out"]

#: Room the rows keep beyond the padding [m], so that a solver's answer (which meets its rows
#: only to its own tolerance) is free for the collision checker.
MARGIN = 2e-4


@dataclass(frozen=True)
class _SceneZone(_KeepOut):
    """What the scene's obstacles share.

    Attributes:
        padding: Distance every selected capsule keeps from the obstacle [m].
        capsules: Indices into :func:`~armctl.kinematics.capsules.arm_capsules` of the capsules
            it acts on (``None``: all; the allowed-collision matrix leaves some out).
        name: The obstacle's name (messages).
        margin: Extra room the CasADi rows keep beyond ``padding`` [m] (not the violation).
    """

    padding: float = field(default=0.0, kw_only=True)
    capsules: tuple[int, ...] | None = field(default=None, kw_only=True)
    name: str = field(default="", kw_only=True)
    margin: float = field(default=MARGIN, kw_only=True)

    def __post_init__(self) -> None:
        super().__post_init__()
        for what, v in (("padding", self.padding), ("margin", self.margin)):
            if not (math.isfinite(v) and v >= 0.0):
                raise InputError(f"the {what} of keep-out zone {self.name!r} must be a number "
                                 f">= 0 [m], got {v}")
        if self.capsules is not None:
            object.__setattr__(self, "capsules", tuple(int(k) for k in self.capsules))

    def structure(self) -> tuple[object, ...]:
        return (*super().structure(), self.capsules)

    def _chosen(self, segments: list[Segment]) -> list[Segment]:
        return segments if self.capsules is None else [segments[k] for k in self.capsules]

    def violation(self, model: KinematicModel, q: Array) -> float:
        caps = arm_capsules(model, self.link_radius)
        a, b = world_segments(model, q, caps)
        keep = range(len(caps)) if self.capsules is None else self.capsules
        return max([0.0, *(self.depth(a[k], b[k], caps[k].radius) for k in keep)])

    def describe(self, model: KinematicModel) -> str:
        mode = "hard" if self.hard else f"weight {self.weight:g}"
        return f"{self.kind} {self.name!r} (links, {mode})" if self.name else super().describe(
            model)


@dataclass(frozen=True)
class KeepAboveTable(_SceneZone):
    """Every selected capsule stays ``padding`` [m] above the plane ``z = height`` [m]."""

    height: float = 0.0
    kind: ClassVar[str] = "keep above table"

    def params(self) -> Array:  # noqa: D102
        return np.array([self.height, self.padding + self.margin])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        out = []
        for a, b, rc, _ in self._chosen(segments):
            out += [p[0] + p[1] + rc - a[2], p[0] + p[1] + rc - b[2]]
        return ca.vertcat(*out) if out else ca.SX(0, 1)

    def depth(self, a: Array, b: Array, radius: float) -> float:  # noqa: D102
        return radius + self.padding - (min(float(a[2]), float(b[2])) - self.height)


@dataclass(frozen=True)
class KeepOutCapsule(_SceneZone):
    """Every selected capsule stays ``padding`` [m] from the capsule ``a``-``b`` of ``radius``.

    A sphere is a capsule with ``a == b``. One row per arm capsule: the distance between the
    two segments from their closest points (the line-line solution clamped to the segments,
    then re-projected), exact.
    """

    a: Array
    b: Array
    radius: float
    kind: ClassVar[str] = "keep out of"

    def __post_init__(self) -> None:
        super().__post_init__()
        object.__setattr__(self, "a", as_vec3(self.a, "obstacle capsule end"))
        object.__setattr__(self, "b", as_vec3(self.b, "obstacle capsule end"))
        if not (math.isfinite(self.radius) and self.radius >= 0.0):
            raise InputError(f"obstacle {self.name!r}: radius must be >= 0 [m], got "
                             f"{self.radius}")

    @property
    def point(self) -> bool:
        """Whether the obstacle is a sphere (its axis has no length)."""
        return float(np.linalg.norm(self.b - self.a)) < 1e-9

    def structure(self) -> tuple[object, ...]:
        """The base structure, and whether the obstacle is a sphere (other rows)."""
        return (*super().structure(), self.point)

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([self.a, self.b, [self.radius + self.padding + self.margin]])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        ea, eb, reach = p[0:3], p[3:6], p[6]
        e2 = eb - ea
        ee = ca.sumsqr(e2)

        def clamp(x: Any) -> Any:
            return ca.fmin(ca.fmax(x, 0), 1)

        out = []
        for a, b, rc, length in self._chosen(segments):
            d = b - a
            r = a - ea
            if self.point and length < 1e-9:
                dist2 = ca.sumsqr(r)
            elif self.point:  # the sphere's centre onto the arm's segment
                dist2 = ca.sumsqr(a + clamp(-ca.dot(d, r) / ca.sumsqr(d)) * d - ea)
            elif length < 1e-9:  # the arm's sphere onto the obstacle's axis
                dist2 = ca.sumsqr(ea + clamp(ca.dot(e2, r) / ee) * e2 - a)
            else:
                aa, bb, cc, ff = ca.sumsqr(d), ca.dot(d, e2), ca.dot(d, r), ca.dot(e2, r)
                s = clamp((bb * ff - cc * ee) / (aa * ee - bb ** 2 + 1e-12))
                t_raw = (bb * s + ff) / ee
                s = ca.if_else(t_raw < 0, clamp(-cc / aa),
                               ca.if_else(t_raw > 1, clamp((bb - cc) / aa), s))
                dist2 = ca.sumsqr(a + s * d - ea - clamp(t_raw) * e2)
            big = reach + rc
            out.append((big ** 2 - dist2) / (2 * big))  # the depth to first order
        return ca.vertcat(*out) if out else ca.SX(0, 1)

    def depth(self, a: Array, b: Array, radius: float) -> float:  # noqa: D102
        return radius + self.radius + self.padding - _segment_distance(a, b, self.a, self.b)


@dataclass(frozen=True)
class KeepOutOrientedBox(_SceneZone):
    """Every selected capsule stays ``padding`` [m] from a box.

    The box has half sizes ``half`` [m] along the columns of ``rotation`` (its axes in the base
    frame), around ``centre`` [m]. Each arm capsule is sampled at points no farther apart than
    its radius, each kept half the spacing farther, as :class:`~armctl.ik.nlp.KeepOutBox`.
    """

    rotation: Array
    centre: Array
    half: Array
    kind: ClassVar[str] = "keep out of"

    def __post_init__(self) -> None:
        super().__post_init__()
        rot = np.asarray(self.rotation, dtype=float)
        if rot.shape != (3, 3) or not np.allclose(rot.T @ rot, np.eye(3), atol=1e-9):
            raise InputError(f"obstacle {self.name!r}: rotation must be a (3, 3) rotation matrix")
        object.__setattr__(self, "rotation", rot)
        object.__setattr__(self, "centre", as_vec3(self.centre, "box centre"))
        object.__setattr__(self, "half", as_vec3(self.half, "box half sizes"))
        if np.any(self.half <= 0):
            raise InputError(f"obstacle {self.name!r}: box sizes must be positive, got "
                             f"{(2 * self.half).tolist()}")

    def params(self) -> Array:  # noqa: D102
        return np.concatenate([self.rotation.reshape(-1), self.centre, self.half,
                               [self.padding + self.margin]])

    def rows(self, ca: Any, rot: Any, pos: Any, segments: list[Segment], p: Any) -> Any:  # noqa: D102
        r = ca.reshape(p[0:9], 3, 3).T  # params hold the rotation row by row
        centre, half, room = p[9:12], p[12:15], p[15]
        out = []
        for a, b, rc, length in self._chosen(segments):
            d = b - a
            n = max(2, math.ceil(length / max(rc, 1e-3)) + 1) if length > 1e-9 else 1
            spacing = length / (n - 1) if n > 1 else 0.0
            for k in range(n):
                x = a if n == 1 else a + (k / (n - 1)) * d
                e = ca.fabs(r.T @ (x - centre)) - half
                outside = ca.sqrt(ca.sumsqr(ca.fmax(e, 0)) + 1e-12) - 1e-6
                inside = ca.fmin(ca.mmax(e), 0)
                out.append(rc + room + spacing / 2 - (outside + inside))
        return ca.vertcat(*out) if out else ca.SX(0, 1)

    def depth(self, a: Array, b: Array, radius: float) -> float:  # noqa: D102
        la = self.rotation.T @ (a - self.centre)
        lb = self.rotation.T @ (b - self.centre)
        return radius + self.padding - segment_box_distance(la, lb, -self.half, self.half)


def _segment_distance(a: Array, b: Array, c: Array, d: Array) -> float:
    """Distance between the segments ``a``-``b`` and ``c``-``d`` [m].

    The closest points of the two lines, clamped to the segments and re-projected (exact,
    parallel and point-like segments included).
    """
    d1, d2, r = b - a, d - c, a - c
    aa, ee, ff = float(d1 @ d1), float(d2 @ d2), float(d2 @ r)
    if aa < 1e-18 and ee < 1e-18:
        return float(np.linalg.norm(r))
    if aa < 1e-18:
        s, t = 0.0, min(max(ff / ee, 0.0), 1.0)
    else:
        cc = float(d1 @ r)
        if ee < 1e-18:
            s, t = min(max(-cc / aa, 0.0), 1.0), 0.0
        else:
            bb = float(d1 @ d2)
            denom = aa * ee - bb * bb
            s = min(max((bb * ff - cc * ee) / denom, 0.0), 1.0) if denom > 1e-18 else 0.0
            t = (bb * s + ff) / ee
            if t < 0.0:
                s, t = min(max(-cc / aa, 0.0), 1.0), 0.0
            elif t > 1.0:
                s, t = min(max((bb - cc) / aa, 0.0), 1.0), 1.0
    return float(np.linalg.norm(a + s * d1 - c - t * d2))


def _zone(ob: Obstacle, world_to_base: Array, config: Any, common: dict[str, Any]) -> _SceneZone:
    """One obstacle as a keep-out zone, as the collision checker sees it (its primitive)."""
    p = obstacle_primitive(ob, world_to_base, config)
    if p.kind is PrimitiveKind.BOX:
        return KeepOutOrientedBox(p.rotation, p.centre, p.half, **common)
    return KeepOutCapsule(p.a, p.b, p.radius, **common)  # a sphere: a capsule of no length


def scene_keep_out(checker: CollisionModel, *, margin: float = MARGIN) -> tuple[Constraint, ...]:
    """The scene of a collision checker as hard NLP keep-out constraints.

    Args:
        checker: The collision checker (``CollisionModel.of(arm, scene)``): its arm, scene
            (table, obstacles, padding, ``base_in_world``) and allowed-collision matrix.
        margin: Room the rows keep beyond the scene's padding [m].

    Returns:
        One constraint per obstacle (and the table) that some moving link may touch: pass them
        as ``constraints=`` to ``arm.ik(..., solver="nlp")``.

    Raises:
        MeshLoadError: A mesh obstacle whose file cannot be read.
    """
    model = checker.model
    scene = checker.scene
    allowed = {p.key for p in checker.allowed.allowed}
    caps = arm_capsules(model)

    def chosen(name: str) -> tuple[int, ...]:
        return tuple(k for k, c in enumerate(caps) if frozenset((c.link, name)) not in allowed)

    out: list[Constraint] = []
    if scene.table is not None:
        keep = chosen(TABLE)
        if keep:
            out.append(KeepAboveTable(scene.table.height, padding=scene.padding, capsules=keep,
                                      name=TABLE, margin=margin))
    world_to_base = np.asarray(np.linalg.inv(scene.base_in_world.matrix()), dtype=np.float64)
    for ob in scene.obstacles:
        keep = chosen(ob.name)
        if keep:
            common = {"padding": scene.padding, "capsules": keep, "name": ob.name,
                      "margin": margin}
            out.append(_zone(ob, world_to_base, scene.file or model.spec.file, common))
    return tuple(out)
