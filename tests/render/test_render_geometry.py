"""Link geometry bound rigidly to links: tessellation, posing, defaults, collision capsules."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from render_indep import IndependentArm, origin_matrix

from armctl.arm import load_arm
from armctl.config.schema import Box, Capsule, Cylinder, Mesh, Origin, Sphere
from armctl.render import (
    BoundGeometry,
    GeometryRole,
    collision_capsules,
    link_meshes,
    link_shapes,
    shape_capsule,
    shape_mesh,
)
from armctl.render.errors import MeshLoadError
from armctl.render.shapes import box_mesh, capsule_mesh, cylinder_mesh, load_mesh_file, sphere_mesh

HERE = Path(__file__).parent / "data"
SHAPES5 = HERE / "shapes5.yaml"
PLANAR = Path(__file__).parent.parent / "data" / "planar3r.yaml"


def seg_dist(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = b - a
    s = np.clip((p - a) @ d / max(float(d @ d), 1e-30), 0, 1)
    return np.linalg.norm(p - (a + s[:, None] * d), axis=1)


# ---- tessellation ------------------------------------------------------------------------------
@pytest.mark.parametrize(("mesh", "volume", "rtol"), [
    (box_mesh((0.1, 0.2, 0.3)), 0.1 * 0.2 * 0.3, 1e-12),
    (cylinder_mesh(0.1, 0.4, 64), math.pi * 0.01 * 0.4, 0.01),
    (sphere_mesh(0.2, 64), 4 / 3 * math.pi * 0.008, 0.01),
    (capsule_mesh(0.1, 0.3, 64), math.pi * 0.01 * 0.3 + 4 / 3 * math.pi * 0.001, 0.01),
])
def test_tessellated_volume_is_positive_and_close(mesh, volume, rtol):
    # positive signed volume = every triangle faces outwards
    assert mesh.volume() == pytest.approx(volume, rel=rtol)
    assert mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices)


def test_shape_surfaces():
    cyl = cylinder_mesh(0.05, 0.2)
    r = np.linalg.norm(cyl.vertices[:, :2], axis=1)
    on_side = r > 1e-12
    assert np.allclose(r[on_side], 0.05) and np.allclose(np.abs(cyl.vertices[:, 2]), 0.1)
    assert np.allclose(np.linalg.norm(sphere_mesh(0.07).vertices, axis=1), 0.07)
    cap = capsule_mesh(0.03, 0.2)
    d = seg_dist(cap.vertices, np.array([0, 0, -0.1]), np.array([0, 0, 0.1]))
    assert np.allclose(d, 0.03)
    corners = {tuple(np.round(c, 9)) for c in itertools.product((-0.05, 0.05), (-0.1, 0.1),
                                                                   (-0.15, 0.15))}
    assert {tuple(np.round(v, 9)) for v in box_mesh((0.1, 0.2, 0.3)).vertices} == corners


def test_mesh_file_scale_and_origin():
    raw = np.array([[0, 0, 0], [0, 0.02, 0], [0.03, 0, 0], [0, 0, 0.04]])
    origin = Origin((0.1, -0.2, 0.3), (0.3, 0.2, -0.1))
    m = shape_mesh(Mesh(HERE / "tetra.stl", (1.0, 2.0, 0.5), origin), "l3")
    t = origin_matrix({"xyz": [0.1, -0.2, 0.3], "rpy": [0.3, 0.2, -0.1]})
    want = (raw * [1.0, 2.0, 0.5]) @ t[:3, :3].T + t[:3, 3]
    got = np.round(m.vertices, 9)
    assert {tuple(v) for v in got} == {tuple(v) for v in np.round(want, 9)}
    assert m.volume() == pytest.approx(0.03 * 0.02 * 0.04 / 6 * (1.0 * 2.0 * 0.5), rel=1e-9)


def test_mesh_file_errors(tmp_path):
    with pytest.raises(MeshLoadError) as err:
        load_mesh_file(tmp_path / "missing.stl", "forearm")
    assert "missing.stl" in str(err.value) and "forearm" in str(err.value)
    assert "file not found" in str(err.value)
    bad = tmp_path / "bad.stl"
    bad.write_text("this is not a mesh")
    with pytest.raises(MeshLoadError, match=r"bad\.stl"):
        load_mesh_file(bad, "forearm")


# ---- binding: vertices move exactly with their link --------------------------------------------
def test_bound_shapes_in_link_frame_match_independent_origins():
    arm = load_arm(SHAPES5)
    geo = BoundGeometry(arm)
    by_link = {}
    for s in geo.shapes:
        by_link.setdefault(s.link, []).append(s)
    base_box = by_link["base"][0].mesh.vertices
    want = {tuple(np.round(np.add(c, (0.0, 0.0, -0.02)), 9))
            for c in itertools.product((-0.06, 0.06), (-0.05, 0.05), (-0.02, 0.02))}
    assert {tuple(np.round(v, 9)) for v in base_box} == want
    # cylinder of l1: in its own frame (independent origin) the vertices lie on the surface
    t = origin_matrix({"xyz": [0, 0, 0.05], "rpy": [0.1, -0.2, 0.3]})
    local = (by_link["l1"][0].mesh.vertices - t[:3, 3]) @ t[:3, :3]
    r = np.linalg.norm(local[:, :2], axis=1)
    assert np.allclose(r[r > 1e-9], 0.03) and np.allclose(np.abs(local[:, 2]), 0.05)
    # capsule and sphere of l2
    t = origin_matrix({"xyz": [0.125, 0, 0], "rpy": [0, 1.5707963, 0]})
    a, b = t[:3, 3] - t[:3, 2] * 0.125, t[:3, 3] + t[:3, 2] * 0.125
    assert np.allclose(seg_dist(by_link["l2"][0].mesh.vertices, a, b), 0.025)
    assert np.allclose(np.linalg.norm(by_link["l2"][1].mesh.vertices, axis=1), 0.04)


def test_every_vertex_follows_its_link_fk():
    arm = load_arm(SHAPES5)
    ind = IndependentArm(SHAPES5)
    geo = BoundGeometry(arm)
    rng = np.random.default_rng(7)
    for q in arm.sample(rng, 5):
        world = geo.world_vertices(q)
        start = 0
        for s in geo.shapes:
            n = len(s.mesh.vertices)
            t = ind.link_pose(s.link, q)
            want = s.mesh.vertices @ t[:3, :3].T + t[:3, 3]
            np.testing.assert_allclose(world[start:start + n], want, atol=1e-12)
            start += n
        assert start == len(world)
        meshes = link_meshes(arm, q)
        assert set(meshes) == {"base", "l1", "l2", "l3", "flange", "l4"}
        t = ind.link_pose("l3", q)
        l3 = next(s for s in geo.shapes if s.link == "l3").mesh.vertices
        np.testing.assert_allclose(meshes["l3"].vertices, l3 @ t[:3, :3].T + t[:3, 3],
                                   atol=1e-12)


def test_vertex_frame_assignment_is_rigid():
    arm = load_arm(SHAPES5)
    geo = BoundGeometry(arm)
    # every vertex is bound to exactly one link: moving only j4 (prismatic, last) must move
    # exactly the vertices of l4 and nothing else, by exactly the joint travel along its axis
    q0 = arm.middle()
    q1 = q0.copy()
    q1[3] += 0.01
    v0, v1 = geo.world_vertices(q0), geo.world_vertices(q1)
    moved = np.linalg.norm(v1 - v0, axis=1) > 1e-12
    l4 = arm.frame_index("l4")
    assert np.array_equal(moved, geo.vertex_frame == l4)
    assert np.allclose(np.linalg.norm(v1[moved] - v0[moved], axis=1), 0.01)


# ---- defaults ----------------------------------------------------------------------------------
def test_default_geometry_follows_the_segments():
    arm = load_arm(PLANAR)
    shapes = link_shapes(arm.spec)
    assert all(ls.default for ls in shapes.values())
    assert isinstance(shapes["base"].shapes[0], Box)
    caps = collision_capsules(arm.spec)
    q = np.array([0.4, -0.7, 1.1])
    poses = arm.fk_all(q)
    # the capsule of link i runs from its origin to the next joint's origin (the tool for l3)
    for link, nxt in (("l1", "l2"), ("l2", "l3"), ("l3", "tip")):
        pairs = zip(caps[link], shapes[link].shapes, strict=True)
        seg = [c for c, sh in pairs if isinstance(sh, Capsule)]
        assert len(seg) == 1
        a, b = seg[0].world(poses[link])
        ends = sorted([a, b], key=lambda p: np.linalg.norm(p - poses[link][:3, 3]))
        np.testing.assert_allclose(ends[0], poses[link][:3, 3], atol=1e-12)
        np.testing.assert_allclose(ends[1], poses[nxt][:3, 3], atol=1e-12)
    # a marker sphere sits on the tool frame
    marker = [s for s in shapes["l3"].shapes if isinstance(s, Sphere)]
    assert len(marker) == 1 and marker[0].origin.xyz == (0.1, 0.0, 0.0)


def test_default_geometry_only_for_links_without_their_own():
    arm = load_arm(SHAPES5)
    shapes = link_shapes(arm.spec)
    assert [n for n, ls in shapes.items() if ls.default] == ["l4"]
    kinds = {type(s) for s in shapes["l4"].shapes}
    assert kinds == {Box, Capsule, Sphere}  # prismatic hub, segment to the tool, tool marker


# ---- collision capsules ------------------------------------------------------------------------
def test_capsules_contain_their_shapes():
    arm = load_arm(SHAPES5)
    caps = collision_capsules(arm.spec)
    col = link_shapes(arm.spec, GeometryRole.COLLISION)
    for link, ls in col.items():
        assert len(caps[link]) == len(ls.shapes) >= 1
        for cap, shape in zip(caps[link], ls.shapes, strict=True):
            v = shape_mesh(shape, link, arm.spec.file).vertices
            d = seg_dist(v, np.array(cap.a), np.array(cap.b))
            assert np.all(d <= cap.radius + 1e-9), (link, shape)
    # l2 uses its collision capsule (radius 0.03), not the visual one
    assert caps["l2"][0].radius == pytest.approx(0.03)
    np.testing.assert_allclose(np.linalg.norm(np.subtract(caps["l2"][0].b, caps["l2"][0].a)),
                               0.25)


def test_mesh_capsule_contains_raw_and_simplified_vertices(tmp_path):
    # a long, placed ellipsoid with more triangles than the drawing keeps: the capsule is fitted to
    # the file's own vertices, so it holds them and the simplified ones drawn
    import trimesh

    from armctl.render.shapes import MAX_MESH_FACES

    blob = trimesh.creation.icosphere(subdivisions=5, radius=1.0)
    assert len(blob.faces) > MAX_MESH_FACES
    blob.apply_scale([0.2, 0.03, 0.05])
    blob.export(tmp_path / "blob.stl")
    shape = Mesh(tmp_path / "blob.stl", (1.0, 1.5, 1.0), Origin((0.1, 0.0, 0.2), (0.3, 0.0, 0.0)))
    a, b, r = shape_capsule(shape, "blob")
    drawn = shape_mesh(shape, "blob").vertices
    assert len(drawn) < len(blob.vertices)
    t = origin_matrix({"xyz": [0.1, 0.0, 0.2], "rpy": [0.3, 0.0, 0.0]})
    raw = (np.asarray(blob.vertices) * [1.0, 1.5, 1.0]) @ t[:3, :3].T + t[:3, 3]
    for v in (raw, drawn):
        assert np.all(seg_dist(v, a, b) <= r + 1e-6)
    # along the long axis (x in the file), as long as the ellipsoid, radius its largest half axis
    # across (0.05 on z; 0.045 on the scaled y)
    np.testing.assert_allclose(np.abs(b - a) / np.linalg.norm(b - a),
                               np.abs(t[:3, 0]), atol=1e-6)
    assert np.linalg.norm(b - a) == pytest.approx(0.4, abs=1e-3)
    assert r == pytest.approx(0.05, abs=1e-3)


def test_capsule_exact_for_capsules_and_spheres():
    a, b, r = shape_capsule(Capsule(0.02, 0.3, Origin((1.0, 2.0, 3.0), (0.0, math.pi / 2, 0.0))))
    np.testing.assert_allclose(sorted([a[0], b[0]]), [0.85, 1.15], atol=1e-12)
    assert r == 0.02
    a, b, r = shape_capsule(Sphere(0.05, Origin((0.1, 0.0, 0.0))))
    np.testing.assert_allclose(a, b)
    np.testing.assert_allclose(a, [0.1, 0, 0])
    a, b, r = shape_capsule(Cylinder(0.04, 0.2))
    np.testing.assert_allclose([a, b], [[0, 0, -0.1], [0, 0, 0.1]], atol=1e-15)


def test_urdf_meshes_are_found_and_bound():
    # package:// resolves against the URDF's folder; OBJ and STL both load; volumes are exact
    from render_indep import rot_x, rot_z

    arm = load_arm(HERE / "mesh_arm.urdf")
    geo = BoundGeometry(arm)
    kinds = {s.link: s for s in geo.shapes}
    assert kinds["arm"].mesh.volume() == pytest.approx(0.03 * 0.02 * 0.04 / 6 * 8)
    assert kinds["hand"].mesh.volume() == pytest.approx(0.04**2 * 0.05 / 3)
    q = np.array([0.7, -0.4])
    world = geo.world_vertices(q)
    # independent: arm frame = Trans(0, 0, 0.05) Rz(q1); hand = arm Trans(0.1, 0, 0) Rx(pi/2) Rz(q2)
    t_arm = np.eye(4)
    t_arm[:3, :3], t_arm[:3, 3] = rot_z(0.7), [0, 0, 0.05]
    t_hand = np.eye(4)
    t_hand[:3, :3], t_hand[:3, 3] = rot_x(1.5707963) @ rot_z(-0.4), [0.1, 0, 0]
    t_hand = t_arm @ t_hand
    raw = np.array([[0, 0, 0], [0, 0.02, 0], [0.03, 0, 0], [0, 0, 0.04]]) * 2
    vis = origin_matrix({"xyz": [0.01, 0, 0.02], "rpy": [0, 0, 0.5]})
    want_arm = (raw @ vis[:3, :3].T + vis[:3, 3]) @ t_arm[:3, :3].T + t_arm[:3, 3]
    got_arm = world[geo.vertex_frame == arm.frame_index("arm")]
    assert {tuple(v) for v in np.round(got_arm, 9)} == {tuple(v) for v in np.round(want_arm, 9)}
    pyramid = np.array([[0, 0, 0], [0.04, 0, 0], [0.04, 0.04, 0], [0, 0.04, 0], [0.02, 0.02, 0.05]])
    got_hand = world[geo.vertex_frame == arm.frame_index("hand")]
    np.testing.assert_allclose(got_hand, pyramid @ t_hand[:3, :3].T + t_hand[:3, 3], atol=1e-12)


def test_dae_mesh_loads():
    m = load_mesh_file(HERE / "box.dae", "flange")
    np.testing.assert_allclose(m.vertices.min(axis=0), [-0.04, -0.08, -0.12], atol=1e-6)
    np.testing.assert_allclose(m.vertices.max(axis=0), [0.06, 0.12, 0.18], atol=1e-6)
    assert abs(m.volume()) == pytest.approx(0.006, rel=1e-5)


def test_large_meshes_are_simplified(tmp_path):
    import trimesh

    from armctl.render.shapes import MAX_MESH_FACES

    fine = trimesh.creation.icosphere(subdivisions=5, radius=0.1)  # 20480 triangles
    path = tmp_path / "ball.stl"
    fine.export(path)
    m = load_mesh_file(path, "ball")
    assert 1000 < len(m.faces) <= MAX_MESH_FACES
    # still the same ball: vertices on the sphere and nearly the same volume
    assert np.abs(np.linalg.norm(m.vertices, axis=1) - 0.1).max() < 0.005
    assert m.volume() == pytest.approx(4 / 3 * np.pi * 0.1**3, rel=0.02)
