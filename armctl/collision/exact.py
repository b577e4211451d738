"""Exact narrow phase: signed distances between the shapes themselves, through coal.

The capsules of :mod:`armctl.kinematics.capsules` contain the shapes, so they can only say "too
close" early; this module answers for the shapes themselves (boxes, cylinders, spheres,
capsules, meshes and the table's half-space) with coal (the maintained successor of hpp-fcl),
chosen on the measurements in ``docs/benchmarks.md`` (section "Exact narrow phase"). coal is an
optional dependency: ``pip install 'armctl[collision]'``; it is imported only when a shape is
first built.

Usage: build the library's object once per shape with :func:`exact_shape` (or every link's with
:func:`exact_link_shapes`), then ask :func:`signed_distance` (two shapes) or
:func:`table_distance` (the table against a shape) as often as the poses change. A shape is
placed by the pose of the frame its ``origin`` is given in (a link's pose for link geometry,
the identity or the obstacle frame for a scene object); all poses and returned points are in
one common frame (the arm's base frame).

Distances are signed: positive is the gap between the shapes, negative the penetration depth
(the shortest translation that brings them apart), and the two returned points are the
witnesses (the closest points, or the deepest points of each shape inside the other).

Meshes are checked as their convex hull by default (:attr:`MeshMode.HULL`): the hull contains
the mesh, so the answer is conservative, and the signed distance is exact for the hull. With
:attr:`MeshMode.SURFACE` the triangles themselves are used: a positive distance is then the
exact gap to the triangles (through a concavity, a hole); a shape wholly inside a closed mesh
is found by the mesh's winding number and counts as overlapping; when they overlap, the value
is the hulls' signed distance, whose magnitude is an upper bound of the true penetration depth.

Spheres are handed to coal as capsules of zero length: coal's dedicated sphere-cylinder
routine overestimates the depth of a sphere whose centre is inside a cylinder near a cap (by
1.5 cm for a 4 cm sphere in the benchmark), while its general routine is right there.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from armctl.collision.errors import MissingExtraError
from armctl.config.schema import ArmSpec, Box, Capsule, Cylinder, Geometry, Mesh, Sphere
from armctl.errors import InputError
from armctl.kinematics.linkshapes import GeometryRole, link_shapes, read_mesh
from armctl.typing import Array

__all__ = [
    "ExactShape",
    "MeshMode",
    "SignedDistance",
    "exact_link_shapes",
    "exact_shape",
    "signed_distance",
    "table_distance",
    "winding_number",
]

_log = logging.getLogger(__name__)

#: Winding number above which a point counts as inside a closed mesh.
_INSIDE = 0.5


class MeshMode(Enum):
    """How a mesh is checked."""

    HULL = "hull"  # its convex hull: conservative, exact signed distance for the hull
    SURFACE = "surface"  # its triangles: exact gap through concavities (see the module notes)


class SignedDistance(NamedTuple):
    """The answer of a distance query.

    Attributes:
        distance: Gap between the shapes [m]; negative: the penetration depth.
        point_a: Witness point on (or in) the first shape, in the common frame [m].
        point_b: Witness point on (or in) the second shape, in the common frame [m].
    """

    distance: float
    point_a: Array
    point_b: Array


@dataclass(frozen=True, eq=False)
class ExactShape:
    """One shape built for the collision library (build once, query many times).

    Attributes:
        shape: The schema shape it was built from.
        offset: ``shape.origin`` as a ``(4, 4)`` transform (shape frame in its parent frame).
        geometry: The library's object for the solid (the hull for a mesh in either mode).
        surface: For a mesh in :attr:`MeshMode.SURFACE`: the library's object for its triangles.
        vertices: For a mesh: its scaled vertices in the shape frame ``(n, 3)`` [m].
        faces: For a mesh: its triangles ``(m, 3)`` (vertex indices).
        closed: For a mesh: True when every edge is shared by exactly two triangles (then the
            winding number tells inside from outside).
        mode: How a mesh is checked (``HULL`` for the other shapes).
    """

    shape: Geometry
    offset: Array
    geometry: Any = field(repr=False)
    surface: Any = field(default=None, repr=False)
    vertices: Array | None = field(default=None, repr=False)
    faces: npt.NDArray[np.int64] | None = field(default=None, repr=False)
    closed: bool = False
    mode: MeshMode = MeshMode.HULL

    @property
    def inner_point(self) -> Array:
        """A point of the solid in the shape frame (the centre, or a vertex of a mesh) [m]."""
        if self.vertices is not None:
            return self.vertices[0]
        return np.zeros(3)


def _coal() -> Any:
    try:
        import coal
    except ImportError as exc:
        raise MissingExtraError("exact collision checking", "coal", "collision") from exc
    return coal


def _vec3s(coal: Any, points: Array) -> Any:
    out = coal.StdVec_Vec3s()
    for p in points:
        out.append(np.asarray(p, dtype=np.float64))
    return out


def _bvh(coal: Any, vertices: Array, faces: npt.NDArray[np.int64]) -> Any:
    model = coal.BVHModelOBBRSS()
    model.beginModel(len(faces), len(vertices))
    model.addVertices(np.ascontiguousarray(vertices, dtype=np.float64))
    model.addTriangles(np.ascontiguousarray(faces, dtype=np.int64))
    model.endModel()
    return model


def _hull(coal: Any, vertices: Array, faces: npt.NDArray[np.int64], where: str) -> Any:
    """The convex hull as a coal polytope; the triangles when the points span no volume."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(vertices)
    except QhullError:
        # flat or degenerate point set: there is no interior, the triangles are the solid
        _log.debug("mesh %s spans no volume: checked as its triangles", where)
        return _bvh(coal, vertices, faces)
    keep = hull.vertices
    remap = np.full(len(vertices), -1, dtype=np.int64)
    remap[keep] = np.arange(len(keep))
    triangles = coal.StdVec_Triangle()
    for a, b, c in remap[hull.simplices]:
        triangles.append(coal.Triangle(int(a), int(b), int(c)))
    return coal.Convex(_vec3s(coal, vertices[keep]), triangles)


def _is_closed(vertices: Array, faces: npt.NDArray[np.int64]) -> bool:
    """Whether every edge is shared by exactly two triangles (vertices merged by position)."""
    scale = float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0
    key = np.round(vertices / max(scale * 1e-9, 1e-15))
    _, same = np.unique(key, axis=0, return_inverse=True)
    merged = same.reshape(-1)[faces]
    edges = np.sort(np.concatenate([merged[:, [0, 1]], merged[:, [1, 2]], merged[:, [2, 0]]]),
                    axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(len(counts) > 0 and np.all(counts == 2))


def exact_shape(shape: Geometry, mesh_mode: MeshMode = MeshMode.HULL, link: str = "?",
                config: Path | None = None) -> ExactShape:
    """Build the collision library's object for one shape.

    Args:
        shape: A schema shape; its ``origin`` places it in its parent frame, a mesh's ``scale``
            is applied per axis.
        mesh_mode: How a mesh is checked (ignored for the other shapes).
        link: The link (or obstacle) it belongs to, for error messages about mesh files.
        config: The file that names it, for error messages.

    Returns:
        The built shape.

    Raises:
        MissingExtraError: If coal is not installed.
        MeshLoadError: If a mesh file is missing or unreadable.
        InputError: If a size is not positive and finite.
    """
    coal = _coal()
    offset = shape.origin.matrix()
    if isinstance(shape, Box):
        _check_sizes(shape, link, size=shape.size)
        return ExactShape(shape, offset, coal.Box(*map(float, shape.size)))
    if isinstance(shape, Sphere):
        _check_sizes(shape, link, radius=shape.radius)
        # a zero-length capsule: coal's sphere-cylinder routine errs inside the cylinder's caps
        return ExactShape(shape, offset, coal.Capsule(float(shape.radius), 0.0))
    if isinstance(shape, Capsule):
        _check_sizes(shape, link, radius=shape.radius, length=shape.length, zero_length=True)
        return ExactShape(shape, offset, coal.Capsule(float(shape.radius), float(shape.length)))
    if isinstance(shape, Cylinder):
        _check_sizes(shape, link, radius=shape.radius, length=shape.length)
        return ExactShape(shape, offset, coal.Cylinder(float(shape.radius), float(shape.length)))
    if isinstance(shape, Mesh):
        _check_sizes(shape, link, scale=shape.scale)
        raw, faces = read_mesh(shape.path, link, config)
        vertices = np.asarray(raw, dtype=np.float64) * np.asarray(shape.scale, dtype=np.float64)
        faces = np.asarray(faces, dtype=np.int64)
        hull = _hull(coal, vertices, faces, f"{shape.path} of {link!r}")
        surface = _bvh(coal, vertices, faces) if mesh_mode is MeshMode.SURFACE else None
        return ExactShape(shape, offset, hull, surface, vertices, faces,
                          _is_closed(vertices, faces), mesh_mode)
    raise TypeError(f"unknown shape {shape!r}")  # pragma: no cover


def exact_link_shapes(spec: ArmSpec, mesh_mode: MeshMode = MeshMode.HULL
                      ) -> dict[str, tuple[ExactShape, ...]]:
    """Every link's collision shapes, built (the shapes the capsules of a link contain).

    A link's collision shapes are used when it has them, else its visual shapes, else the
    default shapes (:func:`~armctl.kinematics.linkshapes.link_shapes`).

    Args:
        spec: The arm description.
        mesh_mode: How meshes are checked.

    Returns:
        Link name -> its built shapes, in the link frame (place them with the link's pose).

    Raises:
        MissingExtraError: If coal is not installed.
        MeshLoadError: If a mesh file is missing or unreadable.
    """
    return {name: tuple(exact_shape(s, mesh_mode, name, spec.file) for s in ls.shapes)
            for name, ls in link_shapes(spec, GeometryRole.COLLISION).items()}


def _check_sizes(shape: Geometry, link: str, size: tuple[float, ...] = (),
                 scale: tuple[float, ...] = (), radius: float | None = None,
                 length: float | None = None, zero_length: bool = False) -> None:
    kind = type(shape).__name__.lower()
    for i, factor in enumerate(scale):  # a negative factor mirrors the mesh
        if not math.isfinite(float(factor)) or float(factor) == 0.0:
            raise InputError(
                f"{kind} of {link!r}: scale[{i}] is {factor}; give a non-zero scale factor",
                {"link": link, "shape": kind, "key": f"scale[{i}]", "value": float(factor)})
    checks = [(f"size[{i}]", v, False) for i, v in enumerate(size)]
    if radius is not None:
        checks.append(("radius", radius, False))
    if length is not None:
        checks.append(("length", length, zero_length))
    for key, value, zero_ok in checks:
        v = float(value)
        if not math.isfinite(v) or v < 0.0 or (v == 0.0 and not zero_ok):
            raise InputError(
                f"{kind} of {link!r}: {key} is {value}; give a positive size in metres",
                {"link": link, "shape": kind, "key": key, "value": v})


def _pose(pose: npt.ArrayLike, name: str) -> Array:
    t = np.asarray(pose, dtype=np.float64)
    if t.shape != (4, 4) or not np.all(np.isfinite(t)):
        raise InputError(f"{name}: expected a finite (4, 4) homogeneous transform, got shape "
                         f"{t.shape}", {"argument": name, "shape": list(t.shape)})
    return t


def _transform(coal: Any, t: Array) -> Any:
    return coal.Transform3s(np.ascontiguousarray(t[:3, :3]), np.ascontiguousarray(t[:3, 3]))


_REQUEST: list[Any] = []


def _request(coal: Any) -> Any:
    if not _REQUEST:
        req = coal.DistanceRequest()
        req.enable_signed_distance = True
        _REQUEST.append(req)
    return _REQUEST[0]


def _query(coal: Any, ga: Any, ta: Array, gb: Any, tb: Array) -> SignedDistance:
    res = coal.DistanceResult()
    d = coal.distance(ga, _transform(coal, ta), gb, _transform(coal, tb), _request(coal), res)
    return SignedDistance(float(d), np.array(res.getNearestPoint1(), dtype=np.float64),
                          np.array(res.getNearestPoint2(), dtype=np.float64))


def _built(shape: ExactShape | Geometry) -> ExactShape:
    return shape if isinstance(shape, ExactShape) else exact_shape(shape)


def winding_number(points: npt.ArrayLike, vertices: Array,
                   faces: npt.NDArray[np.int64]) -> Array:
    """Generalised winding number of points with respect to a triangle mesh.

    About 1 inside a closed, outward-oriented mesh, 0 outside (the sign follows the
    orientation, so callers compare its absolute value); computed from the solid angle each
    triangle subtends (A. Van Oosterom and J. Strackee, IEEE Trans. Biomed. Eng. 30(2), 1983).

    Args:
        points: ``(k, 3)`` or ``(3,)`` points, in the mesh's frame [m].
        vertices: ``(n, 3)`` mesh vertices [m].
        faces: ``(m, 3)`` triangles.

    Returns:
        ``(k,)`` winding numbers.
    """
    p = np.atleast_2d(np.asarray(points, dtype=np.float64))
    tri = vertices[faces]  # (m, 3, 3)
    out = np.empty(len(p))
    for i, x in enumerate(p):
        a, b, c = tri[:, 0] - x, tri[:, 1] - x, tri[:, 2] - x
        la, lb, lc = (np.linalg.norm(v, axis=1) for v in (a, b, c))
        num = np.einsum("ij,ij->i", a, np.cross(b, c))
        den = (la * lb * lc + np.einsum("ij,ij->i", a, b) * lc
               + np.einsum("ij,ij->i", b, c) * la + np.einsum("ij,ij->i", c, a) * lb)
        out[i] = float(np.sum(np.arctan2(num, den))) / (2.0 * math.pi)
    return out


def _inside(container: ExactShape, pose_c: Array, other: ExactShape, pose_o: Array) -> bool:
    """Whether ``other``'s inner point lies inside the closed mesh ``container``."""
    if container.vertices is None or container.faces is None or not container.closed:
        return False
    p = pose_o @ np.append(other.inner_point, 1.0)
    local = np.linalg.solve(pose_c, p)[:3]
    return bool(abs(winding_number(local, container.vertices, container.faces)[0]) > _INSIDE)


def signed_distance(shape_a: ExactShape | Geometry, pose_a: npt.ArrayLike,
                    shape_b: ExactShape | Geometry, pose_b: npt.ArrayLike) -> SignedDistance:
    """Signed distance between two placed shapes.

    Args:
        shape_a: The first shape (built with :func:`exact_shape`; a schema shape is built on
            the spot, with meshes as hulls).
        pose_a: ``(4, 4)`` pose of the frame ``shape_a.origin`` is given in (e.g. its link's
            pose), in the common frame.
        shape_b: The second shape.
        pose_b: Its parent frame's pose.

    Returns:
        ``(distance, point_a, point_b)``: the gap [m] (negative: penetration depth) and the
        witness points on each shape in the common frame [m].

    Raises:
        MissingExtraError: If coal is not installed.
        InputError: If a pose is not a finite ``(4, 4)`` matrix.
    """
    coal = _coal()
    a, b = _built(shape_a), _built(shape_b)
    ta = _pose(pose_a, "pose_a") @ a.offset
    tb = _pose(pose_b, "pose_b") @ b.offset
    if a.surface is None and b.surface is None:
        return _query(coal, a.geometry, ta, b.geometry, tb)
    ga = a.surface if a.surface is not None else a.geometry
    gb = b.surface if b.surface is not None else b.geometry
    gap = _query(coal, ga, ta, gb, tb)
    if gap.distance > 0.0 and not (_inside(a, ta, b, tb) or _inside(b, tb, a, ta)):
        return gap
    hulls = _query(coal, a.geometry, ta, b.geometry, tb)
    return hulls if hulls.distance <= gap.distance else SignedDistance(
        min(gap.distance, 0.0), gap.point_a, gap.point_b)


def table_distance(height: float, shape: ExactShape | Geometry,
                   pose: npt.ArrayLike) -> SignedDistance:
    """Signed distance between the table (the half-space ``z <= height``) and a shape.

    Args:
        height: Height of the table top in the common frame (the arm's base frame) [m].
        shape: The shape (a mesh's lowest point is one of its vertices).
        pose: ``(4, 4)`` pose of the frame ``shape.origin`` is given in.

    Returns:
        ``(distance, point_table, point_shape)``: the height of the shape's lowest point above
        the table top [m] (negative: that far below it), the point on the table top (or the
        table's deepest point inside the shape) and the shape's lowest point, in the common
        frame [m].

    Raises:
        MissingExtraError: If coal is not installed.
        InputError: If the height is not finite or the pose is not a finite ``(4, 4)``
            matrix.
    """
    coal = _coal()
    if not math.isfinite(float(height)):
        raise InputError(f"table height is {height}; give a finite height in metres",
                         {"height": float(height)})
    s = _built(shape)
    t = _pose(pose, "pose") @ s.offset
    if s.vertices is not None:  # a mesh: its lowest point is a vertex
        world = s.vertices @ t[:3, :3].T + t[:3, 3]
        low = world[int(np.argmin(world[:, 2]))]
        return SignedDistance(float(low[2]) - float(height),
                              np.array([low[0], low[1], float(height)]), low.copy())
    plane = coal.Halfspace(np.array([0.0, 0.0, 1.0]), float(height))
    return _query(coal, plane, np.eye(4), s.geometry, t)
