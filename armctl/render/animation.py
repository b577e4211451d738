"""Playback animations: a joint-space motion drawn frame by frame into a GIF (or an MP4).

GIFs are assembled with Pillow. MP4 needs the ``ffmpeg`` program on the PATH; without it a
:class:`~armctl.render.errors.MissingToolError` says so before anything is drawn.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.kinematics.model import KinematicModel
from armctl.render.binding import BoundGeometry
from armctl.render.draw import (
    ArmArtist,
    Bounds,
    Camera,
    FrameTriad,
    View,
    cameras_for,
    draw_target,
    fit_labels,
    setup_axes,
)
from armctl.render.errors import MissingToolError, OutputError
from armctl.render.picture import Target, panel_figure, resolve_frames, triad_length
from armctl.render.plots import check_output
from armctl.render.scene import CONTACT_COLOR, SceneArtist, obstacle_meshes
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.collision.contact import Clearance
    from armctl.collision.model import CollisionModel

__all__ = ["ANIMATION_SUFFIXES", "Animation", "render_animation", "resample"]


#: File types that :func:`render_animation` writes.
ANIMATION_SUFFIXES = (".gif", ".mp4")


@dataclass(frozen=True)
class Animation:
    """What :func:`render_animation` wrote.

    Attributes:
        path: The file.
        frames: Number of frames.
        fps: Frames per second actually used.
        duration: Duration of the motion [s].
        contact_frames: With a scene: how many frames show a pair in contact (drawn red).
        first_contact: With a scene: the pair in contact in the first such frame, else
            ``None``.
        first_contact_time: When that frame is, from the start of the motion [s].
    """

    path: Path
    frames: int
    fps: float
    duration: float
    contact_frames: int = 0
    first_contact: Clearance | None = None
    first_contact_time: float | None = None


def resample(qs: npt.ArrayLike, times: npt.ArrayLike, fps: float,
             arm: KinematicModel | None = None) -> tuple[Array, Array]:
    """Joint values at evenly spaced frame times, linearly interpolated between samples.

    Args:
        qs: Joint values ``(N, nq)``.
        times: Sample times ``(N,)`` [s], strictly increasing.
        fps: Frames per second.
        arm: The arm, when it has ball joints: their quaternions are interpolated on the
            sphere (slerp, :meth:`KinematicModel.interpolate`), not entry by entry.

    Returns:
        Frame times ``(F,)`` [s] (first and last sample included) and joint values ``(F, dof)``.

    Raises:
        InputError: For mismatched shapes, non-increasing or non-finite times.
    """
    q = np.asarray(qs, dtype=float)
    t = np.asarray(times, dtype=float)
    if q.ndim != 2 or t.shape != (len(q),) or len(q) == 0:
        raise InputError(f"animation: need qs of shape (N, dof) and times of shape (N,); got "
                         f"{q.shape} and {t.shape}")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
        raise InputError("animation: times and joint values must be finite numbers")
    if len(t) > 1 and np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise InputError(f"animation: times must increase strictly; sample {k + 1} at "
                         f"{t[k + 1]:.6g} s follows {t[k]:.6g} s")
    if not fps > 0:
        raise InputError(f"animation: fps must be positive, got {fps}")
    n = int(np.floor((t[-1] - t[0]) * fps + 1e-9)) + 1
    ft = t[0] + np.arange(n) / fps
    if ft[-1] < t[-1] - 1e-9:
        ft = np.append(ft, t[-1])
    fq = np.column_stack([np.interp(ft, t, q[:, j]) for j in range(q.shape[1])])
    if arm is not None and arm.multi_dof_joints and len(t) > 1:
        k = np.clip(np.searchsorted(t, ft, side="right") - 1, 0, len(t) - 2)
        frac = np.clip((ft - t[k]) / (t[k + 1] - t[k]), 0.0, 1.0)
        fq = np.array([arm.interpolate(q[i], q[i + 1], float(f))
                       for i, f in zip(k.tolist(), frac.tolist(), strict=True)])
    return ft, fq


class _Mp4Writer:
    def __init__(self, path: Path, fps: float):
        self.path = path
        self.fps = fps
        self.proc: subprocess.Popen[bytes] | None = None

    def add(self, frame: npt.NDArray[np.uint8]) -> None:
        if self.proc is None:
            h, w = frame.shape[:2]
            cmd = ["ffmpeg", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgb24",
                   "-s", f"{w}x{h}", "-r", f"{self.fps:.6g}", "-i", "-", "-vf",
                   "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p", str(self.path)]
            self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stderr=subprocess.PIPE)
        assert self.proc.stdin is not None
        try:
            self.proc.stdin.write(np.ascontiguousarray(frame).tobytes())
        except OSError:  # ffmpeg stopped reading (it failed): report its own message
            self.close()
            raise OutputError(self.path, "ffmpeg stopped early",
                              "check the output location, or write a .gif instead") from None

    def close(self) -> None:
        if self.proc is None:
            return
        proc, self.proc = self.proc, None
        try:
            _, err = proc.communicate()
        except OSError:  # the pipe is already broken: collect what ffmpeg said
            proc.wait()
            err = proc.stderr.read() if proc.stderr is not None else b""
        if proc.returncode != 0:
            raise OutputError(self.path, f"ffmpeg failed: {err.decode(errors='replace').strip()}",
                              "check the output location, or write a .gif instead")


def render_animation(arm: KinematicModel, qs: npt.ArrayLike, times: npt.ArrayLike,
                     out_path: str | Path, *, fps: float = 20.0, view: View = View.ISO,
                     camera: Camera | None = None, frames: Sequence[str] = ("tool",),
                     target: Target | None = None, bounds: Bounds | None = None,
                     geometry: BoundGeometry | None = None, trail: bool = True,
                     max_frames: int = 600, size: float = 4.5, dpi: float = 80,
                     title: str | None = None, line: npt.ArrayLike | None = None,
                     scene: CollisionModel | None = None) -> Animation:
    """Draw a joint-space motion as an animation (GIF, or MP4 when ffmpeg is installed).

    The motion is resampled at ``fps`` by linear interpolation between the given samples (pass
    densely sampled trajectories for smooth playback). When the motion would need more than
    ``max_frames`` frames, the frame rate is lowered to fit.

    Args:
        arm: The arm.
        qs: Joint values ``(N, dof)`` [rad] / [m].
        times: Their times ``(N,)`` [s], strictly increasing.
        out_path: ``.gif`` or ``.mp4`` file.
        fps: Frames per second.
        view: Named view(s); ignored when ``camera`` is given.
        camera: A chosen camera.
        frames: Frames drawn as triads (``tool``, ``all``, ``none`` or names).
        target: A goal to show.
        bounds: The cube shown; fitted around the whole motion when ``None``.
        geometry: Pre-built bound geometry.
        trail: Draw the path the tool frame has travelled.
        max_frames: Most frames to draw.
        size: Size of one panel [in].
        dpi: Resolution.
        title: Title; the arm name when ``None``.
        line: A planned Cartesian path ``(k, 3)`` [m] drawn dashed (e.g. a straight line's ends).
        scene: A collision model whose scene is drawn (the table, the obstacles); in every
            frame where a pair is in contact both members are drawn red. ``None``: the arm
            alone.

    Returns:
        What was written.

    Raises:
        InputError: Bad shapes or times, unknown frames.
        OutputError: Unwritable output or unknown file type.
        MissingToolError: MP4 asked for but ffmpeg is not installed.
    """
    out = check_output(out_path, ANIMATION_SUFFIXES)
    mp4 = out.suffix.lower() == ".mp4"
    if mp4 and shutil.which("ffmpeg") is None:
        raise MissingToolError(f"cannot write {out}: MP4 output needs the ffmpeg program, which "
                               "is not installed\n  fix: install ffmpeg (e.g. apt-get install "
                               "ffmpeg) or write a .gif")
    q_in = arm.as_batch(qs)
    t_in = np.asarray(times, dtype=float)
    duration = float(t_in[-1] - t_in[0]) if t_in.size else 0.0
    if max_frames < 2:
        raise InputError(f"animation: max_frames must be at least 2, got {max_frames}")
    if duration * fps + 1 > max_frames:
        fps = (max_frames - 1) / duration
    ft, fq = resample(q_in, t_in, fps, arm)
    names = resolve_frames(arm, frames)
    geo = geometry or BoundGeometry(arm)
    all_poses = [arm.fk_frames(qf) for qf in fq]
    if bounds is None:
        step = max(len(all_poses) // 40, 1)
        pts = [geo.pose_vertices(p) for p in [*all_poses[::step], all_poses[-1]]]
        if target is not None:
            pts.append(target.pose[:3, 3][None])
        if line is not None:
            pts.append(np.asarray(line, dtype=float).reshape(-1, 3))
        if scene is not None:
            pts += [ob.mesh.vertices for ob in obstacle_meshes(scene.scene, arm.spec.file)]
            if scene.scene.table is not None:  # the table top under the base
                pts.append(np.array([[0.0, 0.0, scene.scene.table.height]]))
        bounds = Bounds.around(np.vstack(pts))
    cams = [camera] if camera is not None else cameras_for(view)
    fig, axes = panel_figure(cams, size)
    fig.set_dpi(dpi)
    length = triad_length(bounds)
    tool = arm.frame_index(None)
    tool_path = np.array([p[tool, :3, 3] for p in all_poses])
    artists = []
    scenes: list[SceneArtist] = []
    for ax, cam in zip(axes, cams, strict=False):
        setup_axes(ax, bounds, cam, title=len(cams) > 1)
        if scene is not None:
            scenes.append(SceneArtist(ax, obstacle_meshes(scene.scene, arm.spec.file),
                                      None if scene.scene.table is None
                                      else scene.scene.table.height, bounds))
        triads = [(arm.frame_index(n), FrameTriad(ax, length)) for n in names]
        trail_line = (ax.plot([], [], [], color="#0072B2", linewidth=1.0, zorder=9)[0]
                      if trail else None)
        if target is not None:
            draw_target(ax, target.pose, length, target.oriented)
        if line is not None:
            lp = np.asarray(line, dtype=float).reshape(-1, 3)
            ax.plot(lp[:, 0], lp[:, 1], lp[:, 2], color="black", linestyle="--", linewidth=1.0,
                    zorder=8)
        artists.append((ArmArtist(ax, geo), triads, trail_line))
    label = fig.suptitle(" ", fontsize=9)  # its room is kept by the layout below
    fit_labels(fig, axes)
    head = title if title is not None else arm.name
    canvas = fig.canvas
    images: list[Any] = []  # GIF frames, reduced to a palette at once to keep memory small
    writer = _Mp4Writer(out, fps) if mp4 else None
    contacts = 0
    first: tuple[Clearance, float] | None = None
    for k, poses in enumerate(all_poses):
        hot: frozenset[str] = frozenset()
        if scene is not None:
            from armctl.collision.single import clearance_once

            c = clearance_once(scene, fq[k])
            if c is not None and c.margin < 0.0:
                hot = frozenset((c.a, c.b))
                contacts += 1
                first = first or (c, float(ft[k] - ft[0]))
            for scene_artist in scenes:
                scene_artist.set_contact(hot)
        for i, (arm_artist, triads, trail_line) in enumerate(artists):
            if scene is not None:
                arm_artist.set_highlight({name: CONTACT_COLOR for name in hot})
            arm_points = arm_artist.set_pose(poses)
            if scenes:
                scenes[i].order(scenes[i].axes, arm_points)
            for idx, triad in triads:
                triad.set_pose(poses[idx])
            if trail_line is not None:
                seg = tool_path[: k + 1]
                trail_line.set_data_3d(seg[:, 0], seg[:, 1], seg[:, 2])
        label.set_text(f"{head}   t = {ft[k] - ft[0]:.2f} s")
        canvas.draw()
        frame = np.asarray(canvas.buffer_rgba())[..., :3].copy()  # type: ignore[attr-defined]
        if writer is not None:
            writer.add(frame)
        else:
            images.append(_palette_image(frame))
    if writer is not None:
        writer.close()
    else:
        _write_gif(out, images, fps)
    return Animation(out, len(all_poses), float(fps), duration, contacts,
                     None if first is None else first[0], None if first is None else first[1])


def _palette_image(frame: npt.NDArray[np.uint8]) -> Any:
    from PIL import Image

    return Image.fromarray(frame).quantize(colors=128, method=Image.Quantize.MEDIANCUT)


def _write_gif(path: Path, images: list[Any], fps: float) -> None:
    try:
        images[0].save(path, save_all=True, append_images=images[1:], loop=0,
                       duration=max(round(1000.0 / fps), 20), optimize=False)
    except OSError as exc:
        raise OutputError(path, str(exc), "choose a writable location") from exc
