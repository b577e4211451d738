"""Which shapes each link carries: its own geometry from the config, or a recognisable default.

A link without geometry gets a default built from the kinematic structure alone: a capsule
along every segment from the link's origin to the origins of its child joints and attached
frames, a hub (a short cylinder) along the axis of the joint that moves it, a flat box under the
base, and a small sphere marking every end-effector frame. Their sizes scale with the arm
(:func:`default_radius`). Defaults are ordinary schema shapes in the link frame, so drawing and
collision capsules (:mod:`armctl.kinematics.capsules`) treat them like configured geometry.

Mesh files are read with trimesh, imported only when a mesh is actually loaded.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from functools import lru_cache
from pathlib import Path

import numpy as np
import numpy.typing as npt

from armctl.config.schema import (
    ArmSpec,
    Box,
    Capsule,
    Cylinder,
    Geometry,
    JointType,
    Origin,
    Sphere,
)
from armctl.errors import ConfigError, KeyPath
from armctl.spatial import axis_angle_to_matrix, matrix_to_rpy
from armctl.typing import Array

__all__ = [
    "GeometryRole",
    "LinkShapes",
    "MeshLoadError",
    "default_radius",
    "link_shapes",
    "read_mesh",
    "z_to_direction_rpy",
]


_EPS = 1e-9


class GeometryRole(Enum):
    """Which of a link's shape lists to use."""

    VISUAL = "visual"
    COLLISION = "collision"


@dataclass(frozen=True)
class LinkShapes:
    """The shapes bound to one link, in the link frame.

    Attributes:
        link: Link name.
        shapes: The shapes.
        default: True when the link has no geometry of its own and these are the defaults.
    """

    link: str
    shapes: tuple[Geometry, ...]
    default: bool


class MeshLoadError(ConfigError):
    """A mesh file named by a link's geometry is missing or cannot be read.

    Args:
        path: The mesh file.
        link: The link whose geometry names it.
        problem: What went wrong.
        config: The arm config that names the mesh, when known.

    ``details`` as for :class:`ConfigError`, and ``mesh`` (the file) and ``link``.
    """

    def __init__(self, path: Path, link: str, problem: str, config: Path | None = None):
        self.path = path
        self.link = link
        super().__init__(
            f"mesh {path} of link {link!r}: {problem}",
            KeyPath(config, ("links",), label=link),
            "check the mesh path (relative paths and package:// URLs resolve against the config's "
            "folder); STL, OBJ and DAE (DAE needs pycollada) are supported",
        )
        self.details.update(mesh=str(path), link=link)


@lru_cache(maxsize=64)
def _read_cached(path: Path, mtime: float) -> tuple[Array, npt.NDArray[np.int64]]:
    import trimesh

    loaded = trimesh.load(str(path), force="mesh", process=False)
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise ValueError("the file holds no triangles")
    vertices = np.array(loaded.vertices, dtype=np.float64)
    faces = np.array(loaded.faces, dtype=np.int64)
    vertices.flags.writeable = False
    faces.flags.writeable = False
    return vertices, faces


def read_mesh(path: Path, link: str = "?",
              config: Path | None = None) -> tuple[Array, npt.NDArray[np.int64]]:
    """Read a mesh file (STL, OBJ, DAE) in the file's own frame and units, all its triangles.

    The result is cached per file and modification time; the arrays are read-only.

    Args:
        path: The file.
        link: The link it belongs to (for error messages).
        config: The arm config that names it (for error messages).

    Returns:
        ``(vertices, faces)``: ``(n, 3)`` positions and ``(m, 3)`` vertex indices of the
        triangles.

    Raises:
        MeshLoadError: If the file is missing or cannot be read.
    """
    path = Path(path)
    if not path.is_file():
        raise MeshLoadError(path, link, "file not found", config)
    try:
        return _read_cached(path.resolve(), path.stat().st_mtime)
    except ImportError as exc:
        raise MeshLoadError(path, link, f"a package needed to read it is missing ({exc})",
                            config) from exc
    except Exception as exc:  # trimesh raises many kinds for bad files
        raise MeshLoadError(path, link, f"cannot be read ({type(exc).__name__}: {exc})",
                            config) from exc


def z_to_direction_rpy(direction: npt.ArrayLike) -> tuple[float, float, float]:
    """Roll, pitch, yaw [rad] of a rotation that turns the z axis onto ``direction``."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    z = np.array([0.0, 0.0, 1.0])
    axis = np.cross(z, d)
    s, c = float(np.linalg.norm(axis)), float(d @ z)
    if s < 1e-12:
        rot = np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    else:
        rot = axis_angle_to_matrix(axis / s, math.atan2(s, c))
    r, p, y = matrix_to_rpy(rot)
    return (float(r), float(p), float(y))


def _children(spec: ArmSpec) -> dict[str, list[Array]]:
    """Per link, the origins of its child joints and attached frames, in the link frame."""
    out: dict[str, list[Array]] = {lk.name: [] for lk in spec.links}
    for j in spec.joints:
        out[j.parent].append(np.asarray(j.origin.xyz, dtype=float))
    for f in spec.frames:
        out[f.parent].append(np.asarray(f.origin.xyz, dtype=float))
    return out


def default_radius(spec: ArmSpec) -> float:
    """Radius [m] of the default link capsules: 3.5 % of the longest base-to-leaf path."""
    children = _children(spec)
    kids: dict[str, list[tuple[str, float]]] = {}
    for j in spec.joints:
        kids.setdefault(j.parent, []).append((j.child, float(np.linalg.norm(j.origin.xyz))))

    def longest(link: str) -> float:
        best = max((float(np.linalg.norm(p)) for p in children[link]), default=0.0)
        for child, offset in kids.get(link, []):
            best = max(best, offset + longest(child))
        return best

    return max(0.035 * longest(spec.base), 1e-3)


def _segment(a: Array, b: Array, radius: float) -> Capsule:
    d = b - a
    mid = (a + b) / 2.0
    return Capsule(radius, float(np.linalg.norm(d)),
                   Origin((float(mid[0]), float(mid[1]), float(mid[2])), z_to_direction_rpy(d)))


def _defaults(spec: ArmSpec, link: str, radius: float,
              children: dict[str, list[Array]]) -> tuple[Geometry, ...]:
    shapes: list[Geometry] = []
    zero = np.zeros(3)
    if link == spec.base:
        shapes.append(Box((5 * radius, 5 * radius, 2 * radius), Origin((0.0, 0.0, -radius))))
    parent = next((j for j in spec.joints if j.child == link), None)
    if parent is not None and parent.type.actuated:
        rpy = z_to_direction_rpy(parent.axis)
        if parent.type is JointType.PRISMATIC:
            shapes.append(Box((2.2 * radius, 2.2 * radius, 3 * radius), Origin(rpy=rpy)))
        else:
            shapes.append(Cylinder(1.3 * radius, 2.6 * radius, Origin(rpy=rpy)))
    segments = [p for p in children[link] if np.linalg.norm(p) > _EPS]
    shapes += [_segment(zero, p, radius) for p in segments]
    for f in spec.frames:
        if f.parent == link and f.name in spec.end_effectors:
            shapes.append(Sphere(0.8 * radius, Origin(f.origin.xyz)))
    if not shapes:
        shapes.append(Sphere(radius))
    return tuple(shapes)


def link_shapes(spec: ArmSpec, role: GeometryRole = GeometryRole.VISUAL,
                radius: float | None = None) -> dict[str, LinkShapes]:
    """The shapes bound to every link, in the link frame, defaults filled in.

    Collision geometry falls back to the visual geometry, then to the defaults; visual geometry
    falls back to the defaults.

    Args:
        spec: The arm description.
        role: Visual or collision shapes.
        radius: Capsule radius of the default shapes [m] (the other default shapes scale with
            it); ``None`` for :func:`default_radius`.

    Returns:
        Link name -> its shapes, in the order of ``spec.links``.
    """
    r = default_radius(spec) if radius is None else float(radius)
    children = _children(spec)
    out: dict[str, LinkShapes] = {}
    for lk in spec.links:
        own = lk.visual if role is GeometryRole.VISUAL else (lk.collision or lk.visual)
        if own:
            out[lk.name] = LinkShapes(lk.name, own, False)
        else:
            out[lk.name] = LinkShapes(lk.name, _defaults(spec, lk.name, r, children), True)
    return out
