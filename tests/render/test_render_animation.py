"""Playback animations: frames follow the motion, resampling is exact, errors are clear."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence

from armctl.arm import load_arm
from armctl.errors import InputError
from armctl.render import animation as anim
from armctl.render.animation import render_animation, resample
from armctl.render.draw import Bounds, Camera
from armctl.render.errors import MissingToolError, OutputError

PLANAR = Path(__file__).parent.parent / "data" / "planar3r.yaml"
TOP = Camera("top", 90.0, -90.0)


@pytest.fixture(scope="module")
def arm():
    return load_arm(PLANAR)


def orange_centroid(frame: Image.Image) -> np.ndarray:
    img = np.asarray(frame.convert("RGB")).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    ys, xs = np.nonzero((r - b > 80) & (r > g) & (g > b + 30))
    assert len(xs) > 30
    return np.array([xs.mean(), ys.mean()])


def test_resample_is_linear_between_samples():
    qs = np.array([[0.0, 1.0], [1.0, 3.0], [4.0, 3.0]])
    t = np.array([0.0, 1.0, 2.5])
    ft, fq = resample(qs, t, 4.0)
    assert ft[0] == 0.0 and ft[-1] == 2.5
    np.testing.assert_allclose(np.diff(ft[:-1]), 0.25)
    k = int(np.flatnonzero(np.isclose(ft, 0.5))[0])
    np.testing.assert_allclose(fq[k], [0.5, 2.0])
    k = int(np.flatnonzero(np.isclose(ft, 2.0))[0])
    np.testing.assert_allclose(fq[k], [1.0 + 3.0 * (1.0 / 1.5), 3.0])


def test_resample_rejects_bad_times():
    with pytest.raises(InputError, match="increase strictly"):
        resample(np.zeros((3, 2)), [0.0, 1.0, 1.0], 10)
    with pytest.raises(InputError, match="shape"):
        resample(np.zeros((3, 2)), [0.0, 1.0], 10)
    with pytest.raises(InputError, match="finite"):
        resample(np.zeros((2, 2)), [0.0, np.inf], 10)


def test_gif_frames_follow_the_motion(arm, tmp_path):
    out = tmp_path / "play.gif"
    qs = np.array([[0.0, 0.0, 0.0], [np.pi / 2, 0.0, 0.0]])
    res = render_animation(arm, qs, [0.0, 1.0], out, fps=5, camera=TOP, frames=("none",),
                           bounds=Bounds((0.0, 0.0, 0.0), 0.65), size=2.5, dpi=60, trail=False)
    assert res.frames == 6 and res.duration == 1.0
    gif = Image.open(out)
    frames = [f.copy() for f in ImageSequence.Iterator(gif)]
    assert len(frames) == 6
    cs = np.array([orange_centroid(f) for f in frames])
    # the arm sweeps from +x (right) to +y (up): image x falls, image y falls, frame by frame
    assert cs[-1, 0] < cs[0, 0] - 10 and cs[-1, 1] < cs[0, 1] - 10
    assert np.all(np.diff(cs[:, 1]) < 0)
    assert gif.info["duration"] == 200


def test_frame_rate_is_lowered_to_fit_max_frames(arm, tmp_path):
    res = render_animation(arm, [[0, 0, 0], [1, 1, 1]], [0.0, 10.0], tmp_path / "a.gif",
                           fps=30, max_frames=6, size=2.0, dpi=40)
    assert res.frames == 6 and res.fps == pytest.approx(0.5)


def test_mp4_without_ffmpeg_is_a_clear_error(arm, tmp_path, monkeypatch):
    monkeypatch.setattr(anim.shutil, "which", lambda name: None)
    with pytest.raises(MissingToolError, match="ffmpeg"):
        render_animation(arm, [[0, 0, 0], [1, 1, 1]], [0, 1], tmp_path / "a.mp4")
    assert not (tmp_path / "a.mp4").exists()


def test_animation_bad_input(arm, tmp_path):
    with pytest.raises(OutputError, match="unknown file type"):
        render_animation(arm, [[0, 0, 0], [1, 1, 1]], [0, 1], tmp_path / "a.png")
    with pytest.raises(InputError, match=r"\(N, 3\)"):
        render_animation(arm, [[0, 0], [1, 1]], [0, 1], tmp_path / "a.gif")
    with pytest.raises(InputError, match="increase strictly"):
        render_animation(arm, [[0, 0, 0], [1, 1, 1]], [1, 0], tmp_path / "a.gif")


def test_mp4_writer_reports_ffmpeg_failure(arm, tmp_path, monkeypatch):
    # a stand-in ffmpeg that fails at once, as a real one does when it cannot open its output
    fake = tmp_path / "bin" / "ffmpeg"
    fake.parent.mkdir()
    fake.write_text("#!/bin/sh\necho 'Error opening output file' >&2\nexit 1\n")
    fake.chmod(0o755)
    monkeypatch.setenv("PATH", f"{fake.parent}{os.pathsep}{os.environ.get('PATH', '')}")
    with pytest.raises(OutputError, match="ffmpeg failed: Error opening output file"):
        render_animation(arm, [[0, 0, 0], [1, 1, 1]], [0, 1], tmp_path / "a.mp4", fps=4,
                         size=2.0, dpi=40)


def test_an_arm_with_ball_joints_is_resampled_on_the_sphere(tmp_path: Path) -> None:
    """Frames between two samples turn a ball joint along the great circle (scipy's Slerp at
    the frame's time), unit quaternions throughout; the animation is written."""
    from scipy.spatial.transform import Rotation, Slerp

    import armctl

    fig = armctl.load_arm("figure")
    a, b = fig.named_pose("stand"), fig.named_pose("tpose")
    b[fig.q_index("right_hip")] = np.roll(Rotation.from_rotvec([0.2, -0.5, 0.1]).as_quat(), 1)
    qs, ts = np.array([a, b]), np.array([0.0, 1.0])
    ft, fq = resample(qs, ts, 4.0, fig)
    assert np.allclose(ft, [0.0, 0.25, 0.5, 0.75, 1.0])
    for name in fig.multi_dof_joints:
        sl = fig.q_index(name)
        ends = Rotation.from_quat(np.roll(qs[:, sl], -1, axis=1))
        want = Slerp([0.0, 1.0], ends)(ft).as_quat()
        got = np.roll(fq[:, sl], -1, axis=1)
        assert np.allclose(np.linalg.norm(got, axis=1), 1.0, atol=1e-15)
        dots = np.abs(np.sum(want * got, axis=1))  # q and -q are one rotation
        assert np.allclose(dots, 1.0, atol=1e-12), name
    out = render_animation(fig, qs, ts, tmp_path / "turn.gif", fps=4.0, size=2.0, dpi=30)
    assert out.frames == 5 and out.path.stat().st_size > 0
