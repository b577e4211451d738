"""The figure's skin: one mesh, every vertex bound to one bone, drawn T_b(q) T_b(q_bind)^-1 v.

The independent truth is a per-vertex chain of 4x4 matrices along the path from the root,
built here from the joint origins and axes of the arm file (scipy rotations), not from
armctl's kinematics.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from chain_truth import by_name, chain_poses
from scipy.spatial.transform import Rotation

from armctl.config import bundled_configs_dir, load_spec
from armctl.errors import ConfigError
from armctl.kinematics.model import KinematicModel
from armctl.render.binding import BoundGeometry

FIGURE = bundled_configs_dir() / "figure.yaml"
SKIN = bundled_configs_dir() / "figure_skin.npz"


@pytest.fixture(scope="module")
def figure() -> KinematicModel:
    return KinematicModel(load_spec("figure"))


def _copy(folder: Path) -> Path:
    """The figure and its skin file copied into ``folder``; returns the arm file."""
    shutil.copyfile(SKIN, folder / SKIN.name)
    return Path(shutil.copyfile(FIGURE, folder / FIGURE.name))


def test_skin_file_binds_every_vertex_to_one_bone():
    with np.load(SKIN, allow_pickle=False) as data:
        vertices, faces = data["vertices"], data["faces"]
        bones, vertex_bone = data["bones"], data["vertex_bone"]
    assert 2000 <= len(faces) <= 10000  # a few thousand triangles
    assert vertex_bone.shape == (len(vertices),)  # exactly one bone per vertex
    assert set(vertex_bone.tolist()) == set(range(len(bones)))  # every bone has vertices
    assert SKIN.stat().st_size < 300_000
    # height of an adult, standing on the floor
    assert vertices[:, 2].min() == pytest.approx(0.0, abs=0.01)
    assert vertices[:, 2].max() == pytest.approx(1.75, abs=0.01)


def test_posed_vertices_equal_a_chain_of_matrices(figure: KinematicModel, tmp_path: Path):
    doc = yaml.safe_load(figure.spec.file.read_text(encoding="utf-8"))
    skin = figure.spec.skin
    assert skin is not None
    geo = BoundGeometry(figure)
    drawn_count = sum(len(s.mesh.vertices) for s in geo.shapes)
    assert drawn_count >= len(skin.vertices)
    rng = np.random.default_rng(5)
    assert skin.bind_pose == "tpose"
    bind = chain_poses(doc, by_name(figure, figure.named_pose("tpose")))
    for _ in range(3):
        q = figure.sample(rng)
        poses = chain_poses(doc, by_name(figure, q))
        expected = np.array([(poses[b] @ np.linalg.inv(bind[b]) @ np.append(v, 1.0))[:3]
                             for v, b in zip(skin.vertices, skin.vertex_link, strict=True)])
        drawn = geo.world_vertices(q)
        # every skin vertex is drawn where its bone puts it (the drawing may copy a vertex
        # shared by triangles of two bones; each copy follows its own bone)
        per_shape = [(s.link, s.mesh.vertices) for s in geo.shapes]
        assert {lk for lk, _ in per_shape} == set(skin.vertex_link)
        for bone in set(skin.vertex_link):
            mine = np.array([b == bone for b in skin.vertex_link])
            start = sum(len(v) for lk, v in per_shape[:[lk for lk, _ in per_shape].index(bone)])
            count = len(dict(per_shape)[bone])
            got = drawn[start:start + count]
            want = expected[mine]
            # same point sets: each expected vertex is among the drawn ones of its bone
            d = np.linalg.norm(want[:, None, :] - got[None, :, :], axis=2).min(axis=1)
            assert d.max() < 1e-9, bone


def test_the_mesh_follows_its_bones(figure: KinematicModel):
    geo = BoundGeometry(figure)
    rng = np.random.default_rng(9)
    q0 = figure.named_pose("tpose")
    q1 = figure.sample(rng)
    a, b = geo.world_vertices(q0), geo.world_vertices(q1)
    moved = np.linalg.norm(a - b, axis=1)
    assert moved.max() > 0.3  # it moves
    for link in set(figure.spec.skin.vertex_link):  # type: ignore[union-attr]
        idx = np.flatnonzero(np.array(geo.links)[geo.face_link] == link)
        verts = np.unique(geo.faces[idx].ravel())
        da = np.linalg.norm(a[verts][:, None] - a[verts][None], axis=2)
        db = np.linalg.norm(b[verts][:, None] - b[verts][None], axis=2)
        np.testing.assert_allclose(da, db, atol=1e-9)  # rigid: distances kept
    # the bind pose draws the mesh as modelled
    skin = figure.spec.skin
    assert skin is not None
    d = np.linalg.norm(skin.vertices[:, None] - a[None], axis=2).min(axis=1)
    assert d.max() < 1e-9


def _variant(tmp_path: Path, **arrays: np.ndarray) -> Path:
    arm = _copy(tmp_path)
    with np.load(SKIN, allow_pickle=False) as data:
        content = {k: data[k] for k in data.files}
    content.update(arrays)
    np.savez(tmp_path / "figure_skin.npz", **content)  # type: ignore[arg-type]
    return arm


def test_wrong_vertex_count_is_a_clear_error(tmp_path: Path):
    with np.load(SKIN) as data:
        short = data["vertex_bone"][:-5]
    with pytest.raises(ConfigError, match=r"binds .* vertices but the mesh has .*exactly one"):
        load_spec(_variant(tmp_path, vertex_bone=short))


def test_unknown_bone_is_a_clear_error(tmp_path: Path):
    with np.load(SKIN) as data:
        bones = data["bones"].copy()
    bones[0] = "pelvsi"
    with pytest.raises(ConfigError, match="'pelvsi' is not a link") as info:
        load_spec(_variant(tmp_path, bones=bones))
    assert "pelvis" in str(info.value)  # the fix names the near link
    assert info.value.details["key"] == "skin.mesh"


def test_bad_or_missing_file_is_a_clear_error(tmp_path: Path):
    arm = _copy(tmp_path)
    (tmp_path / "figure_skin.npz").write_bytes(b"not a zip")
    with pytest.raises(ConfigError, match="cannot read the skin file"):
        load_spec(arm)
    (tmp_path / "figure_skin.npz").unlink()
    with pytest.raises(ConfigError, match="not found"):
        load_spec(arm)
    faces = np.array([[0, 1, 99999]])
    with pytest.raises(ConfigError, match="refers to vertex 99999"):
        load_spec(_variant(tmp_path, faces=faces))
    doc = yaml.safe_load(arm.read_text(encoding="utf-8"))
    doc["skin"]["bind_pose"] = "nope"
    arm.write_text(yaml.safe_dump(doc), encoding="utf-8")
    with pytest.raises(ConfigError, match="bind pose 'nope' is not a named pose"):
        load_spec(arm)


def test_the_writer_keeps_the_skin(tmp_path: Path, figure: KinematicModel):
    from armctl.config.writer import dump_arm_yaml

    out = tmp_path / "sub" / "figure_copy.yaml"
    out.parent.mkdir()
    out.write_text(dump_arm_yaml(figure.spec, out), encoding="utf-8")
    again = KinematicModel(load_spec(out))
    assert again.spec.skin is not None and again.spec.skin.bind_pose == "tpose"
    q = figure.sample(np.random.default_rng(2))
    a, b = BoundGeometry(again).world_vertices(q), BoundGeometry(figure).world_vertices(q)
    assert a.shape == b.shape  # the same vertices, the moved pelvis' part drawn last
    assert np.linalg.norm(a[:, None] - b[None], axis=2).min(axis=1).max() < 1e-9


def test_a_bind_pose_other_than_zero(tmp_path: Path, figure: KinematicModel):
    """The same mesh declared as modelled in 'stand' is drawn as in the file at 'stand'."""
    arm = _copy(tmp_path)
    doc = yaml.safe_load(arm.read_text(encoding="utf-8"))
    doc["skin"]["bind_pose"] = "stand"
    arm.write_text(yaml.safe_dump(doc), encoding="utf-8")
    other = KinematicModel(load_spec(arm))
    skin = other.spec.skin
    assert skin is not None
    drawn = BoundGeometry(other).world_vertices(other.named_pose("stand"))
    d = np.linalg.norm(skin.vertices[:, None] - drawn[None], axis=2).min(axis=1)
    assert d.max() < 1e-9
    # at the T-pose each vertex is moved by T_b(0) T_b(stand)^-1 (chain of matrices)
    stand = chain_poses(doc, by_name(other, other.named_pose("stand")))
    zero = chain_poses(doc, by_name(other, other.named_pose("tpose")))
    want = np.array([(zero[b] @ np.linalg.inv(stand[b]) @ np.append(v, 1.0))[:3]
                     for v, b in zip(skin.vertices, skin.vertex_link, strict=True)])
    drawn = BoundGeometry(other).world_vertices(other.named_pose("tpose"))
    d = np.linalg.norm(want[:, None] - drawn[None], axis=2).min(axis=1)
    assert d.max() < 1e-9


def test_the_shipped_skin_is_what_the_tool_builds():
    import importlib.util

    tool = Path(__file__).parent.parent.parent / "tools" / "make_figure_mesh.py"
    spec = importlib.util.spec_from_file_location("make_figure_mesh", tool)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    built = module.build(FIGURE)
    with np.load(SKIN, allow_pickle=False) as data:
        for key in ("vertices", "faces", "bones", "vertex_bone"):
            np.testing.assert_array_equal(data[key], built[key], err_msg=key)


def test_a_skin_on_an_arm_with_a_ball_joint(tmp_path: Path):
    """Vertices of a bone behind a ball joint follow it: T_b(q) T_b(q_bind)^-1 v, the bind
    pose every coordinate at zero and the ball at the identity."""
    from armctl_testpaths import DATA

    arm_file = tmp_path / "ball_arm.yaml"
    doc = yaml.safe_load((DATA / "ball_arm.yaml").read_text(encoding="utf-8"))
    doc["skin"] = {"mesh": "skin.npz"}
    arm_file.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    rng = np.random.default_rng(3)
    vertices = rng.uniform(-0.05, 0.05, (12, 3)) + np.array([0.0, 0.0, 0.3])
    np.savez(tmp_path / "skin.npz", vertices=vertices, faces=np.arange(12).reshape(4, 3),
             bones=np.array(["upper", "fore"]), vertex_bone=np.repeat([0, 1], 6))
    arm = KinematicModel(load_spec(arm_file))
    q = arm.integrate(arm.neutral(), rng.uniform(-0.8, 0.8, arm.nv))
    frames = arm.fk_frames(q)
    zero = np.zeros(arm.nq)
    zero[arm.q_index("shoulder").start] = 1.0  # the identity quaternion
    bind = arm.fk_frames(zero)
    drawn = BoundGeometry(arm).world_vertices(q)
    for v, bone in zip(vertices, ["upper"] * 6 + ["fore"] * 6, strict=True):
        i = arm.frame_index(bone)
        want = (frames[i] @ np.linalg.inv(bind[i]) @ np.append(v, 1.0))[:3]
        assert np.linalg.norm(drawn - want, axis=1).min() < 1e-12


def test_the_skin_follows_a_ball_joint_through_the_old_gimbal_lock(figure: KinematicModel):
    """A shoulder turned so that the upper arm points straight forward (where three axes
    x-z-y lock: their middle angle at 90 deg), then twisted about the bone and swung on: the
    skin of the arm follows the independent chain at every step."""
    doc = yaml.safe_load(figure.spec.file.read_text(encoding="utf-8"))
    geo = BoundGeometry(figure)
    bind = chain_poses(doc, by_name(figure, figure.named_pose("tpose")))
    arm_bones = {"left_upper_arm", "left_forearm", "left_hand"}
    sl = figure.q_index("left_shoulder")
    forward = Rotation.from_rotvec([0, 0, np.pi / 2])  # +y (the bone) onto +x (forward)
    for extra in (Rotation.identity(), Rotation.from_rotvec([0, 0.7, 0]),
                  Rotation.from_rotvec([0.3, 0, 0.2])):
        q = figure.named_pose("tpose")
        x, y, z, w = (forward * extra).as_quat()
        q[sl] = [w, x, y, z]
        q = figure.clip(q)
        poses = chain_poses(doc, by_name(figure, q))
        drawn = geo.world_vertices(q)
        skin = figure.spec.skin
        assert skin is not None
        want = np.array([(poses[b] @ np.linalg.inv(bind[b]) @ np.append(v, 1.0))[:3]
                         for v, b in zip(skin.vertices, skin.vertex_link, strict=True)
                         if b in arm_bones])
        d = np.linalg.norm(want[:, None] - drawn[None], axis=2).min(axis=1)
        assert d.max() < 1e-9
    # the shoulder's three tangent columns of the hand's Jacobian keep full rank there
    q = figure.named_pose("tpose")
    x, y, z, w = forward.as_quat()
    q[sl] = [w, x, y, z]
    jac = figure.jacobian(q, "left_palm")[3:, figure.v_index("left_shoulder")]
    np.testing.assert_allclose(np.linalg.svd(jac, compute_uv=False), [1, 1, 1], atol=1e-12)
