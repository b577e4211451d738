"""Collision capsules: each link's geometry approximated by capsules, for keep-out constraints.

A capsule is a segment (two end points) plus a radius: every point within the radius of the
segment is inside. The approximations are conservative (they contain the shape):

* capsule: exact; sphere: a capsule of zero length; cylinder: the capsule on its axis with the
  same radius and end points at the cap centres;
* box: the capsule along its longest edge, end points at the centres of the two end faces,
  radius half the diagonal of the cross section;
* mesh: the capsule along the principal axis of the vertices, spanning them, with the largest
  distance of a vertex from that axis as radius.

Capsules come from each link's collision shapes, else its visual shapes, else the default shapes
of :mod:`armctl.kinematics.linkshapes`, so every link has at least one.
:func:`collision_capsules` gives them per link in the link frames (what the drawing code
checks); :func:`arm_capsules` gives those of the links that move, in the frames of the actuated
joints that carry them (what the keep-out constraints of the NLP solver use), and
:func:`world_segments` places them at a joint vector. Only numpy is needed (trimesh for mesh
files).
"""

from __future__ import annotations

import math
import weakref
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from armctl.config.schema import ArmSpec, Box, Capsule, Cylinder, Geometry, Mesh, Sphere
from armctl.kinematics.linkshapes import GeometryRole, link_shapes, read_mesh
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = [
    "BodyCapsule",
    "LinkCapsule",
    "arm_capsules",
    "collision_capsules",
    "segment_box_distance",
    "segment_point_distance",
    "shape_capsule",
    "world_segments",
]


def _t3(v: Array) -> tuple[float, float, float]:
    return float(v[0]), float(v[1]), float(v[2])


@dataclass(frozen=True)
class LinkCapsule:
    """A capsule bound to a link.

    Attributes:
        link: The link's name.
        a: First end point of the segment, in the link frame [m].
        b: Second end point, in the link frame [m].
        radius: Radius [m].
    """

    link: str
    a: tuple[float, float, float]
    b: tuple[float, float, float]
    radius: float

    def world(self, link_pose: npt.ArrayLike) -> tuple[Array, Array]:
        """The end points in the base frame, given the link's ``(4, 4)`` pose."""
        t = np.asarray(link_pose, dtype=float)
        return t[:3, :3] @ np.asarray(self.a) + t[:3, 3], t[:3, :3] @ np.asarray(self.b) + t[:3, 3]


@dataclass(frozen=True)
class BodyCapsule:
    """A capsule of a moving link, in the frame of the actuated joint that carries it.

    Attributes:
        link: Name of the link it covers.
        body: Index of the actuated joint whose frame carries it.
        a: One end of the segment in the body frame [m].
        b: The other end in the body frame [m].
        radius: Radius [m].
    """

    link: str
    body: int
    a: tuple[float, float, float]
    b: tuple[float, float, float]
    radius: float


def _axis_capsule(shape: Geometry, half: float, radius: float) -> tuple[Array, Array, float]:
    t = shape.origin.matrix()
    z = t[:3, 2] * half
    return t[:3, 3] - z, t[:3, 3] + z, radius


def shape_capsule(shape: Geometry, link: str = "?",
                  config: Path | None = None) -> tuple[Array, Array, float]:
    """A capsule containing one shape, in the frame of the shape's origin (the link frame).

    Args:
        shape: The shape.
        link: The link it belongs to (for error messages about mesh files).
        config: The arm config it comes from (for error messages).

    Returns:
        ``(a, b, radius)``: end points ``(3,)`` [m] and radius [m].

    Raises:
        MeshLoadError: If a mesh file is missing or unreadable.
    """
    if isinstance(shape, Capsule | Cylinder):
        return _axis_capsule(shape, shape.length / 2.0, shape.radius)
    if isinstance(shape, Sphere):
        return _axis_capsule(shape, 0.0, shape.radius)
    t = shape.origin.matrix()
    if isinstance(shape, Box):
        size = np.asarray(shape.size, dtype=float)
        k = int(np.argmax(size))
        others = np.delete(size, k)
        half = t[:3, k] * size[k] / 2.0
        return t[:3, 3] - half, t[:3, 3] + half, float(np.linalg.norm(others) / 2.0)
    if isinstance(shape, Mesh):
        raw, _ = read_mesh(shape.path, link, config)
        verts = (raw * np.asarray(shape.scale, dtype=float)) @ t[:3, :3].T + t[:3, 3]
        centre = verts.mean(axis=0)
        _, _, vt = np.linalg.svd(verts - centre, full_matrices=False)
        axis = vt[0]
        s = (verts - centre) @ axis
        radial = (verts - centre) - np.outer(s, axis)
        radius = float(np.linalg.norm(radial, axis=1).max())
        return centre + s.min() * axis, centre + s.max() * axis, radius
    raise TypeError(f"unknown shape {shape!r}")  # pragma: no cover


def collision_capsules(spec: ArmSpec,
                       radius: float | None = None) -> dict[str, tuple[LinkCapsule, ...]]:
    """Capsules approximating every link's collision geometry, in the link frames.

    Collision shapes are used when a link has them, else its visual shapes, else the default
    shapes.

    Args:
        spec: The arm description (``arm.spec``).
        radius: Capsule radius of the default shapes [m]; ``None`` scales it with the arm
            (:func:`~armctl.kinematics.linkshapes.default_radius`).

    Returns:
        Link name -> its capsules, for every link of the arm.

    Raises:
        MeshLoadError: If a mesh file is missing or unreadable.
    """
    out: dict[str, tuple[LinkCapsule, ...]] = {}
    for name, ls in link_shapes(spec, GeometryRole.COLLISION, radius).items():
        caps = []
        for shape in ls.shapes:
            a, b, r = shape_capsule(shape, name, spec.file)
            caps.append(LinkCapsule(name, _t3(a), _t3(b), r))
        out[name] = tuple(caps)
    return out


def _body_capsules(model: KinematicModel, radius: float | None) -> tuple[BodyCapsule, ...]:
    out: list[BodyCapsule] = []
    for name, caps in collision_capsules(model.spec, radius).items():
        k = model.frame_index(name)
        body = int(model.tree.anchor[k])
        if body < 0:  # fixed to the base: nothing a joint does moves it
            continue
        off = model.tree.frame_offset(k)
        for c in caps:
            a = off[:3, :3] @ np.asarray(c.a) + off[:3, 3]
            b = off[:3, :3] @ np.asarray(c.b) + off[:3, 3]
            out.append(BodyCapsule(name, body, _t3(a), _t3(b), c.radius))
    return tuple(out)


_CACHE: weakref.WeakKeyDictionary[KinematicModel, dict[float | None, tuple[BodyCapsule, ...]]] = (
    weakref.WeakKeyDictionary())


def arm_capsules(model: KinematicModel,
                 radius: float | None = None) -> tuple[BodyCapsule, ...]:
    """Capsules covering every link that moves (computed once per model and radius).

    Links fixed to the base are left out: nothing an IK solve does moves them.

    Args:
        model: The arm.
        radius: Capsule radius of the default shapes of links without geometry [m]; ``None``
            scales it with the arm (:func:`~armctl.kinematics.linkshapes.default_radius`).

    Returns:
        The capsules, in body coordinates.

    Raises:
        MeshLoadError: If a mesh file is missing or unreadable.
    """
    per_model = _CACHE.setdefault(model, {})
    if radius not in per_model:
        per_model[radius] = _body_capsules(model, radius)
    return per_model[radius]


def world_segments(model: KinematicModel, q: npt.ArrayLike,
                   capsules: tuple[BodyCapsule, ...]) -> tuple[Array, Array]:
    """Ends of the capsules' segments in the base frame at ``q``.

    Args:
        model: The arm.
        q: Joint vector ``(dof,)``.
        capsules: The capsules.

    Returns:
        ``(a, b)``, each ``(k, 3)`` [m].
    """
    frames = model.fk_frames(q)
    # the link a joint moves has the joint's frame (compiled with an identity offset)
    poses = {j: frames[model.frame_index(joint.child)]
             for j, joint in enumerate(model.spec.actuated_joints)}
    a = np.array([poses[c.body][:3, :3] @ c.a + poses[c.body][:3, 3] for c in capsules])
    b = np.array([poses[c.body][:3, :3] @ c.b + poses[c.body][:3, 3] for c in capsules])
    return a.reshape(-1, 3), b.reshape(-1, 3)


def segment_point_distance(a: Array, b: Array, p: Array) -> float:
    """Distance from point ``p`` to the segment ``a``-``b`` [m]."""
    d = b - a
    dd = float(d @ d)
    t = 0.0 if dd < 1e-18 else min(max(float((p - a) @ d) / dd, 0.0), 1.0)
    return float(np.linalg.norm(a + t * d - p))


def _point_box_distance(p: Array, lower: Array, upper: Array) -> float:
    centre, half = (lower + upper) / 2.0, (upper - lower) / 2.0
    q = np.abs(p - centre) - half
    return float(np.linalg.norm(np.maximum(q, 0.0)) + min(float(q.max()), 0.0))


def segment_box_distance(a: Array, b: Array, lower: Array, upper: Array) -> float:
    """Signed distance from the segment ``a``-``b`` to an axis-aligned box [m].

    Negative when the segment enters the box: minus its penetration depth, the least
    translation that takes it out (the least overlap of the two along the separating-axis
    candidates: the box's face normals and the segment's direction crossed with the box's
    edges). Apart, the distance along a segment to a convex set is convex, so a golden-section
    search finds the minimum.
    """
    g = (math.sqrt(5.0) - 1.0) / 2.0
    lo, hi = 0.0, 1.0

    def f(t: float) -> float:
        return _point_box_distance(a + t * (b - a), lower, upper)

    x1, x2 = hi - g * (hi - lo), lo + g * (hi - lo)
    f1, f2 = f(x1), f(x2)
    for _ in range(60):
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - g * (hi - lo)
            f1 = f(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + g * (hi - lo)
            f2 = f(x2)
    gap = min(f1, f2, f(0.0), f(1.0))
    if gap > 0.0:
        return gap
    centre, half = (lower + upper) / 2.0, (upper - lower) / 2.0
    ends = np.stack([a - centre, b - centre])
    d = b - a
    axes = [np.eye(3)[i] for i in range(3)]
    for i in range(3):
        c = np.cross(d, np.eye(3)[i])
        if np.linalg.norm(c) > 1e-9 * max(float(np.linalg.norm(d)), 1e-300):
            axes.append(c / np.linalg.norm(c))
    depth = min(min(float((ends @ n).max() + np.abs(n) @ half),
                    float(np.abs(n) @ half - (ends @ n).min())) for n in axes)
    return -depth
