"""Triangle meshes of the geometry shapes: boxes, cylinders, spheres, capsules and mesh files.

Every function returns a :class:`TriMesh` in the frame the shape is defined in (its ``origin``
already applied), with outward-facing triangles (counter-clockwise seen from outside).
Mesh files are read with :func:`armctl.kinematics.linkshapes.read_mesh` (trimesh, imported only
when a mesh is actually loaded).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
import numpy.typing as npt

from armctl.config.schema import Box, Capsule, Cylinder, Geometry, Mesh, Sphere
from armctl.kinematics.linkshapes import read_mesh
from armctl.typing import Array

__all__ = [
    "MAX_MESH_FACES",
    "TriMesh",
    "box_mesh",
    "capsule_mesh",
    "cylinder_mesh",
    "decimate",
    "load_mesh_file",
    "shape_mesh",
    "sphere_mesh",
]


#: Mesh files with more triangles than this are simplified (see :func:`decimate`) for drawing.
MAX_MESH_FACES = 6000


@dataclass(frozen=True, eq=False)
class TriMesh:
    """A triangle mesh.

    Attributes:
        vertices: ``(n, 3)`` vertex positions in [m].
        faces: ``(m, 3)`` vertex indices of each triangle, counter-clockwise seen from outside.
    """

    vertices: Array
    faces: npt.NDArray[np.int64]

    def transformed(self, transform: npt.ArrayLike) -> TriMesh:
        """The mesh moved by a ``(4, 4)`` rigid transform."""
        t = np.asarray(transform, dtype=float)
        return TriMesh(self.vertices @ t[:3, :3].T + t[:3, 3], self.faces)

    def volume(self) -> float:
        """Enclosed volume [m^3] (positive for a closed mesh with outward triangles)."""
        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)

    @staticmethod
    def concatenate(meshes: list[TriMesh]) -> TriMesh:
        """One mesh holding all the triangles of ``meshes``."""
        if not meshes:
            return TriMesh(np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64))
        offsets = np.cumsum([0] + [len(m.vertices) for m in meshes[:-1]])
        return TriMesh(np.vstack([m.vertices for m in meshes]),
                       np.vstack([m.faces + o for m, o in zip(meshes, offsets, strict=True)]))


def _revolve(rings: list[tuple[float, float]], top: float, bottom: float, n: int) -> TriMesh:
    """Surface of revolution about z: poles at ``top`` and ``bottom``, rings between.

    Rings are listed from the top down; ``bottom`` is the height of the lower pole.
    """
    phi = np.linspace(0.0, 2.0 * math.pi, n, endpoint=False)
    verts = [np.array([[0.0, 0.0, top]])]
    for radius, z in rings:
        verts.append(np.column_stack([radius * np.cos(phi), radius * np.sin(phi), np.full(n, z)]))
    verts.append(np.array([[0.0, 0.0, bottom]]))
    vertices = np.vstack(verts)
    k = np.arange(n)
    k1 = (k + 1) % n
    faces = [np.column_stack([np.zeros(n, dtype=np.int64), 1 + k, 1 + k1])]
    for r in range(len(rings) - 1):
        a, b = 1 + r * n, 1 + (r + 1) * n
        faces.append(np.column_stack([a + k, b + k, b + k1]))
        faces.append(np.column_stack([a + k, b + k1, a + k1]))
    last = 1 + (len(rings) - 1) * n
    south = len(vertices) - 1
    faces.append(np.column_stack([np.full(n, south), last + k1, last + k]))
    return TriMesh(vertices, np.vstack(faces).astype(np.int64))


def box_mesh(size: npt.ArrayLike) -> TriMesh:
    """A box centred on the origin with edge lengths ``size`` [m] along x, y, z."""
    h = np.asarray(size, dtype=float).reshape(3) / 2.0
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    # corner index = 4 * (x > 0) + 2 * (y > 0) + (z > 0)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = [(a, b, c) for a, b, c, _ in quads] + [(a, c, d) for a, _, c, d in quads]
    return TriMesh(corners * h, np.array(faces, dtype=np.int64))


def cylinder_mesh(radius: float, length: float, segments: int = 24) -> TriMesh:
    """A closed cylinder along z centred on the origin; sizes in [m]."""
    h = length / 2.0
    return _revolve([(radius, h), (radius, -h)], h, -h, segments)


def sphere_mesh(radius: float, segments: int = 20) -> TriMesh:
    """A UV sphere centred on the origin; radius in [m]."""
    rows = max(segments // 2, 3)
    theta = np.linspace(0.0, math.pi, rows + 1)[1:-1]
    return _revolve([(radius * math.sin(t), radius * math.cos(t)) for t in theta],
                    radius, -radius, segments)


def capsule_mesh(radius: float, length: float, segments: int = 20) -> TriMesh:
    """A capsule along z centred on the origin: hemisphere centres at ``z = +-length / 2`` [m]."""
    rows = max(segments // 4, 2)
    h = length / 2.0
    theta = np.linspace(0.0, math.pi / 2.0, rows + 1)[1:]
    top = [(radius * math.sin(t), h + radius * math.cos(t)) for t in theta]
    bottom = [(r, -z) for r, z in reversed(top)]
    return _revolve(top + bottom, h + radius, -h - radius, segments)


@lru_cache(maxsize=64)
def _drawable(path: Path, mtime: float) -> TriMesh:
    vertices, faces = read_mesh(path)
    out = TriMesh(vertices, faces)
    return decimate(out, MAX_MESH_FACES) if len(out.faces) > MAX_MESH_FACES else out


def decimate(mesh: TriMesh, max_faces: int) -> TriMesh:
    """Fewer triangles by vertex clustering: vertices in one grid cell merge into their mean.

    The grid is refined from coarse to fine and the finest result with at most ``max_faces``
    triangles is kept; triangles that collapse are dropped. The shape is kept to within about
    one cell (meant for drawing, not for measuring).
    """
    lo = mesh.vertices.min(axis=0)
    size = float(np.ptp(mesh.vertices, axis=0).max()) or 1.0
    best = None
    for cells in (4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128):
        key = np.floor((mesh.vertices - lo) / (size / cells) * 0.999999).astype(np.int64)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        inverse = inverse.reshape(-1)
        verts = np.zeros((len(counts), 3))
        np.add.at(verts, inverse, mesh.vertices)
        verts /= counts[:, None]
        faces = inverse[mesh.faces]
        keep = ((faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
                & (faces[:, 0] != faces[:, 2]))
        faces = np.unique(faces[keep], axis=0)
        if len(faces) > max_faces:
            break
        best = TriMesh(verts, faces)
    return best if best is not None else TriMesh(verts, faces[:max_faces])


def load_mesh_file(path: Path, link: str = "?", config: Path | None = None) -> TriMesh:
    """Read a mesh file (STL, OBJ, DAE) as a triangle mesh in the file's own frame and units.

    Meshes with more than :data:`MAX_MESH_FACES` triangles are simplified with :func:`decimate`.

    Args:
        path: The file.
        link: The link it belongs to (for error messages).
        config: The arm config that names it (for error messages).

    Raises:
        MeshLoadError: If the file is missing or cannot be read.
    """
    path = Path(path)
    read_mesh(path, link, config)  # cached: the errors name the file as given
    return _drawable(path.resolve(), path.stat().st_mtime)


def shape_mesh(shape: Geometry, link: str = "?", config: Path | None = None) -> TriMesh:
    """The triangle mesh of one geometry shape, in the frame its ``origin`` refers to (the link).

    Args:
        shape: A box, cylinder, sphere, capsule or mesh file.
        link: The link it belongs to (for error messages).
        config: The arm config it comes from (for error messages).
    """
    if isinstance(shape, Box):
        local = box_mesh(shape.size)
    elif isinstance(shape, Cylinder):
        local = cylinder_mesh(shape.radius, shape.length)
    elif isinstance(shape, Sphere):
        local = sphere_mesh(shape.radius)
    elif isinstance(shape, Capsule):
        local = capsule_mesh(shape.radius, shape.length)
    elif isinstance(shape, Mesh):
        raw = load_mesh_file(shape.path, link, config)
        local = TriMesh(raw.vertices * np.asarray(shape.scale, dtype=float), raw.faces)
        if np.prod(shape.scale) < 0:  # a mirroring scale turns the triangles inside out
            local = TriMesh(local.vertices, local.faces[:, ::-1].copy())
    else:  # pragma: no cover - the schema has no other shapes
        raise TypeError(f"unknown shape {shape!r}")
    return local.transformed(shape.origin.matrix())
