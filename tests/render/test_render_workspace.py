"""Workspace sampling and plots, and the shared plot helpers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from render_indep import IndependentArm

from armctl.arm import load_arm
from armctl.errors import InputError, UnknownNameError
from armctl.render.plots import (
    PALETTE,
    bar_chart,
    cdf_plot,
    check_output,
    new_figure,
    save_figure,
    style_axes,
)
from armctl.render.workspace import plot_workspace, sample_workspace, voxel_volume

DATA = Path(__file__).parent / "data"
PLANAR = Path(__file__).parent.parent / "data" / "planar3r.yaml"


def test_planar_workspace_is_the_annulus():
    arm = load_arm(PLANAR)
    ws = sample_workspace(arm, 4000, seed=3)
    # planar arm with links 0.3, 0.2, 0.1 m and joints limited to +-3 rad: every point is in the
    # plane z = 0 within 0.6 m of the base, and random samples come close to full reach
    assert np.allclose(ws.points[:, 2], 0.0)
    r = np.linalg.norm(ws.points, axis=1)
    assert r.max() <= 0.6 + 1e-12 and ws.max_reach == pytest.approx(r.max())
    assert ws.max_reach > 0.57
    assert ws.hull_volume is None  # a flat cloud has no volume
    assert np.all(ws.lower >= -0.6) and np.all(ws.upper <= 0.6)


def test_workspace_points_are_fk_of_seeded_samples():
    arm = load_arm(DATA / "shapes5.yaml")
    ind = IndependentArm(DATA / "shapes5.yaml")
    ws = sample_workspace(arm, 200, seed=11)
    qs = arm.sample(np.random.default_rng(11), 200)
    for q, p in zip(qs[:20], ws.points[:20], strict=True):
        np.testing.assert_allclose(p, ind.frame_pose("tcp", q)[:3, 3], atol=1e-12)
    assert ws.hull_volume is not None and ws.hull_volume > 0
    assert ws.voxel_volume == pytest.approx(voxel_volume(ws.points, ws.voxel))
    assert sample_workspace(arm, 200, seed=11).points.tobytes() == ws.points.tobytes()


def test_voxel_volume_of_a_ball():
    rng = np.random.default_rng(5)
    p = rng.uniform(-1.0, 1.0, (60000, 3))
    p = p[np.linalg.norm(p, axis=1) <= 1.0]
    assert voxel_volume(p, 0.15) == pytest.approx(4.0 / 3.0 * np.pi, rel=0.08)
    # a single occupied voxel is all surface: it counts half
    assert voxel_volume(np.array([[0.01, 0.01, 0.01], [0.02, 0.02, 0.02]]), 0.1) == \
        pytest.approx(0.5 * 0.1**3)


def test_workspace_plot(tmp_path):
    arm = load_arm(DATA / "shapes5.yaml")
    ws = sample_workspace(arm, 2000, frame="l3")
    plot = plot_workspace(ws, tmp_path / "ws.png", z_slice=0.1, slab=0.02, size=2.5)
    assert plot.z_slice == 0.1 and plot.slab == 0.02
    assert plot.y_slice == pytest.approx((ws.lower[1] + ws.upper[1]) / 2)
    img = np.asarray(Image.open(tmp_path / "ws.png").convert("RGB")).astype(int)
    blue = (img[..., 2] > 150) & (img[..., 0] < 60)  # slice points are drawn in palette blue
    assert blue.sum() > 20


def test_workspace_bad_input():
    arm = load_arm(PLANAR)
    with pytest.raises(UnknownNameError):
        sample_workspace(arm, 100, frame="nope")
    with pytest.raises(InputError, match="at least 10"):
        sample_workspace(arm, 2)
    with pytest.raises(InputError, match="voxel"):
        sample_workspace(arm, 100, voxel=-1.0)


def test_plot_helpers(tmp_path):
    fig, axes = new_figure(1, 2, size=(4.0, 2.0), dpi=50)
    bar_chart(axes[0], ["dls", "ccd", "jt"], [1.0, 2.0, 3.0], errors=[0.1, 0.2, 0.3])
    cdf_plot(axes[1], [3.0, 1.0, 2.0], "dls")
    style_axes(axes[1], "errors", "error [m]", "fraction", log_y=False, legend=True)
    line = axes[1].get_lines()[0]
    np.testing.assert_allclose(line.get_ydata(), [1 / 3, 2 / 3, 1.0])
    out = save_figure(fig, tmp_path / "p.png")
    img = Image.open(out)
    assert img.size == (200, 100)
    pixels = {tuple(p) for p in np.asarray(img.convert("RGB")).reshape(-1, 3)}
    first = tuple(int(PALETTE[0][i:i + 2], 16) for i in (1, 3, 5))
    assert first in pixels  # the first bar is in the first palette colour
    with pytest.raises(InputError, match="unknown file type"):
        check_output(tmp_path / "p.bmp")
