"""Collision capsules: each link's geometry approximated by capsules, for keep-out constraints.

A capsule is a segment (two end points in the link frame) plus a radius: every point within the
radius of the segment is inside. The approximations are conservative (they contain the shape):

* capsule: exact; sphere: a capsule of zero length; cylinder: the capsule on its axis with the
  same radius and end points at the cap centres;
* box: the capsule along its longest edge, end points at the centres of the two end faces,
  radius half the diagonal of the cross section;
* mesh: the capsule along the principal axis of the vertices, spanning them, with the largest
  distance of a vertex from that axis as radius.

Links without geometry of their own use the default shapes (:mod:`armctl.render.linkshapes`),
so every link has at least one capsule. Only numpy is needed (trimesh for mesh files).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from armctl.config.schema import ArmSpec, Box, Capsule, Cylinder, Geometry, Mesh, Sphere
from armctl.render.linkshapes import GeometryRole, link_shapes

__all__ = ["LinkCapsule", "collision_capsules", "shape_capsule"]

Array = npt.NDArray[np.float64]


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
    """
    if isinstance(shape, Capsule):
        return _axis_capsule(shape, shape.length / 2.0, shape.radius)
    if isinstance(shape, Cylinder):
        return _axis_capsule(shape, shape.length / 2.0, shape.radius)
    if isinstance(shape, Sphere):
        return _axis_capsule(shape, 0.0, shape.radius)
    if isinstance(shape, Box):
        size = np.asarray(shape.size, dtype=float)
        k = int(np.argmax(size))
        others = np.delete(size, k)
        t = shape.origin.matrix()
        half = t[:3, k] * size[k] / 2.0
        return t[:3, 3] - half, t[:3, 3] + half, float(np.linalg.norm(others) / 2.0)
    if isinstance(shape, Mesh):
        from armctl.render.shapes import shape_mesh

        verts = shape_mesh(shape, link, config).vertices
        centre = verts.mean(axis=0)
        _, _, vt = np.linalg.svd(verts - centre, full_matrices=False)
        axis = vt[0]
        s = (verts - centre) @ axis
        radial = (verts - centre) - np.outer(s, axis)
        radius = float(np.linalg.norm(radial, axis=1).max())
        return centre + s.min() * axis, centre + s.max() * axis, radius
    raise TypeError(f"unknown shape {shape!r}")  # pragma: no cover


def collision_capsules(spec: ArmSpec) -> dict[str, tuple[LinkCapsule, ...]]:
    """Capsules approximating every link's collision geometry, in the link frames.

    Collision shapes are used when a link has them, else its visual shapes, else the default
    shapes.

    Args:
        spec: The arm description (``arm.spec``).

    Returns:
        Link name -> its capsules, for every link of the arm.

    Raises:
        MeshLoadError: If a mesh file is missing or unreadable.
    """
    out: dict[str, tuple[LinkCapsule, ...]] = {}
    for name, ls in link_shapes(spec, GeometryRole.COLLISION).items():
        caps = []
        for shape in ls.shapes:
            a, b, r = shape_capsule(shape, name, spec.file)
            caps.append(LinkCapsule(name, (float(a[0]), float(a[1]), float(a[2])),
                                    (float(b[0]), float(b[1]), float(b[2])), r))
        out[name] = tuple(caps)
    return out
