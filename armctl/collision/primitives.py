"""Scene obstacles as the primitives the checks use: spheres, capsules and boxes.

A sphere, a capsule and a box are taken as they are; a cylinder becomes the capsule around it
and a mesh the box around its vertices along their principal axes (both contain the shape).
The collision kernels (:mod:`armctl.collision.model`) and the NLP keep-out zones
(:mod:`armctl.ik.nlp.scene`) take obstacles from here, so both see the same shapes.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from pathlib import Path

import numpy as np

from armctl.collision.errors import SceneError
from armctl.config.scene import Obstacle, SceneFrame
from armctl.config.schema import Box, Capsule, Cylinder, Mesh, Sphere
from armctl.kinematics.linkshapes import read_mesh
from armctl.typing import Array

__all__ = ["Primitive", "PrimitiveKind", "obstacle_primitive"]


class PrimitiveKind(Enum):
    """The kind of an obstacle's primitive."""

    SPHERE = "sphere"
    CAPSULE = "capsule"
    BOX = "box"


@dataclass(frozen=True, eq=False)
class Primitive:
    """An obstacle's primitive in the arm's base frame.

    Attributes:
        kind: Sphere, capsule or box.
        a: Sphere: its centre; capsule: one end of its segment [m].
        b: Sphere: its centre; capsule: the other end [m].
        radius: Sphere and capsule radius [m] (0 for a box).
        rotation: Box: ``(3, 3)``, its axes as columns.
        centre: The centre [m].
        half: Box: half its sizes along its axes [m] (zeros otherwise).
    """

    kind: PrimitiveKind
    a: Array
    b: Array
    radius: float
    rotation: Array
    centre: Array
    half: Array

    @property
    def bounding_radius(self) -> float:
        """Radius of a sphere around :attr:`centre` that contains it [m]."""
        if self.kind is PrimitiveKind.BOX:
            return float(np.linalg.norm(self.half))
        return float(np.linalg.norm(self.b - self.a)) / 2.0 + self.radius


def obstacle_primitive(ob: Obstacle, world_to_base: Array,
                       config: Path | None = None) -> Primitive:
    """An obstacle as a primitive in the base frame.

    Args:
        ob: The obstacle.
        world_to_base: ``(4, 4)``: the world frame in the base frame (for ``frame: world``).
        config: The file the obstacle comes from (for errors about mesh files).

    Raises:
        MeshLoadError: A mesh file that cannot be read.
    """
    shape = ob.shape
    t = shape.origin.matrix()
    if ob.frame is SceneFrame.WORLD:
        t = world_to_base @ t
    centre = np.array(t[:3, 3], dtype=float)
    zero = np.zeros(3)
    if isinstance(shape, Sphere):
        return Primitive(PrimitiveKind.SPHERE, centre, centre.copy(), shape.radius, np.eye(3),
                         centre, zero)
    if isinstance(shape, Capsule | Cylinder):  # a cylinder as the capsule around it
        z = t[:3, 2] * (shape.length / 2.0)
        return Primitive(PrimitiveKind.CAPSULE, centre - z, centre + z, shape.radius,
                         np.eye(3), centre, zero)
    if isinstance(shape, Box):
        return Primitive(PrimitiveKind.BOX, centre, centre.copy(), 0.0,
                         np.array(t[:3, :3], dtype=float), centre,
                         np.asarray(shape.size, dtype=float) / 2.0)
    if isinstance(shape, Mesh):  # the box around the vertices along their principal axes
        raw, _ = read_mesh(shape.path, ob.name, config)
        verts = np.asarray(raw, dtype=float) * np.asarray(shape.scale, dtype=float)
        mean = verts.mean(axis=0)
        _, _, vt = np.linalg.svd(verts - mean, full_matrices=False)
        axes = vt.T if np.linalg.det(vt.T) > 0 else vt.T * np.array([1.0, 1.0, -1.0])
        local = (verts - mean) @ axes
        lo, hi = local.min(axis=0), local.max(axis=0)
        mid = t[:3, :3] @ (mean + axes @ ((lo + hi) / 2.0)) + t[:3, 3]
        return Primitive(PrimitiveKind.BOX, mid, mid.copy(), 0.0, t[:3, :3] @ axes, mid,
                         np.maximum((hi - lo) / 2.0, 1e-9))
    raise SceneError(f"obstacle {ob.name!r}: unknown shape {shape!r}")  # pragma: no cover
