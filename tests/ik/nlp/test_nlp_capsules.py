import numpy as np
import pytest
from brute_depth import segment_box_depth

from armctl.kinematics.capsules import (
    arm_capsules,
    collision_capsules,
    segment_box_distance,
    segment_point_distance,
    world_segments,
)
from armctl.kinematics.linkshapes import MeshLoadError, default_radius


def _by_link(caps):
    out = {}
    for c in caps:
        out.setdefault(c.link, []).append(c)
    return out


def test_capsules_from_shapes_and_default_shapes(twoarm):
    caps = _by_link(arm_capsules(twoarm))
    # the torso's capsule shape as given; the cylinder on la1 as a capsule along its axis
    (torso,) = caps["torso"]
    assert torso.radius == 0.05
    np.testing.assert_allclose(torso.a, [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(torso.b, [0, 0, 0.3], atol=1e-12)
    np.testing.assert_allclose(caps["la1"][0].b, [0.25, 0, 0], atol=1e-7)
    # the box on ra1: along its long x axis, radius covers the 0.04 x 0.04 section
    assert np.isclose(caps["ra1"][0].radius, np.hypot(0.02, 0.02))
    # links without shapes get the default shapes, sized by the arm: 3.5 % of the longest
    # base-to-leaf path (lift 0 + shoulder 0.15/0.3 offset + 0.25 + 0.2 + 0.1)
    r = 0.035 * (np.hypot(0.15, 0.3) + 0.25 + 0.2 + 0.1)
    assert np.isclose(default_radius(twoarm.spec), r)
    hub, segment = caps["la2"]
    # the hub on the joint axis (y) and the segment to the child's origin
    np.testing.assert_allclose(np.abs(hub.a), [0, 1.3 * r, 0], atol=1e-9)
    assert np.isclose(hub.radius, 1.3 * r)
    np.testing.assert_allclose(segment.a, [0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(segment.b, [0.2, 0, 0], atol=1e-9)
    assert np.isclose(segment.radius, r)
    # the end effector's marker sphere on la3
    assert any(np.allclose(c.a, [0.1, 0, 0]) and np.allclose(c.b, [0.1, 0, 0])
               and np.isclose(c.radius, 0.8 * r) for c in caps["la3"])
    # an explicit radius replaces the scaled one for the default shapes only
    fixed = _by_link(arm_capsules(twoarm, 0.02))
    assert np.isclose(fixed["la2"][1].radius, 0.02)
    assert fixed["torso"][0].radius == 0.05
    # links fixed to the base (the base and its default box) are left out
    assert "base" not in caps


def test_body_capsules_are_the_link_capsules(twoarm):
    # one implementation: the NLP's body-frame capsules are the drawing code's link capsules
    rng = np.random.default_rng(4)
    per_link = collision_capsules(twoarm.spec)
    caps = arm_capsules(twoarm)
    for q in twoarm.sample(rng, 3):
        a, b = world_segments(twoarm, q, caps)
        expected = [end for name in per_link if name != "base"
                    for c in per_link[name] for end in c.world(twoarm.fk(q, name))]
        np.testing.assert_allclose(np.ravel(list(zip(a, b, strict=True))),
                                   np.ravel(expected), atol=1e-12)
        assert [c.radius for c in caps] == [c.radius for name in per_link if name != "base"
                                            for c in per_link[name]]


def test_world_segments_follow_fk(twoarm):
    caps = arm_capsules(twoarm)
    q = twoarm.sample(np.random.default_rng(1))
    a, b = world_segments(twoarm, q, caps)
    # la3's default segment runs from its origin to the tool frame
    k = next(i for i, c in enumerate(caps)
             if c.link == "la3" and np.isclose(c.radius, default_radius(twoarm.spec)))
    np.testing.assert_allclose(a[k], twoarm.fk(q, "la3")[:3, 3], atol=1e-9)
    np.testing.assert_allclose(b[k], twoarm.fk(q, "left_tip")[:3, 3], atol=1e-9)


def test_distances_against_dense_sampling():
    rng = np.random.default_rng(2)
    lower, upper = np.array([-0.1, -0.2, 0.0]), np.array([0.2, 0.1, 0.3])
    ts = np.linspace(0, 1, 20001)
    for _ in range(30):
        a, b, p = rng.uniform(-0.6, 0.6, (3, 3))
        pts = a + ts[:, None] * (b - a)
        assert np.isclose(segment_point_distance(a, b, p),
                          np.linalg.norm(pts - p, axis=1).min(), atol=1e-4)
        outside = np.linalg.norm(np.maximum(np.maximum(lower - pts, pts - upper), 0), axis=1)
        inside = np.minimum(np.minimum(pts - lower, upper - pts).min(axis=1), 0)
        depth = np.where(outside > 0, outside, -np.minimum(pts - lower, upper - pts).min(axis=1))
        assert inside.max() <= 0
        got = segment_box_distance(a, b, lower, upper)
        if depth.min() > 0:
            assert np.isclose(got, depth.min(), atol=1e-4)
        else:  # inside: minus the penetration depth (at least the deepest point's depth)
            centre, half = (lower + upper) / 2, (upper - lower) / 2
            assert got <= depth.min() + 1e-9
            assert np.isclose(got, -segment_box_depth(np.stack([a, b]) - centre, half),
                              atol=1e-6)


def _mesh_arm(folder, mesh, scale="[1, 2, 1]"):
    from armctl.arm import load_arm

    (folder / "arm.yaml").write_text(
        "name: meshy\nbase: base\ntool: l1\n"
        f"links:\n  - {{name: l1, visual: [{{shape: mesh, path: {mesh}, scale: {scale},"
        " origin: {xyz: [0.15, 0, 0]}}]}\n"
        "joints:\n  - {name: j1, type: revolute, parent: base, child: l1, axis: [0, 0, 1],"
        " limits: {lower: -1, upper: 1}}\n")
    return load_arm(folder / "arm.yaml")


def test_mesh_shapes_become_their_main_axis_capsule(tmp_path):
    import trimesh

    box = trimesh.creation.box(extents=[0.3, 0.04, 0.06])
    box.export(tmp_path / "link.stl")
    (cap,) = arm_capsules(_mesh_arm(tmp_path, "link.stl"))
    # along the long x axis, covering the scaled 0.08 x 0.06 section
    np.testing.assert_allclose(sorted([cap.a[0], cap.b[0]]), [0.0, 0.3], atol=1e-6)  # float32 STL
    assert np.isclose(cap.radius, np.hypot(0.04, 0.03), atol=1e-6)
    # a mesh lying diagonally in its file: the capsule follows it (a bounding box would not)
    turn = trimesh.transformations.rotation_matrix(np.pi / 4, [0, 0, 1])
    box.apply_transform(turn)
    box.export(tmp_path / "diagonal.stl")
    (cap,) = arm_capsules(_mesh_arm(tmp_path, "diagonal.stl", "[1, 1, 1]"))
    axis = np.subtract(cap.b, cap.a)
    assert np.isclose(np.linalg.norm(axis), 0.3, atol=1e-6)
    np.testing.assert_allclose(np.abs(axis) / 0.3, [np.sqrt(0.5), np.sqrt(0.5), 0], atol=1e-6)
    assert np.isclose(cap.radius, np.hypot(0.02, 0.03), atol=1e-6)
    a, b = np.array(cap.a), np.array(cap.b)
    assert all(segment_point_distance(a, b, v) <= cap.radius + 1e-6
               for v in np.asarray(box.vertices) + np.array([0.15, 0, 0]))


def test_missing_mesh_is_a_config_error(tmp_path):
    arm = _mesh_arm(tmp_path, "nowhere.stl")
    with pytest.raises(MeshLoadError, match=r"nowhere\.stl.*file not found"):
        arm_capsules(arm)
