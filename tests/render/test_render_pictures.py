"""Pictures drawn headless: the drawn arm moves the way the pose says, errors are clear."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from armctl.arm import load_arm
from armctl.errors import InputError, UnknownNameError
from armctl.render.draw import Bounds, Camera, View, point_to_polyline
from armctl.render.errors import OutputError
from armctl.render.picture import Target, render_path, render_pose

PLANAR = Path(__file__).parent.parent / "data" / "planar3r.yaml"
FIXED = Bounds((0.0, 0.0, 0.0), 0.65)
TOP = Camera("top", 90.0, -90.0)
FRONT = Camera("front", 0.0, 0.0)


@pytest.fixture(scope="module")
def arm():
    return load_arm(PLANAR)


def rgb(path: Path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(int)


def orange_mask(img: np.ndarray) -> np.ndarray:
    """Pixels of the orange links (saturated, red > green > blue)."""
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (r - b > 80) & (r > g) & (g > b + 30)


def centroid(mask: np.ndarray) -> np.ndarray:
    ys, xs = np.nonzero(mask)
    assert len(xs) > 50, "nothing drawn"
    return np.array([xs.mean(), ys.mean()])  # image x to the right, image y downwards


def draw(arm, q, path, camera, **kw):
    return render_pose(arm, q, path, camera=camera, frames=("none",), bounds=FIXED, size=3.0,
                       dpi=60, title="", **kw)


def test_drawing_is_headless(arm, tmp_path):
    draw(arm, [0.0, 0.0, 0.0], tmp_path / "a.png", TOP)
    assert "matplotlib.pyplot" not in sys.modules
    img = Image.open(tmp_path / "a.png")
    assert img.size == (180, 180)


def test_silhouette_turns_with_the_base_joint(arm, tmp_path):
    # top view: x to the right, y up. The straight arm points along +x at q1 = 0 and along +y
    # at q1 = 90 deg, so its silhouette moves left and up in the picture.
    draw(arm, [0.0, 0.0, 0.0], tmp_path / "x.png", TOP)
    draw(arm, [np.pi / 2, 0.0, 0.0], tmp_path / "y.png", TOP)
    m0, m1 = orange_mask(rgb(tmp_path / "x.png")), orange_mask(rgb(tmp_path / "y.png"))
    c0, c1 = centroid(m0), centroid(m1)
    assert c1[0] < c0[0] - 15 and c1[1] < c0[1] - 15
    # the same amount of link is drawn (a rotation), within a tolerance for pixel rounding
    assert abs(int(m0.sum()) - int(m1.sum())) < 0.25 * m0.sum()
    # horizontal extent at q1 = 0 is much larger than vertical, and the other way round
    ys, xs = np.nonzero(m0)
    assert np.ptp(xs) > 3 * np.ptp(ys)
    ys, xs = np.nonzero(m1)
    assert np.ptp(ys) > 3 * np.ptp(xs)


def test_silhouette_in_front_view(arm, tmp_path):
    # seen from +x the y axis points right: turning the arm to -y moves it left
    draw(arm, [np.pi / 2, 0.0, 0.0], tmp_path / "p.png", FRONT)
    draw(arm, [-np.pi / 2, 0.0, 0.0], tmp_path / "n.png", FRONT)
    cp = centroid(orange_mask(rgb(tmp_path / "p.png")))
    cn = centroid(orange_mask(rgb(tmp_path / "n.png")))
    assert cn[0] < cp[0] - 30 and abs(cn[1] - cp[1]) < 5


def test_elbow_moves_only_the_outer_links(arm, tmp_path):
    draw(arm, [0.0, 0.0, 0.0], tmp_path / "a.png", TOP)
    draw(arm, [0.0, 1.2, 0.0], tmp_path / "b.png", TOP)
    a, b = orange_mask(rgb(tmp_path / "a.png")), orange_mask(rgb(tmp_path / "b.png"))
    h, w = a.shape
    # the first link (from the base at the picture's centre to x = 0.3) is unchanged
    inner = (slice(h // 2 - 8, h // 2 + 8), slice(w // 2 + 5, w // 2 + int(0.25 / 1.3 * w)))
    assert np.array_equal(a[inner], b[inner])
    assert centroid(b)[1] < centroid(a)[1] - 5  # the rest swung towards +y (up)


def test_target_is_drawn_where_it_is(arm, tmp_path):
    out = tmp_path / "t.png"
    pic = draw(arm, [0.0, 0.0, 0.0], out, TOP,
               target=Target.from_xyz_rpy([-0.4, 0.4, 0.0], [0.0, 0.0, 0.5]))
    img = rgb(out)
    magenta = (img[..., 0] > 150) & (img[..., 2] > 150) & (img[..., 1] < 90)
    c = centroid(magenta) if magenta.sum() > 50 else np.argwhere(magenta).mean(axis=0)[::-1]
    h, w = magenta.shape
    assert magenta.sum() > 5
    assert c[0] < w / 2 and c[1] < h / 2  # upper left: x < 0, y > 0
    assert pic.target_distance == pytest.approx(np.hypot(1.0, 0.4))
    assert pic.tool_position == pytest.approx((0.6, 0.0, 0.0))


def test_all_views_and_vector_output(arm, tmp_path):
    pic = render_pose(arm, [0.1, 0.2, 0.3], tmp_path / "all.svg", view=View.ALL, frames=("all",),
                      size=2.0)
    assert len(pic.cameras) == 4
    assert "<svg" in (tmp_path / "all.svg").read_text()[:2000]


def test_path_picture(arm, tmp_path):
    qs = np.linspace([0.0, 0.5, 0.5], [1.0, -0.5, 0.2], 9)
    ends = arm.fk_batch(qs[[0, -1]])[:, :3, 3]
    res = render_path(arm, qs, tmp_path / "path.png", line=ends, camera=TOP, ghosts=2)
    tool = arm.fk_batch(qs)[:, :3, 3]
    a, b = ends
    d = b - a
    s = np.clip((tool - a) @ d / (d @ d), 0, 1)
    want = np.linalg.norm(tool - (a + s[:, None] * d), axis=1).max()
    assert res.max_deviation == pytest.approx(want) and want > 0.01
    assert res.samples == 9
    assert orange_mask(rgb(tmp_path / "path.png")).sum() > 50
    assert point_to_polyline([[0.0, 1.0, 0.0]], [[0, 0, 0], [1, 0, 0], [1, 1, 0]])[0] == 1.0


def test_bad_input(arm, tmp_path):
    with pytest.raises(InputError, match="3 values"):
        render_pose(arm, [0.0, 0.0], tmp_path / "a.png")
    with pytest.raises(UnknownNameError, match="'tip'"):
        render_pose(arm, [0.0, 0.0, 0.0], tmp_path / "a.png", frames=("tipp",))
    with pytest.raises(OutputError, match="does not exist"):
        render_pose(arm, [0.0, 0.0, 0.0], tmp_path / "missing" / "a.png")
    (tmp_path / "file").write_text("x")
    with pytest.raises(OutputError, match="is a file, not a folder"):
        render_pose(arm, [0.0, 0.0, 0.0], tmp_path / "file" / "a.png")
    with pytest.raises(OutputError, match="unknown file type"):
        render_pose(arm, [0.0, 0.0, 0.0], tmp_path / "a.txt")
    with pytest.raises(OutputError, match="folder"):
        render_pose(arm, [0.0, 0.0, 0.0], tmp_path)
    with pytest.raises(InputError, match="NaN"):
        render_pose(arm, [0.0, np.nan, 0.0], tmp_path / "a.png")
    assert not (tmp_path / "a.png").exists()
