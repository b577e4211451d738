"""Collision distances against independent truth: brute-force point sampling of the shapes.

Every shape is sampled densely on its surface (grids on faces, rims and caps, Fibonacci points
on spheres, the vertices and area samples of meshes). Two truths come from the samples:

* the gap between separated shapes: the least distance between a sample of one and a sample of
  the other. Samples lie on the surfaces, so it is never below the true gap, and exceeds it by
  at most the sampling resolution;
* the signed distance of two convex shapes, apart or overlapping: the largest over directions
  ``n`` of ``min(n . a) - max(n . b)`` over the samples ``a`` of one and ``b`` of the other
  (the support functions of their Minkowski difference), maximised over dense directions. The
  samples include every corner, rim and pole that a support can land on, so this is exact to
  a few micrometres.

They check :mod:`armctl.collision.exact` (coal) on random poses, and the capsule kernels of
:class:`armctl.collision.CollisionModel` on random configurations of bundled arms: capsules
contain the shapes, so their distance may never exceed the exact distance of the shapes.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass, field
from functools import lru_cache
from itertools import combinations_with_replacement
from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import ConvexHull, cKDTree

import armctl
from armctl.collision.errors import MissingExtraError
from armctl.collision.exact import (
    MeshMode,
    exact_link_shapes,
    exact_shape,
    signed_distance,
    table_distance,
    winding_number,
)
from armctl.config.scene import TABLE, CollisionSpec, Obstacle, SceneSpec, TableSpec
from armctl.config.schema import Box, Capsule, Cylinder, Geometry, Mesh, Origin, Sphere
from armctl.errors import InputError
from armctl.kinematics.capsules import LinkCapsule, collision_capsules, shape_capsule
from armctl.kinematics.linkshapes import GeometryRole, link_shapes, read_mesh

H = 0.001  # sampling resolution [m]
H_SUPPORT = 0.0012  # sampling resolution for support functions [m] (error ~ h^2 / 8r)
SUPPORT_TOL = 3e-5  # error of the sampled support functions [m]


# ---- sampling -----------------------------------------------------------------------------------

def _fibonacci(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    s = np.sqrt(1.0 - z * z)
    return np.column_stack([s * np.cos(phi), s * np.sin(phi), z])


def _ring(radius: float, z: float, h: float) -> np.ndarray:
    n = max(8, math.ceil(2 * math.pi * radius / h))
    t = np.linspace(0.0, 2 * math.pi, n, endpoint=False)
    return np.column_stack([radius * np.cos(t), radius * np.sin(t), np.full(n, z)])


def _disc(radius: float, z: float, h: float) -> np.ndarray:
    rings = [np.array([[0.0, 0.0, z]])]
    for rho in np.linspace(0.0, radius, max(2, math.ceil(radius / h) + 1))[1:]:
        rings.append(_ring(rho, z, h))
    return np.vstack(rings)


def _side(radius: float, length: float, h: float) -> np.ndarray:
    return np.vstack([_ring(radius, z, h)
                      for z in np.linspace(-length / 2, length / 2,
                                           max(2, math.ceil(length / h) + 1))])


def _sphere(radius: float, h: float) -> np.ndarray:
    n = max(50, math.ceil(4 * math.pi * radius**2 / h**2 * 1.3))
    return radius * np.vstack([_fibonacci(n), [[0, 0, 1], [0, 0, -1]]])


def _box(size: tuple[float, float, float], h: float) -> np.ndarray:
    half = np.asarray(size) / 2
    faces = []
    for axis in range(3):
        u, v = [k for k in range(3) if k != axis]
        gu = np.linspace(-half[u], half[u], max(2, math.ceil(size[u] / h) + 1))
        gv = np.linspace(-half[v], half[v], max(2, math.ceil(size[v] / h) + 1))
        uu, vv = np.meshgrid(gu, gv)
        for sign in (-1.0, 1.0):
            p = np.zeros((uu.size, 3))
            p[:, u], p[:, v], p[:, axis] = uu.ravel(), vv.ravel(), sign * half[axis]
            faces.append(p)
    return np.vstack(faces)


@lru_cache(maxsize=64)
def extreme_samples(shape: Geometry) -> np.ndarray:
    """The samples of :func:`surface_samples` on their convex hull (invariant under motion)."""
    return _extreme(surface_samples(shape, H_SUPPORT))


@lru_cache(maxsize=64)
def surface_samples(shape: Geometry, h: float = H) -> np.ndarray:
    """Points on the shape's surface, in its parent frame (``origin`` applied) [m]."""
    if isinstance(shape, Box):
        p = _box(shape.size, h)
    elif isinstance(shape, Sphere):
        p = _sphere(shape.radius, h)
    elif isinstance(shape, Cylinder):
        r, half = shape.radius, shape.length / 2
        p = np.vstack([_side(r, shape.length, h), _disc(r, half, h), _disc(r, -half, h)])
    elif isinstance(shape, Capsule):
        ball = _sphere(shape.radius, h)
        up, down = ball[ball[:, 2] >= 0], ball[ball[:, 2] <= 0]
        half = shape.length / 2
        shift = np.array([0.0, 0.0, half])
        p = np.vstack([_side(shape.radius, shape.length, h), up + shift, down - shift])
    elif isinstance(shape, Mesh):
        v, f = read_mesh(shape.path)
        mesh = trimesh.Trimesh(np.asarray(v) * shape.scale, f, process=False)
        count = math.ceil(mesh.area / h**2 * 1.5)
        pts, _ = trimesh.sample.sample_surface(mesh, count, seed=3)
        p = np.vstack([mesh.vertices, pts])
    else:  # pragma: no cover
        raise TypeError(shape)
    t = shape.origin.matrix()
    return p @ t[:3, :3].T + t[:3, 3]


def _place(points: np.ndarray, pose: np.ndarray) -> np.ndarray:
    return points @ pose[:3, :3].T + pose[:3, 3]


def _extreme(points: np.ndarray) -> np.ndarray:
    """The samples a support function can land on (the vertices of their hull)."""
    try:
        return points[ConvexHull(points).vertices]
    except Exception:  # flat: keep them all
        return points


def brute_gap(pa: np.ndarray, pb: np.ndarray) -> float:
    """Least distance between two sample sets [m]."""
    d, _ = cKDTree(pb).query(pa, k=1)
    return float(d.min())


def _cone(axis: np.ndarray, angle: float, n: int) -> np.ndarray:
    z = np.array([0.0, 0.0, 1.0])
    i = np.arange(n) + 0.5
    fz = 1.0 - (1.0 - math.cos(angle)) * i / n  # a Fibonacci spiral on the cap
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    fs = np.sqrt(1.0 - fz * fz)
    f = np.column_stack([fs * np.cos(phi), fs * np.sin(phi), fz])
    v = np.cross(z, axis)
    s, c = np.linalg.norm(v), float(axis @ z)
    if s < 1e-12:
        return f if c > 0 else -f
    k = v / s
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    rot = np.eye(3) + s * kx + (1 - c) * kx @ kx
    return f @ rot.T


def brute_signed_extreme(ea: np.ndarray, eb: np.ndarray) -> float:
    """Signed distance of two convex sample sets: max over n of min(n.a) - max(n.b) [m].

    Only the samples on the sets' hulls matter (see :func:`extreme_samples`).
    """

    def values(dirs: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return (a @ dirs.T).min(axis=0) - (b @ dirs.T).max(axis=0)

    coarse = _fibonacci(2000)
    # a thinned set finds the promising directions; the full sets refine them
    vals = values(coarse, ea[::max(1, len(ea) // 600)], eb[::max(1, len(eb) // 600)])
    value = -math.inf
    # several starts: the function has local maxima (one per face normal of a polytope)
    for start in coarse[np.argsort(vals)[-3:]]:
        n = start
        for angle in (0.08, 0.02, 0.005, 0.0012, 0.0003):
            dirs = np.vstack([_cone(n, angle, 60), n])
            vs = values(dirs, ea, eb)
            i = int(np.argmax(vs))
            n, v = dirs[i], float(vs[i])
        value = max(value, v)
    return value


def random_pose(rng: np.random.Generator, spread: float) -> np.ndarray:
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    t = np.eye(4)
    t[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                 [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                 [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]]
    t[:3, 3] = rng.uniform(-spread, spread, 3)
    return t


# ---- shapes -------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def mesh_files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("meshes")
    cone = trimesh.creation.cone(radius=0.025, height=0.05, sections=24)
    torus = trimesh.creation.torus(major_radius=0.05, minor_radius=0.015, major_sections=48,
                                   minor_sections=24)
    out = {"cone": folder / "cone.stl", "torus": folder / "torus.obj"}
    cone.export(out["cone"])
    torus.export(out["torus"])
    return out


def convex_shapes(meshes: dict[str, Path]) -> dict[str, Geometry]:
    off = Origin((0.004, -0.003, 0.002), (0.3, -0.2, 0.5))
    return {
        "box": Box((0.05, 0.035, 0.025), off),
        "cylinder": Cylinder(0.018, 0.05, off),
        "sphere": Sphere(0.02, off),
        "capsule": Capsule(0.015, 0.04, off),
        "mesh": Mesh(meshes["cone"], (1.2, 0.8, 1.0), off),
    }


KINDS = ("box", "cylinder", "sphere", "capsule", "mesh")


# ---- exact.py against brute force ---------------------------------------------------------------

@pytest.mark.parametrize(("ka", "kb"), list(combinations_with_replacement(KINDS, 2)))
def test_exact_signed_distance_matches_brute_force(ka: str, kb: str,
                                                   mesh_files: dict[str, Path]) -> None:
    shapes = convex_shapes(mesh_files)
    sa, sb = shapes[ka], shapes[kb]
    ea, eb = exact_shape(sa), exact_shape(sb)
    la, lb = surface_samples(sa), surface_samples(sb)
    rng = np.random.default_rng(10 * KINDS.index(ka) + KINDS.index(kb))
    apart = overlapping = 0
    for _ in range(8):
        ta, tb = random_pose(rng, 0.03), random_pose(rng, 0.03)
        got = signed_distance(ea, ta, eb, tb)
        pa, pb = _place(la, ta), _place(lb, tb)
        truth = brute_signed_extreme(_place(extreme_samples(sa), ta),
                                     _place(extreme_samples(sb), tb))
        assert got.distance == pytest.approx(truth, abs=SUPPORT_TOL), (ka, kb, ta, tb)
        # the witness points lie on the surfaces, |distance| apart
        assert np.linalg.norm(pa - got.point_a, axis=1).min() < H
        assert np.linalg.norm(pb - got.point_b, axis=1).min() < H
        assert np.linalg.norm(got.point_a - got.point_b) == pytest.approx(abs(got.distance),
                                                                           abs=1e-6)
        if got.distance > 0:
            apart += 1
            gap = brute_gap(pa, pb)
            assert got.distance <= gap + 1e-9  # no pair of surface points is closer
            assert gap - got.distance < H
        else:
            overlapping += 1
    assert apart >= 2 and overlapping >= 2, (apart, overlapping)  # both cases were seen


def test_sphere_inside_cylinder_near_a_cap() -> None:
    # the case coal's dedicated sphere-cylinder routine gets wrong: the depth is the distance
    # to the cap plus the radius
    cyl = Cylinder(0.03, 0.12)
    ball = Sphere(0.04)
    for x, z in [(0.011, -0.0505), (0.006, 0.0574), (-0.005, 0.054)]:
        t = np.eye(4)
        t[:3, 3] = (x, 0.0, z)
        got = signed_distance(ball, t, cyl, np.eye(4))
        assert got.distance == pytest.approx(-(0.06 - abs(z)) - 0.04, abs=1e-6)
        truth = brute_signed_extreme(_place(extreme_samples(ball), t), extreme_samples(cyl))
        assert got.distance == pytest.approx(truth, abs=SUPPORT_TOL)


@pytest.mark.parametrize("kind", KINDS)
def test_table_distance_matches_lowest_sample(kind: str, mesh_files: dict[str, Path]) -> None:
    shape = convex_shapes(mesh_files)[kind]
    built = exact_shape(shape)
    local = surface_samples(shape)
    rng = np.random.default_rng(11)
    below = 0
    for height in (0.0, 0.013, -0.02):
        for _ in range(8):
            pose = random_pose(rng, 0.04)
            got = table_distance(height, built, pose)
            lowest = float(_place(local, pose)[:, 2].min())
            assert got.distance == pytest.approx(lowest - height, abs=SUPPORT_TOL)
            assert got.point_b[2] == pytest.approx(lowest, abs=SUPPORT_TOL)  # the lowest point
            below += got.distance < 0
    assert 0 < below < 24


def test_surface_mesh_gap_through_the_hole_and_containment(mesh_files: dict[str, Path]) -> None:
    major, minor, r = 0.05, 0.015, 0.01
    surface = exact_shape(Mesh(mesh_files["torus"]), MeshMode.SURFACE)
    hull = exact_shape(Mesh(mesh_files["torus"]), MeshMode.HULL)
    assert surface.closed
    ball = Sphere(r)
    ball_samples = surface_samples(ball)
    torus_samples = surface_samples(Mesh(mesh_files["torus"]))
    rng = np.random.default_rng(5)
    seen = {"hole": 0, "inside": 0, "apart": 0}
    for _ in range(60):
        c = rng.uniform([-0.075, -0.075, -0.035], [0.075, 0.075, 0.035])
        # the smooth torus's signed distance; the mesh is within 0.2 mm of it
        sd = math.hypot(math.hypot(c[0], c[1]) - major, c[2]) - minor
        if abs(sd - r) < 0.002:
            continue
        t = np.eye(4)
        t[:3, 3] = c
        got = signed_distance(ball, t, surface, np.eye(4))
        if sd < r:
            assert got.distance < 0, c  # overlapping, or wholly inside the tube
            seen["inside"] += sd < -r
            # the value bounds the depth from above: the hulls' depth
            assert got.distance <= signed_distance(ball, t, hull, np.eye(4)).distance + 1e-12
        else:
            gap = brute_gap(_place(ball_samples, t), torus_samples)
            assert got.distance <= gap + 1e-9
            assert gap - got.distance < H
            in_hole = math.hypot(c[0], c[1]) < major - minor and abs(c[2]) < minor
            seen["hole" if in_hole else "apart"] += 1
            if in_hole:  # the hull fills the hole: conservative there
                assert signed_distance(ball, t, hull, np.eye(4)).distance < 0
    assert all(v > 0 for v in seen.values()), seen


def test_winding_number_inside_outside(mesh_files: dict[str, Path]) -> None:
    v, f = read_mesh(mesh_files["torus"])
    w = winding_number([[0.05, 0, 0], [0, 0, 0], [0.2, 0, 0], [0.05, 0, 0.014]], v, f)
    assert np.allclose(np.abs(w), [1, 0, 0, 1], atol=1e-6)


def test_mesh_scale_is_applied(mesh_files: dict[str, Path]) -> None:
    # the cone's base is at z = 0, its apex at z = 0.05: upside down, the apex is lowest
    flip = Origin((0.0, 0.0, 0.0), (math.pi, 0.0, 0.0))
    plain = Mesh(mesh_files["cone"], origin=flip)
    tall = Mesh(mesh_files["cone"], (1.0, 1.0, 3.0), flip)
    assert table_distance(0.0, plain, np.eye(4)).distance == pytest.approx(-0.05, abs=1e-6)
    assert table_distance(0.0, tall, np.eye(4)).distance == pytest.approx(-0.15, abs=1e-6)
    mirrored = Mesh(mesh_files["cone"], (1.0, 1.0, -1.0))  # a negative factor mirrors
    assert table_distance(0.0, mirrored, np.eye(4)).distance == pytest.approx(-0.05, abs=1e-6)
    with pytest.raises(InputError, match=r"scale\[1\] is 0"):
        exact_shape(Mesh(mesh_files["cone"], (1.0, 0.0, 1.0)), link="hand")


def test_bad_input_is_refused() -> None:
    with pytest.raises(InputError, match="radius"):
        exact_shape(Sphere(-0.1), link="wrist")
    with pytest.raises(InputError, match=r"\(4, 4\)"):
        signed_distance(Sphere(0.1), np.eye(3), Sphere(0.1), np.eye(4))
    with pytest.raises(InputError, match="height"):
        table_distance(math.nan, Sphere(0.1), np.eye(4))


def test_missing_library_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    monkeypatch.setitem(sys.modules, "coal", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'armctl\[collision\]'"):
        exact_shape(Box((0.1, 0.1, 0.1)))


# ---- the capsule kernels against the exact shapes -----------------------------------------------

ARMS = ("so101", "ur5e", "panda")


def _scene(meshes: dict[str, Path], reach: float) -> SceneSpec:
    s = reach
    obstacles = (
        Obstacle("box", Box((0.3 * s, 0.1 * s, 0.4 * s), Origin((0.45 * s, 0.1 * s, 0.2 * s),
                                                                 (0.0, 0.0, 0.4)))),
        Obstacle("ball", Sphere(0.12 * s, Origin((-0.3 * s, 0.35 * s, 0.5 * s)))),
        Obstacle("post", Cylinder(0.06 * s, 0.6 * s, Origin((0.0, -0.45 * s, 0.3 * s),
                                                             (0.3, 0.0, 0.0)))),
        Obstacle("rail", Capsule(0.05 * s, 0.5 * s, Origin((-0.4 * s, -0.2 * s, 0.3 * s),
                                                            (0.0, 1.2, 0.3)))),
        Obstacle("cone", Mesh(meshes["cone"], (6 * s, 6 * s, 6 * s),
                              Origin((0.2 * s, 0.45 * s, 0.25 * s), (0.5, 0.2, 0.0)))),
    )
    return SceneSpec(table=TableSpec(0.0), obstacles=obstacles, padding=0.0)


def _capsule_shape(a: np.ndarray, b: np.ndarray, r: float) -> tuple[Capsule, np.ndarray]:
    """A schema capsule with the segment a-b, and its pose."""
    from armctl.kinematics.linkshapes import z_to_direction_rpy

    d = b - a
    length = float(np.linalg.norm(d))
    rpy = z_to_direction_rpy(d) if length > 1e-12 else (0.0, 0.0, 0.0)
    return Capsule(r, length, Origin(tuple((a + b) / 2), rpy)), np.eye(4)


def _obstacle_as_kernel_sees_it(shape: Geometry) -> Geometry | None:
    """The primitive the kernels check an obstacle as (None: a mesh's box, not public)."""
    if isinstance(shape, Cylinder):
        return Capsule(shape.radius, shape.length, shape.origin)
    return None if isinstance(shape, Mesh) else shape


@dataclass(frozen=True)
class PairRecord:
    """One checked pair at one configuration: the kernels' answer and the truths."""

    arm: str
    a: str
    b: str
    q: tuple[float, ...]
    kernel: float  # least capsule distance the kernels report for the pair [m]
    same: float | None  # coal's distance between the same capsules and primitives [m]
    exact: float  # coal's distance between the shapes themselves [m]
    box: bool  # b is an obstacle the kernels check as a box (a box or a mesh)
    # for link-link pairs: both links' capsules as (schema capsule, pose) in the base frame
    capsules: tuple[tuple[tuple[Capsule, np.ndarray], ...], ...] = field(
        default=(), compare=False, repr=False)


def _capsule_link(c: LinkCapsule, pose: np.ndarray) -> tuple[Capsule, np.ndarray]:
    a = pose[:3, :3] @ np.asarray(c.a) + pose[:3, 3]
    b = pose[:3, :3] @ np.asarray(c.b) + pose[:3, 3]
    return _capsule_shape(a, b, c.radius)


@lru_cache(maxsize=8)
def kernel_records(name: str, cone: Path, samples: int) -> tuple[PairRecord, ...]:
    """Every checked pair of a bundled arm in a five-obstacle scene, at random configurations."""
    from armctl.collision import CollisionModel, ContactKind

    arm = armctl.load_arm(name)
    scene = _scene({"cone": cone}, float(arm.reach()))
    cm = CollisionModel.of(arm, scene, CollisionSpec())  # every pair checked, adjacent too
    shapes = {k: ls.shapes for k, ls in link_shapes(arm.spec, GeometryRole.COLLISION).items()}
    built = exact_link_shapes(arm.spec)
    assert [b.shape for v in built.values() for b in v] == [x for v in shapes.values() for x in v]
    caps = collision_capsules(arm.spec)
    obstacles = {ob.name: ob.shape for ob in scene.obstacles}
    pad = np.array([scene.padding if cm.pair_names(i)[2] is ContactKind.SCENE else 0.0
                    for i in range(cm.pair_count)])
    out: list[PairRecord] = []
    for q in arm.sample(np.random.default_rng(17), samples):
        frames = arm.fk_frames(q)
        pose = {k: frames[arm.frame_index(k)] for k in shapes}
        slack = cm.slacks(q)
        clear = cm.clearance(q)
        assert clear is not None
        assert clear.distance == pytest.approx(float(slack.min() + pad[np.argmin(slack)]),
                                               abs=1e-12)
        kernel: dict[tuple[str, str], float] = defaultdict(lambda: math.inf)
        for i in range(cm.pair_count):
            a, b, _ = cm.pair_names(i)
            kernel[a, b] = min(kernel[a, b], float(slack[i] + pad[i]))
        for (a, b), kd in kernel.items():
            cap_a = [_capsule_link(c, pose[a]) for c in caps[a]]
            same: float | None
            if b == TABLE:
                exact = min(table_distance(0.0, s, pose[a]).distance for s in built[a])
                same = min(table_distance(0.0, c, p).distance for c, p in cap_a)
            elif b in obstacles:
                exact = min(signed_distance(s, pose[a], obstacles[b], np.eye(4)).distance
                            for s in built[a])
                seen = _obstacle_as_kernel_sees_it(obstacles[b])
                same = (None if seen is None else
                        min(signed_distance(c, p, seen, np.eye(4)).distance for c, p in cap_a))
            else:
                cap_b = [_capsule_link(c, pose[b]) for c in caps[b]]
                exact = min(signed_distance(sa, pose[a], sb, pose[b]).distance
                            for sa in built[a] for sb in built[b])
                same = min(signed_distance(ca, pa, cb, pb).distance
                           for ca, pa in cap_a for cb, pb in cap_b)
            box = b in obstacles and isinstance(obstacles[b], Box | Mesh)
            pair_caps = () if b == TABLE or b in obstacles else (tuple(cap_a), tuple(cap_b))
            out.append(PairRecord(name, a, b, tuple(map(float, q)), kd, same, exact, box,
                                  pair_caps))
    return tuple(out)


@pytest.mark.parametrize("name", ARMS)
def test_capsule_kernels_against_exact_shapes(name: str, mesh_files: dict[str, Path]) -> None:
    records = kernel_records(name, mesh_files["cone"], 25)
    overlapping = 0
    for r in records:
        # the kernels' capsule distance is coal's for the same capsules and primitives
        if r.same is not None and not (r.box and r.same <= 0.0):
            assert r.kernel == pytest.approx(r.same, abs=1e-7), r
        elif r.same is not None:  # a capsule in a box: both see the overlap
            assert r.same - 1e-7 <= r.kernel <= 1e-7, r
        # capsules contain the shapes: whatever the shapes are closer than, so are the
        # capsules (when the capsules are apart, never farther apart than the shapes)
        if r.kernel > 0.0:
            assert r.kernel <= r.exact + 1e-9, r
        else:
            overlapping += 1
        if r.exact <= 0.0:
            assert r.kernel <= 0.0, r
    assert len(records) > 300 and overlapping > 10, (len(records), overlapping)
    # the kernels' distance of two capsules apart against brute force on their surfaces
    single = [r for r in records if len(r.capsules) == 2 and r.kernel > 0.005
              and len(r.capsules[0]) == len(r.capsules[1]) == 1][:6]
    assert len(single) == 6
    for r in single:
        (ca, pa), (cb, pb) = r.capsules[0][0], r.capsules[1][0]
        gap = brute_gap(_place(surface_samples(ca, 0.002), pa),
                        _place(surface_samples(cb, 0.002), pb))
        assert r.kernel <= gap + 1e-9 and gap - r.kernel < 0.002, (r, gap)


def test_capsule_kernel_depth_in_boxes_bounds_the_shapes(mesh_files: dict[str, Path]) -> None:
    records = [r for name in ARMS for r in kernel_records(name, mesh_files["cone"], 25)
               if r.box and r.kernel <= 0.0]
    assert len(records) > 5
    deeper = [r for r in records if r.kernel > r.exact + 1e-9]
    assert not deeper, (len(deeper), max(r.kernel - r.exact for r in deeper), deeper[0])


def test_capsule_distance_matches_brute_force() -> None:
    rng = np.random.default_rng(23)
    found = 0
    for _ in range(12):
        ca = Capsule(0.02, 0.06)
        cb = Capsule(0.015, 0.03)
        ta, tb = random_pose(rng, 0.05), random_pose(rng, 0.05)
        pa, pb = _place(surface_samples(ca), ta), _place(surface_samples(cb), tb)
        got = signed_distance(ca, ta, cb, tb).distance
        # capsules: the segment distance less the radii, in closed form
        sa = [ta[:3, 3] - ta[:3, 2] * 0.03, ta[:3, 3] + ta[:3, 2] * 0.03]
        sb = [tb[:3, 3] - tb[:3, 2] * 0.015, tb[:3, 3] + tb[:3, 2] * 0.015]
        closed = _segment_distance(*sa, *sb) - 0.035
        assert got == pytest.approx(closed, abs=1e-9)
        if got > 0:
            gap = brute_gap(pa, pb)
            assert got <= gap + 1e-9 and gap - got < H
            found += 1
        else:
            truth = brute_signed_extreme(_place(extreme_samples(ca), ta),
                                         _place(extreme_samples(cb), tb))
            assert got == pytest.approx(truth, abs=SUPPORT_TOL)
    assert 2 < found < 10


def _segment_distance(p0: np.ndarray, p1: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> float:
    """Segment-segment distance by dense sampling of one segment and projection on the other."""
    s = np.linspace(0.0, 1.0, 20001)[:, None]
    pts = p0 + s * (p1 - p0)
    d = q1 - q0
    t = np.clip((pts - q0) @ d / (d @ d), 0.0, 1.0)[:, None]
    return float(np.linalg.norm(pts - (q0 + t * d), axis=1).min())


def test_shape_capsules_contain_their_shapes(mesh_files: dict[str, Path]) -> None:
    # the capsule of every shape is never farther than the shape from any other shape
    shapes = convex_shapes(mesh_files)
    rng = np.random.default_rng(29)
    for kind, shape in shapes.items():
        a, b, r = shape_capsule(shape)
        cap, cap_pose = _capsule_shape(a, b, r)
        samples = surface_samples(shape)
        # every sample of the shape is inside its capsule
        seg = b - a
        t = np.clip((samples - a) @ seg / max(float(seg @ seg), 1e-18), 0.0, 1.0)[:, None]
        assert np.linalg.norm(samples - (a + t * seg), axis=1).max() <= r + 1e-9, kind
        for _ in range(10):
            other_pose = random_pose(rng, 0.06)
            probe = Box((0.02, 0.03, 0.01))
            d_cap = signed_distance(cap, cap_pose, probe, other_pose).distance
            d_shape = signed_distance(shape, np.eye(4), probe, other_pose).distance
            assert d_cap <= d_shape + 1e-9, kind
