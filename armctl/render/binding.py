"""Geometry bound rigidly to links: every vertex belongs to exactly one link.

This is the rigid binding of the lecture (L. Kavan, *Metody skeletální animace*, 2002), with
links for bones.

:class:`BoundGeometry` tessellates each link's shapes once, in the link frame (the part of the
drawing that depends on the model alone). Posing the arm is then one rigid transform per link:
the link's forward-kinematics pose applied to its vertices.

An arm with a ``skin:`` (one mesh modelled in a bind pose, each vertex bound to one link, see
:mod:`armctl.config.skin`) is drawn from its skin instead of its link shapes: a vertex ``v`` of
link ``b`` is drawn at ``T_b(q) · T_b(q_bind)^-1 · v``. The product ``T_b(q_bind)^-1 · v`` is
the vertex in its link's frame, computed here once; posing is then the same one transform per
link as for the link shapes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.config.schema import Geometry, JointType, Mesh
from armctl.config.skin import SkinSpec
from armctl.kinematics.linkshapes import GeometryRole, link_shapes
from armctl.kinematics.model import KinematicModel
from armctl.render.shapes import TriMesh, shape_mesh
from armctl.typing import Array

__all__ = ["BoundGeometry", "BoundShape", "bind_pose", "link_meshes"]


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
        skin = arm.spec.skin
        if role is GeometryRole.VISUAL and skin is not None:
            shapes = _skin_shapes(arm, skin)
        else:
            shapes = []
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


def bind_pose(arm: KinematicModel, skin: SkinSpec) -> Array:
    """The joint vector ``(nq,)`` of a skin's bind pose.

    Its named pose, or the zero pose: every coordinate at zero, every ball joint at the
    identity rotation.
    """
    if skin.bind_pose is not None:
        return arm.named_pose(skin.bind_pose)
    q = np.zeros(arm.nq)
    for joint in arm.spec.actuated_joints:
        if joint.type is JointType.BALL:
            q[arm.q_index(joint.name).start] = 1.0
    return q


def _skin_shapes(arm: KinematicModel, skin: SkinSpec) -> list[BoundShape]:
    """One shape per bone: the bone's part of the skin, moved into the bone's frame.

    Each part keeps the triangles whose three vertices are bound to the bone; a triangle whose
    vertices lie on different bones is drawn with the bone of its first vertex, its other
    vertices copied into that bone's part (each drawn vertex still follows one bone only).
    """
    poses = arm.fk_frames(bind_pose(arm, skin))
    bones = sorted(set(skin.vertex_link), key=arm.frame_index)
    link_of = {f.name: f.parent for f in arm.spec.frames}  # a bone folded into its parent
    vertex_link = np.array(skin.vertex_link)
    shape = Mesh(skin.path)
    out = []
    for bone in bones:
        frame = arm.frame_index(bone)
        mine = vertex_link[skin.faces[:, 0]] == bone
        faces = skin.faces[mine]
        used, inverse = np.unique(faces, return_inverse=True)
        t = np.linalg.inv(poses[frame])
        local = skin.vertices[used] @ t[:3, :3].T + t[:3, 3]
        out.append(BoundShape(link_of.get(bone, bone), frame, shape,
                              TriMesh(local, inverse.reshape(-1, 3)), False))
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
