"""Still pictures: an arm in one pose, or a planned path with its IK samples, written to a file."""

from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from armctl.kinematics.model import KinematicModel
from armctl.render.binding import BoundGeometry
from armctl.render.draw import (
    ArmArtist,
    Bounds,
    Camera,
    FrameTriad,
    View,
    cameras_for,
    draw_path,
    draw_target,
    fit_labels,
    point_to_polyline,
    setup_axes,
)
from armctl.render.plots import check_output, new_figure, save_figure
from armctl.render.scene import CONTACT_COLOR, SceneDrawing, draw_scene
from armctl.spatial import make_transform, rpy_to_matrix
from armctl.typing import Array

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d import Axes3D

    from armctl.collision.contact import Clearance

__all__ = [
    "PathPicture",
    "PosePicture",
    "Target",
    "panel_figure",
    "pose_title",
    "render_path",
    "render_pose",
    "resolve_frames",
    "triad_length",
]


@dataclass(frozen=True, eq=False)
class Target:
    """A goal to show in a picture.

    Attributes:
        pose: ``(4, 4)`` goal pose in the base frame [m].
        oriented: Whether the orientation is part of the goal (drawn as a dashed triad).
    """

    pose: Array
    oriented: bool

    @staticmethod
    def from_xyz_rpy(xyz: npt.ArrayLike, rpy: npt.ArrayLike | None = None) -> Target:
        """A target from a position [m] and optional roll, pitch, yaw [rad]."""
        rot = np.eye(3) if rpy is None else rpy_to_matrix(rpy)
        return Target(make_transform(rot, np.asarray(xyz, dtype=float)), rpy is not None)


@dataclass(frozen=True)
class PosePicture:
    """What :func:`render_pose` drew.

    Attributes:
        path: The file written.
        cameras: The cameras, one per panel.
        bounds: The cube shown.
        tool_position: Position of the tool frame [m].
        target_distance: Distance from the tool frame to the target [m], ``None`` without one.
        clearance: With a scene: the checked pair with the least room at the pose (drawn red
            when in contact); ``None`` without a scene or when no pair is checked.
    """

    path: Path
    cameras: tuple[Camera, ...]
    bounds: Bounds
    tool_position: tuple[float, float, float]
    target_distance: float | None
    clearance: Clearance | None = None


@dataclass(frozen=True)
class PathPicture:
    """What :func:`render_path` drew.

    Attributes:
        path: The file written.
        samples: Number of IK samples.
        max_deviation: Largest distance [m] of a sample's tool position from the planned line
            (``None`` without a line).
    """

    path: Path
    samples: int
    max_deviation: float | None


def resolve_frames(arm: KinematicModel, names: Sequence[str]) -> tuple[str, ...]:
    """Frame names to draw triads for; ``tool`` means the end effectors, ``all`` every frame.

    Raises:
        UnknownNameError: For a name that is neither a keyword nor a frame of the arm.
    """
    out: list[str] = []
    for name in names:
        if name == "all":
            out += arm.frame_names
        elif name == "tool":
            out += arm.end_effectors
        elif name != "none":
            arm.frame_index(name)
            out.append(name)
    return tuple(dict.fromkeys(out))


#: A picture title's font size [pt], and the smallest it is shrunk to before it wraps.
_TITLE_SIZE, _TITLE_SMALLEST = 9.0, 6.0
#: The width of an average character of the title font, in font sizes (DejaVu Sans).
_CHAR_WIDTH = 0.6


def set_title(fig: Figure, text: str) -> None:
    """Set a picture's title so that it fits the picture's width.

    One line at 9 pt when it fits, else smaller (down to 6 pt), else wrapped at 6 pt (a long
    joint vector, e.g. of an arm with ball joints).
    """
    width_pt = fig.get_figwidth() * 72.0 * 0.96
    size = _TITLE_SIZE
    fits = width_pt / (_CHAR_WIDTH * size)
    if len(text) > fits:
        size = max(_TITLE_SMALLEST, _TITLE_SIZE * fits / len(text))
        text = "\n".join(textwrap.wrap(text, max(10, int(width_pt / (_CHAR_WIDTH * size)))))
    fig.suptitle(text, fontsize=size)


def pose_title(arm: KinematicModel, q: npt.ArrayLike, deg: bool = False) -> str:
    """The arm's name and joint values, with their units, for a picture's title.

    Args:
        arm: The arm.
        q: Joint values ``(dof,)`` [rad] / [m].
        deg: Rotary joints in degrees (else radians); prismatic joints are in metres.
    """
    from armctl.config.schema import JointType

    qv = arm.as_q(q)
    if arm.multi_dof_joints:  # per joint: a quaternion for a ball joint, angles otherwise
        parts = []
        for i, t in enumerate(arm.joint_types):
            vals = qv[arm.q_index(i)]
            if t is JointType.BALL:
                parts.append("(" + " ".join(f"{v:.3f}" for v in vals) + ")")
            elif t is JointType.PRISMATIC:
                parts.append(f"{vals[0]:.3f} m")
            else:
                parts += [f"{math.degrees(v):.1f}" if deg else f"{v:.3f}" for v in vals]
        unit = "deg" if deg else "rad"
        return f"{arm.name}  q = [{', '.join(parts)}] ({unit}; ball joints as quaternions)"
    prismatic = [t is JointType.PRISMATIC for t in arm.joint_types]
    unit = "deg" if deg else "rad"
    if all(prismatic):
        return f"{arm.name}  q = [{', '.join(f'{v:.3f}' for v in qv)}] m"
    values = []
    for v, slides in zip(qv, prismatic, strict=True):
        if slides:  # a gripper finger among rotary joints: its own unit
            values.append(f"{v:.3f} m")
        else:
            values.append(f"{math.degrees(v):.1f}" if deg else f"{v:.3f}")
    return f"{arm.name}  q = [{', '.join(values)}] {unit}"


def triad_length(bounds: Bounds) -> float:
    """Length [m] of frame triads in a picture showing ``bounds``."""
    return 0.18 * bounds.half


def panel_figure(cameras: Sequence[Camera], size: float) -> tuple[Figure, list[Axes3D]]:
    """A figure with one 3-D panel per camera (two columns for several), ``size`` [in] each."""
    cols = 1 if len(cameras) == 1 else 2
    rows = (len(cameras) + cols - 1) // cols
    fig, axes = new_figure(rows, cols, size=(size * cols, size * rows), projection="3d")
    return fig, axes


def render_pose(arm: KinematicModel, q: npt.ArrayLike, out_path: str | Path, *,
                view: View = View.ISO, camera: Camera | None = None,
                frames: Sequence[str] = ("tool",), target: Target | None = None,
                bounds: Bounds | None = None, geometry: BoundGeometry | None = None,
                title: str | None = None, size: float = 5.0, dpi: float = 110,
                scene: SceneDrawing | None = None) -> PosePicture:
    """Draw the arm in one pose and write the picture (PNG, SVG, PDF, JPEG).

    Args:
        arm: The arm.
        q: Joint values ``(dof,)`` [rad] / [m].
        out_path: The image file.
        view: Named view(s); ignored when ``camera`` is given.
        camera: A chosen camera.
        frames: Frames to draw as axis triads (``tool``, ``all``, ``none`` or names).
        target: A goal pose to draw.
        bounds: The cube to show; fitted around the arm (and target) when ``None``.
        geometry: Pre-built bound geometry (built from ``arm`` when ``None``).
        title: Figure title; the arm name and joint values when ``None``.
        size: Size of one panel [in].
        dpi: Resolution.
        scene: The scene at this pose (:func:`armctl.render.scene.scene_drawing`): the table
            and the obstacles are drawn, and a pair in contact in red; ``None``: the arm alone.

    Returns:
        What was drawn.

    Raises:
        InputError: Wrong number of joint values, unknown frame names.
        OutputError: If the file cannot be written (checked before drawing).
    """
    qv = arm.as_q(q)
    out = check_output(out_path)
    names = resolve_frames(arm, frames)
    geo = geometry or BoundGeometry(arm)
    poses = arm.fk_frames(qv)
    verts = geo.pose_vertices(poses)
    if bounds is None:
        pts = [verts] if target is None else [verts, target.pose[:3, 3][None, :]]
        if scene is not None:
            pts.append(scene.points())
            if scene.table_height is not None:  # the table top under the base
                pts.append(np.array([[0.0, 0.0, scene.table_height]]))
        bounds = Bounds.around(np.vstack(pts))
    hot = {} if scene is None else {name: CONTACT_COLOR for name in scene.highlighted}
    cams = [camera] if camera is not None else cameras_for(view)
    fig, axes = panel_figure(cams, size)
    fig.set_dpi(dpi)
    length = triad_length(bounds)
    for ax, cam in zip(axes, cams, strict=False):
        setup_axes(ax, bounds, cam, title=len(cams) > 1 or camera is None)
        arm_points = ArmArtist(ax, geo, highlight=hot).set_pose(poses)
        if scene is not None:
            draw_scene(ax, scene, bounds, arm_points)
        for name in names:
            FrameTriad(ax, length, name if len(names) <= 8 else "").set_pose(
                poses[arm.frame_index(name)])
        if target is not None:
            draw_target(ax, target.pose, length, target.oriented)
    set_title(fig, title if title is not None else pose_title(arm, qv))
    fit_labels(fig, axes)
    save_figure(fig, out)
    tool = arm.fk(qv)[:3, 3]
    dist = None if target is None else float(np.linalg.norm(tool - target.pose[:3, 3]))
    return PosePicture(out, tuple(cams), bounds,
                       (float(tool[0]), float(tool[1]), float(tool[2])), dist,
                       None if scene is None else scene.clearance)


def render_path(arm: KinematicModel, qs: npt.ArrayLike, out_path: str | Path, *,
                line: npt.ArrayLike | None = None, frame: str | None = None, ghosts: int = 3,
                view: View = View.ISO, camera: Camera | None = None,
                target: Target | None = None, bounds: Bounds | None = None,
                geometry: BoundGeometry | None = None, title: str | None = None,
                size: float = 5.0, scene: SceneDrawing | None = None) -> PathPicture:
    """Draw a planned move (see :func:`armctl.render.draw.draw_path`) and write the picture.

    Args:
        arm: The arm.
        qs: Joint values of the IK samples ``(N, dof)``.
        out_path: The image file.
        line: The planned Cartesian path ``(k, 3)`` [m], e.g. a straight line's two ends.
        frame: The frame that follows the path; the tool frame when ``None``.
        ghosts: Number of translucent intermediate poses.
        view: Named view(s); ignored when ``camera`` is given.
        camera: A chosen camera.
        target: The goal, drawn as in :func:`render_pose`.
        bounds: The cube to show; fitted around everything drawn when ``None``.
        geometry: Pre-built bound geometry.
        title: Figure title.
        size: Size of one panel [in].
        scene: The scene at the last sample (:func:`armctl.render.scene.scene_drawing`): the
            table and the obstacles are drawn, and a pair in contact at the last pose in red.

    Returns:
        What was drawn, with the largest deviation of the samples from the line.
    """
    q = arm.as_batch(qs)
    out = check_output(out_path)
    arm.frame_index(frame)
    geo = geometry or BoundGeometry(arm)
    if bounds is None:
        pts = [geo.world_vertices(q[0]), geo.world_vertices(q[-1])]
        if line is not None:
            pts.append(np.asarray(line, dtype=float).reshape(-1, 3))
        if scene is not None:
            pts.append(scene.points())
        bounds = Bounds.around(np.vstack(pts))
    hot = {} if scene is None else {name: CONTACT_COLOR for name in scene.highlighted}
    cams = [camera] if camera is not None else cameras_for(view)
    fig, axes = panel_figure(cams, size)
    tool_pts = np.zeros((0, 3))
    for ax, cam in zip(axes, cams, strict=False):
        setup_axes(ax, bounds, cam)
        tool_pts = draw_path(ax, geo, q, line=line, frame=frame, ghosts=ghosts, highlight=hot)
        if scene is not None:
            draw_scene(ax, scene, bounds, geo.pose_vertices(arm.fk_frames(q[-1])))
        if target is not None:
            draw_target(ax, target.pose, triad_length(bounds), target.oriented)
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(title or f"{arm.name}: path with {len(q)} IK samples", fontsize=9)
    fit_labels(fig, axes)
    save_figure(fig, out)
    dev = None if line is None else float(point_to_polyline(tool_pts, line).max())
    return PathPicture(out, len(q), dev)
