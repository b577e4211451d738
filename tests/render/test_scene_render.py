"""Pictures of the scene: obstacles where the scene puts them, the pair in contact in red.

Drawn headless. The obstacle meshes are checked against corners and centres computed by hand;
whether a pose is in contact against a brute-force distance of the link's capsules (points
along their axes) from the box, independent of the collision kernels.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.colors import to_rgb
from PIL import Image

from armctl.arm import load_arm
from armctl.cli import main
from armctl.config.geometry import Origin
from armctl.config.scene import Obstacle, SceneFrame, SceneSpec
from armctl.config.schema import Box, Sphere
from armctl.kinematics.capsules import collision_capsules
from armctl.render.binding import BoundGeometry
from armctl.render.draw import ArmArtist, Bounds, Camera
from armctl.render.picture import render_pose
from armctl.render.plots import new_figure
from armctl.render.scene import (
    CONTACT_COLOR,
    OBSTACLE_COLOR,
    draw_scene,
    obstacle_meshes,
    scene_drawing,
)

TOP = Camera("top", 90.0, -90.0)
POST_CENTRE = np.array([0.342, -0.187, 0.15])
POST_SIZE = np.array([0.04, 0.04, 0.3])
POST = SceneSpec(obstacles=(Obstacle("post", Box(tuple(POST_SIZE),  # type: ignore[arg-type]
                                                 Origin(tuple(POST_CENTRE)))),))  # type: ignore[arg-type]
INTO_POST = [0.5, 0.0, 0.0, 0.0, 0.0, 0.0]  # the gripper turned into the post
AWAY = [-0.5, 0.0, 0.0, 0.0, 0.0, 0.0]  # turned the other way


@pytest.fixture(scope="module")
def so101():
    return load_arm("so101")


def box_distance(arm, q, link) -> float:
    """Signed distance of a link's capsules from the post (brute force) [m]."""
    pose = arm.fk(np.asarray(q, dtype=float), link)
    best = math.inf
    for cap in collision_capsules(arm.spec)[link]:
        s = np.linspace(0.0, 1.0, 400)[:, None]
        p = (np.asarray(cap.a) + s * (np.asarray(cap.b) - np.asarray(cap.a))) @ pose[:3, :3].T
        p += pose[:3, 3]
        d = np.abs(p - POST_CENTRE) - POST_SIZE / 2.0
        sd = np.linalg.norm(np.maximum(d, 0.0), axis=1) + np.minimum(d.max(axis=1), 0.0)
        best = min(best, float(sd.min()) - cap.radius)
    return best


def red_mask(path: Path) -> np.ndarray:
    img = np.asarray(Image.open(path).convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r > 140) & (g < 90) & (b < 90) & (r - g > 80)


# ---- meshes -------------------------------------------------------------------------------
def test_obstacle_meshes_are_placed_in_the_base_frame() -> None:
    yaw = 0.3
    box = Obstacle("crate", Box((0.2, 0.1, 0.05), Origin((0.4, 0.1, 0.2), (0.0, 0.0, yaw))))
    ball = Obstacle("ball", Sphere(0.05, Origin((1.0, 2.0, 0.5))), SceneFrame.WORLD)
    scene = SceneSpec(obstacles=(box, ball), base_in_world=Origin((0.5, 2.0, 0.0)))
    crate, sphere = obstacle_meshes(scene)
    assert (crate.name, sphere.name) == ("crate", "ball")
    # the crate's corners, rotated about z by hand
    c, s = math.cos(yaw), math.sin(yaw)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    corners = np.array([[x, y, z] for x in (-0.1, 0.1) for y in (-0.05, 0.05)
                        for z in (-0.025, 0.025)]) @ rz.T + [0.4, 0.1, 0.2]
    got = crate.mesh.vertices
    for corner in corners:
        assert np.min(np.linalg.norm(got - corner, axis=1)) < 1e-12
    assert len(got) == 8
    # the ball: world (1, 2, 0.5) with the base at world (0.5, 2, 0) is base (0.5, 0, 0.5)
    r = np.linalg.norm(sphere.mesh.vertices - [0.5, 0.0, 0.5], axis=1)
    assert np.allclose(r, 0.05)
    assert sphere.mesh.volume() == pytest.approx(4 / 3 * math.pi * 0.05**3, rel=0.05)


def test_the_drawing_names_the_pair_in_contact(so101) -> None:
    hit = scene_drawing(so101, INTO_POST, POST)
    assert hit.in_contact
    link, other = hit.clearance.a, hit.clearance.b
    assert other == "post" and hit.highlighted == {link, "post"}
    assert hit.clearance.distance == pytest.approx(box_distance(so101, INTO_POST, link),
                                                   abs=2e-4)
    assert box_distance(so101, INTO_POST, link) < 0.0
    free = scene_drawing(so101, AWAY, POST)
    assert not free.in_contact and free.highlighted == frozenset()
    assert free.clearance.margin > 0.0
    assert [o.name for o in free.obstacles] == ["post"] and free.table_height == 0.0
    none = scene_drawing(so101, AWAY, SceneSpec(table=None))
    assert none.table_height is None and none.obstacles == ()


# ---- colours --------------------------------------------------------------------------------
def _face_rgb(collection) -> np.ndarray:
    return np.asarray(collection.get_facecolor())[:, :3]


def test_the_pair_in_contact_is_coloured(so101) -> None:
    bounds = Bounds((0.2, 0.0, 0.15), 0.3)
    for q, red in ((INTO_POST, True), (AWAY, False)):
        drawing = scene_drawing(so101, q, POST)
        _, (ax,) = new_figure(projection="3d")
        artists = draw_scene(ax, drawing, bounds)
        assert set(artists) == {"table", "post"}
        post = _face_rgb(artists["post"])
        want = np.array(to_rgb(CONTACT_COLOR if red else OBSTACLE_COLOR))
        # shaded: each face is the colour scaled by its light, so the hue is the colour's
        scale = post @ want / (want @ want)
        assert np.allclose(post, scale[:, None] * want, atol=1e-6)
        assert np.asarray(artists["table"].get_facecolor())[:, 3].max() < 0.5  # translucent
        # the arm: every face of the link in contact red, no other (matplotlib may keep the
        # faces in its own order, so they are counted)
        geo = BoundGeometry(so101)
        link = drawing.clearance.a
        hot = {n: CONTACT_COLOR for n in drawing.highlighted}
        artist = ArmArtist(ax, geo, highlight=hot)
        artist.set_pose(so101.fk_frames(np.asarray(q)))
        faces = _face_rgb(artist.collection)
        red_hue = (faces[:, 0] > 3 * faces[:, 1]) & (faces[:, 0] > 3 * faces[:, 2])
        mine = int((geo.face_link == geo.links.index(link)).sum())
        assert mine > 0
        assert int(red_hue.sum()) == (mine if red else 0)


def test_a_picture_of_a_contact_shows_red_where_the_post_is(so101, tmp_path: Path) -> None:
    bounds = Bounds((0.2, 0.0, 0.15), 0.3)
    hit, free = tmp_path / "hit.png", tmp_path / "free.png"
    pic = render_pose(so101, INTO_POST, hit, camera=TOP, frames=("none",), bounds=bounds,
                      size=3.0, dpi=80, title="", scene=scene_drawing(so101, INTO_POST, POST))
    render_pose(so101, AWAY, free, camera=TOP, frames=("none",), bounds=bounds, size=3.0,
                dpi=80, title="", scene=scene_drawing(so101, AWAY, POST))
    assert pic.clearance is not None and pic.clearance.b == "post"
    hot, cold = red_mask(hit), red_mask(free)
    assert hot.sum() > 100 and cold.sum() == 0
    # seen from the top (x right, y up) the post at x 0.34, y -0.19 is right of and below the
    # centre (x 0.2, y 0): the red drawn there
    ys, xs = np.nonzero(hot)
    h, w = hot.shape
    assert xs.mean() > w / 2 and ys.mean() > h / 2


def test_without_a_scene_the_arm_is_drawn_alone(so101, tmp_path: Path) -> None:
    pic = render_pose(so101, INTO_POST, tmp_path / "a.png", camera=TOP, frames=("none",),
                      size=2.0, dpi=60)
    assert pic.clearance is None
    assert red_mask(tmp_path / "a.png").sum() == 0


def test_render_command_draws_the_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                        ) -> None:
    scene = tmp_path / "post.yaml"
    scene.write_text("obstacles:\n  - {name: post, shape: box, size: [0.04, 0.04, 0.3], "
                     "origin: {xyz: [0.342, -0.187, 0.15]}}\n")
    q = [str(v) for v in INTO_POST]
    out = tmp_path / "r.png"
    assert main(["render", "so101", *q, "-o", str(out), "--scene", str(scene), "--json",
                 "--size", "2", "--dpi", "50"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["scene"]["obstacles"] == ["post"] and data["scene"]["table"] is True
    assert data["clearance"]["pair"][1] == "post" and data["clearance"]["in_contact"] is True
    assert main(["render", "so101", *q, "-o", str(out), "--scene", str(scene)]) == 0
    text = capsys.readouterr().out
    assert "IN CONTACT" in text and "(drawn red)" in text
    assert main(["render", "so101", *q, "-o", str(out), "--no-scene", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["scene"] is None and data["clearance"] is None
    assert main(["render", "so101", "-o", str(out), "--scene", str(scene), "--no-scene"]) == 2


def test_the_scene_module_imports_no_matplotlib() -> None:
    code = ("import sys\nimport armctl.render.scene\n"
            "print('matplotlib' in sys.modules, 'numba' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60, check=True).stdout
    assert out.strip() == "False False"


KEYFRAMES_INTO_POST = """\
armctl_keyframes: 1
arm: so101
units: {angle: rad, length: m}
joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]
keyframes:
- {q: [0.5, 0, 0, 0, 0]}
"""


def test_an_animation_colours_the_frames_in_contact(so101, tmp_path: Path) -> None:
    from armctl.collision import CollisionModel
    from armctl.render.animation import render_animation

    qs = np.zeros((11, so101.dof))
    qs[:, 0] = np.linspace(-0.5, 0.5, 11)  # from away from the post into it
    ts = np.linspace(0.0, 1.0, 11)
    res = render_animation(so101, qs, ts, tmp_path / "a.gif", fps=10.0, camera=TOP,
                           frames=("none",), size=2.0, dpi=50,
                           scene=CollisionModel.of(so101, POST))
    assert res.frames == 11
    # the frames in contact by brute force: some link closer to the post than the padding
    links = [n for n in collision_capsules(so101.spec) if n != so101.spec.base]
    touching = [min(box_distance(so101, q, n) for n in links) < POST.padding for q in qs]
    assert res.contact_frames == sum(touching) > 0
    first = touching.index(True)
    assert res.first_contact.b == "post"
    assert res.first_contact_time == pytest.approx(ts[first])
    # the last frame of the GIF shows red, the first none
    with Image.open(tmp_path / "a.gif") as gif:
        gif.seek(0)
        start = np.asarray(gif.convert("RGB")).astype(int)
        gif.seek(gif.n_frames - 1)
        end = np.asarray(gif.convert("RGB")).astype(int)

    def red(img: np.ndarray) -> int:
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        return int(((r > 140) & (g < 90) & (b < 90) & (r - g > 80)).sum())

    assert red(start) == 0 and red(end) > 20


def test_render_command_reports_contacts_of_a_playback(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    scene = tmp_path / "post.yaml"
    scene.write_text("obstacles:\n  - {name: post, shape: box, size: [0.04, 0.04, 0.3], "
                     "origin: {xyz: [0.342, -0.187, 0.15]}}\n")
    kf = tmp_path / "kf.yaml"
    kf.write_text(KEYFRAMES_INTO_POST)
    start = ["-0.5", "0", "0", "0", "0", "0"]
    args = ["render", "so101", *start, "--keyframes", str(kf), "-o", str(tmp_path / "k.gif"),
            "--fps", "5", "--size", "2", "--dpi", "40", "--json"]
    assert main([*args, "--scene", str(scene)]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["contact_frames"] > 0 and data["first_contact"]["pair"][1] == "post"
    assert 0.0 < data["first_contact"]["time"] <= data["duration"]
    assert main(args) == 0  # the config's scene: only the table, which the move stays above
    data = json.loads(capsys.readouterr().out)
    assert data["contact_frames"] == 0 and data["first_contact"] is None


def test_render_command_reports_the_first_path_sample_in_contact(
        so101, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scene = tmp_path / "post.yaml"
    scene.write_text("obstacles:\n  - {name: post, shape: box, size: [0.04, 0.04, 0.3], "
                     "origin: {xyz: [0.342, -0.187, 0.15]}}\n")
    # a straight line from the rest pose to where the shoulder turned by 1 rad puts the tool
    # (a chord of the arc the tool turns on) grazes the post half way
    args = ["render", "so101", "0", "0", "0", "0", "0", "0", "--path", "--target-xyz",
            "0.2293", "-0.2967", "0.2265", "-o", str(tmp_path / "p.png"), "--size", "2",
            "--json", "--scene", str(scene)]
    assert main(args) == 0
    data = json.loads(capsys.readouterr().out)
    first = data["first_contact"]
    assert first is not None and first["pair"][1] == "post" and first["in_contact"]
    assert 0 < first["sample"] < data["samples"] - 1
    assert data["clearance"]["in_contact"] is False  # the goal itself is clear of the post
    assert main([*args[:-2], "--no-scene"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["first_contact"] is None and data["clearance"] is None


def test_an_obstacle_nearer_the_camera_than_the_arm_is_drawn_over_it(so101) -> None:
    """Collections are drawn whole in a fixed order: an obstacle between the camera and the
    arm is drawn after the arm (over it, translucent), one behind the arm before it."""
    from armctl.render.draw import setup_axes

    q = so101.named_pose("home") if "home" in so101.spec.poses else so101.middle()
    geo = BoundGeometry(so101)
    arm_points = geo.pose_vertices(so101.fk_frames(q))
    centre = arm_points.mean(axis=0)
    for azim in (0.0, 90.0, -135.0):
        toward = np.array([np.cos(np.radians(azim)), np.sin(np.radians(azim)), 0.0])
        obstacles = tuple(
            Obstacle(name, Sphere(0.02, Origin(tuple(centre + 0.5 * sign * toward))))  # type: ignore[arg-type]
            for name, sign in (("front", 1.0), ("back", -1.0)))
        scene = SceneSpec(table=None, obstacles=obstacles)
        _, (ax,) = new_figure(projection="3d")
        bounds = Bounds(tuple(centre), 0.8)
        setup_axes(ax, bounds, Camera("test", 0.0, azim))
        artist = ArmArtist(ax, geo)
        artists = draw_scene(ax, scene_drawing(so101, q, scene), bounds,
                             artist.set_pose(so101.fk_frames(q)))
        arm_z = artist.collection.get_zorder()
        assert artists["front"].get_zorder() > arm_z > artists["back"].get_zorder(), azim
