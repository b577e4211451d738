"""Seeing the arm: link geometry bound to links, pictures of poses, paths and playback.

Importing this package is cheap: matplotlib, trimesh and the live viewer (viser) are imported only
by the functions that need them. See ``docs/render.md``.
"""

from __future__ import annotations

from armctl.kinematics.capsules import LinkCapsule, collision_capsules, shape_capsule
from armctl.kinematics.linkshapes import GeometryRole, LinkShapes, link_shapes
from armctl.render.animation import Animation, render_animation
from armctl.render.binding import BoundGeometry, BoundShape, link_meshes
from armctl.render.draw import ArmArtist, Bounds, Camera, View, draw_path
from armctl.render.errors import MeshLoadError, MissingToolError, OutputError
from armctl.render.picture import PathPicture, PosePicture, Target, render_path, render_pose
from armctl.render.shapes import TriMesh, shape_mesh
from armctl.render.workspace import Workspace, plot_workspace, sample_workspace

__all__ = [
    "Animation",
    "ArmArtist",
    "BoundGeometry",
    "BoundShape",
    "Bounds",
    "Camera",
    "GeometryRole",
    "LinkCapsule",
    "LinkShapes",
    "MeshLoadError",
    "MissingToolError",
    "OutputError",
    "PathPicture",
    "PosePicture",
    "Target",
    "TriMesh",
    "View",
    "Workspace",
    "collision_capsules",
    "draw_path",
    "link_meshes",
    "link_shapes",
    "plot_workspace",
    "render_animation",
    "render_path",
    "render_pose",
    "sample_workspace",
    "shape_capsule",
    "shape_mesh",
]
