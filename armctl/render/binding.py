"""Geometry bound rigidly to links: every vertex belongs to exactly one link.

This is the rigid binding of the lecture (L. Kavan, *Metody skeletální animace*, 2002), with
links for bones.

:class:`BoundGeometry` tessellates each link's shapes once, in the link frame (the part of the
drawing that depends on the model alone). Posing the arm is then one rigid transform per link:
the link's forward-kinematics pose applied to its vertices.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.config.schema import Geometry
from armctl.kinematics.linkshapes import GeometryRole, link_shapes
from armctl.kinematics.model import KinematicModel
from armctl.render.shapes import TriMesh, shape_mesh
from armctl.typing import Array

__all__ = ["BoundGeometry", "BoundShape", "link_meshes"]


@dataclass(frozen=True, eq=False)
class BoundShape:
    """One shape bound to a link.

    Attributes:
        link: The link's name.
        frame: Index of the link in the model's frame list (:attr:`KinematicModel.frame_names`).
        shape: The shape as described (origin in the link frame).
        mesh: Its triangles in the link frame [m].
        default: True for a default shape (the link has no geometry of its own).
    """

    link: str
    frame: int
    shape: Geometry
    mesh: TriMesh
    default: bool


class BoundGeometry:
    """The tessellated geometry of every link of an arm, ready to be posed.

    Args:
        arm: The kinematic model (an :class:`~armctl.arm.Arm`).
        role: Visual or collision shapes.

    Raises:
        MeshLoadError: If a mesh file of a link is missing or unreadable.
    """

    def __init__(self, arm: KinematicModel, role: GeometryRole = GeometryRole.VISUAL):
        self.arm = arm
        self.role = role
        shapes: list[BoundShape] = []
        config = arm.spec.file
        for name, ls in link_shapes(arm.spec, role).items():
            frame = arm.frame_index(name)
            for shape in ls.shapes:
                shapes.append(BoundShape(name, frame, shape, shape_mesh(shape, name, config),
                                         ls.default))
        self.shapes: tuple[BoundShape, ...] = tuple(shapes)
        #: Link names, in the order of ``spec.links``.
        self.links: tuple[str, ...] = tuple(lk.name for lk in arm.spec.links)
        link_pos = {name: i for i, name in enumerate(self.links)}
        merged = TriMesh.concatenate([s.mesh for s in shapes])
        #: All vertices in their link frames ``(V, 3)``.
        self.local_vertices: Array = merged.vertices
        #: All triangles ``(F, 3)`` (indices into the vertices).
        self.faces: npt.NDArray[np.int64] = merged.faces
        counts = [len(s.mesh.vertices) for s in shapes]
        #: Frame index (into the model's frames) of the link each vertex is bound to ``(V,)``.
        self.vertex_frame: npt.NDArray[np.int64] = np.repeat(
            np.array([s.frame for s in shapes], dtype=np.int64), counts)
        #: Position in :attr:`links` of the link each triangle belongs to ``(F,)``.
        self.face_link: npt.NDArray[np.int64] = np.repeat(
            np.array([link_pos[s.link] for s in shapes], dtype=np.int64),
            [len(s.mesh.faces) for s in shapes])

    def world_vertices(self, q: npt.ArrayLike) -> Array:
        """Every vertex in the base frame for joint values ``q`` ``(dof,)``: ``(V, 3)`` [m]."""
        return self.pose_vertices(self.arm.fk_frames(q))

    def pose_vertices(self, frame_poses: npt.ArrayLike) -> Array:
        """Every vertex in the base frame, given the poses ``(m, 4, 4)`` of all frames."""
        poses = np.asarray(frame_poses, dtype=float)[self.vertex_frame]
        return np.einsum("vij,vj->vi", poses[:, :3, :3], self.local_vertices) + poses[:, :3, 3]

    def link_meshes(self, q: npt.ArrayLike) -> dict[str, TriMesh]:
        """Each link's shapes as one triangle mesh in the base frame, for joint values ``q``."""
        poses = self.arm.fk_frames(q)
        out: dict[str, list[TriMesh]] = {}
        for s in self.shapes:
            out.setdefault(s.link, []).append(s.mesh.transformed(poses[s.frame]))
        return {name: TriMesh.concatenate(m) for name, m in out.items()}

    def local_radius(self) -> dict[str, float]:
        """Per link, the largest distance [m] of its vertices from the link origin."""
        out: dict[str, float] = {}
        for s in self.shapes:
            r = float(np.linalg.norm(s.mesh.vertices, axis=1).max(initial=0.0))
            out[s.link] = max(out.get(s.link, 0.0), r)
        return out


def link_meshes(arm: KinematicModel, q: npt.ArrayLike,
                role: GeometryRole = GeometryRole.VISUAL) -> dict[str, TriMesh]:
    """Every link's shapes as world-space (base frame) triangle meshes for joint values ``q``.

    Args:
        arm: The arm.
        q: Joint values ``(dof,)`` in [rad] / [m].
        role: Visual or collision shapes.

    Returns:
        Link name -> its shapes merged into one mesh, vertices in [m].
    """
    return BoundGeometry(arm, role).link_meshes(q)
