"""Drawing an arm on matplotlib 3-D axes: shaded link geometry, frame triads, targets, paths.

The functions take axes made by :func:`armctl.render.plots.new_figure` with ``projection="3d"``;
the projection is orthographic with equal scale on all axes, so distances in a picture are true.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from armctl.render.binding import BoundGeometry
from armctl.typing import Array

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d import Axes3D

__all__ = [
    "ArmArtist",
    "Bounds",
    "Camera",
    "FrameTriad",
    "View",
    "cameras_for",
    "draw_path",
    "draw_target",
    "fit_labels",
    "point_to_polyline",
    "setup_axes",
]


_LINK_COLORS = ("#E69F00", "#8FA3B8")
_BASE_COLOR = "#4D4D4D"
_AXIS_COLORS = ("#D62728", "#2CA02C", "#1F77B4")
_TARGET_COLOR = "#CC00CC"
_LIGHT = np.array([-0.35, -0.55, 0.76]) / np.linalg.norm([-0.35, -0.55, 0.76])


@dataclass(frozen=True)
class Camera:
    """A viewing direction.

    Attributes:
        name: Label shown above the picture.
        elev: Elevation of the eye above the x-y plane [deg].
        azim: Azimuth of the eye about z, from the +x axis [deg].
    """

    name: str
    elev: float
    azim: float


class View(Enum):
    """Named cameras: ``iso``, ``front`` (from +x), ``side`` (from -y), ``top``, or ``all``."""

    ISO = "iso"
    FRONT = "front"
    SIDE = "side"
    TOP = "top"
    ALL = "all"


_CAMERAS = {
    View.ISO: Camera("iso", 25.0, -50.0),
    View.FRONT: Camera("front (from +x)", 0.0, 0.0),
    View.SIDE: Camera("side (from -y)", 0.0, -90.0),
    View.TOP: Camera("top (from +z)", 90.0, -90.0),
}


def cameras_for(view: View) -> list[Camera]:
    """The cameras of a named view (four for :attr:`View.ALL`)."""
    if view is View.ALL:
        return [_CAMERAS[v] for v in (View.ISO, View.FRONT, View.SIDE, View.TOP)]
    return [_CAMERAS[view]]


@dataclass(frozen=True)
class Bounds:
    """An axis-aligned cube that a picture shows.

    Attributes:
        centre: Centre [m].
        half: Half the edge length [m].
    """

    centre: tuple[float, float, float]
    half: float

    @staticmethod
    def around(points: npt.ArrayLike, pad: float = 0.08) -> Bounds:
        """The smallest cube holding ``points`` ``(n, 3)``, enlarged by ``pad`` of its size."""
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        lo, hi = p.min(axis=0), p.max(axis=0)
        half = max(float((hi - lo).max()) / 2.0, 1e-3) * (1.0 + pad)
        c = (lo + hi) / 2.0
        return Bounds((float(c[0]), float(c[1]), float(c[2])), half)


def _depth_axis(camera: Camera) -> str | None:
    """The axis that points at the eye, for cameras looking along a coordinate axis."""
    if abs(abs(camera.elev) - 90.0) < 1e-9:
        return "z"
    if abs(camera.elev) < 1e-9 and camera.azim % 90.0 == 0.0:
        return "x" if camera.azim % 180.0 == 0.0 else "y"
    return None


def setup_axes(ax: Axes3D, bounds: Bounds, camera: Camera, *, title: bool = True) -> None:
    """Orthographic camera, equal scale, limits from ``bounds``, labelled axes in [m]."""
    ax.set_proj_type("ortho")
    ax.view_init(elev=camera.elev, azim=camera.azim)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    c, h = bounds.centre, bounds.half
    ax.set_xlim(c[0] - h, c[0] + h)
    ax.set_ylim(c[1] - h, c[1] + h)
    ax.set_zlim(c[2] - h, c[2] + h)
    depth = _depth_axis(camera)
    for name, axis in (("x", ax.xaxis), ("y", ax.yaxis), ("z", ax.zaxis)):
        axis.set_pane_color((0.96, 0.96, 0.96, 1.0))
        if name == depth:  # seen end-on: its ticks would collapse into one blot
            axis.set_ticks([])
            axis.set_label_text("")
        else:
            axis.set_label_text(f"{name} [m]", fontsize=7)
    ax.tick_params(labelsize=6)
    ax.computed_zorder = False
    if title:
        ax.set_title(camera.name, fontsize=9)


#: Room [px] kept between a panel's labels and the figure's edge.
_EDGE = 3.0


def fit_labels(fig: Figure, axes: Sequence[Axes3D]) -> None:
    """Shrink the 3-D panels whose axis labels would reach past the figure's edge.

    A 3-D panel draws its axis labels outside the cube, and the layout does not always leave
    room for them (the z label of the iso view falls off the right edge). Each such panel's
    cube is scaled down about its centre just enough to bring every label inside.
    """
    fig.draw_without_rendering()  # lays the figure out and places the labels
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    width, height = fig.bbox.width, fig.bbox.height
    for ax in axes:
        cx, cy = ax.bbox.x0 + ax.bbox.width / 2.0, ax.bbox.y0 + ax.bbox.height / 2.0
        scale = 1.0
        for text in (ax.xaxis.label, ax.yaxis.label, ax.zaxis.label):  # outside the ticks
            if not text.get_visible() or not text.get_text():
                continue
            box = text.get_window_extent(renderer)
            for far, centre, lo, hi in ((box.x0, cx, _EDGE, width - _EDGE),
                                        (box.x1, cx, _EDGE, width - _EDGE),
                                        (box.y0, cy, _EDGE, height - _EDGE),
                                        (box.y1, cy, _EDGE, height - _EDGE)):
                edge = hi if far > hi else lo if far < lo else None
                if edge is not None and abs(far - centre) > 1e-6:
                    scale = min(scale, (edge - centre) / (far - centre))
        if scale < 1.0:
            ax.set_box_aspect((1.0, 1.0, 1.0), zoom=max(0.5, 0.97 * scale))


def _link_colors(geometry: BoundGeometry, highlight: Mapping[str, str] | None = None) -> Array:
    from matplotlib.colors import to_rgb

    base = geometry.arm.spec.base
    colors = []
    k = 0
    for name in geometry.links:
        if name == base:
            colors.append(to_rgb(_BASE_COLOR))
        else:
            colors.append(to_rgb(_LINK_COLORS[k % 2]))
            k += 1
        if highlight and name in highlight:
            colors[-1] = to_rgb(highlight[name])
    return np.array(colors)[geometry.face_link]


class ArmArtist:
    """The arm's link geometry as one shaded triangle collection that can be re-posed.

    Args:
        ax: 3-D axes.
        geometry: The bound geometry.
        alpha: Opacity (1 solid).
        zorder: Drawing order among the artists of ``ax``.
        tint: One colour for every link (e.g. for ghost poses), or ``None`` for link colours.
        highlight: Colours of chosen links by name (e.g. a pair in contact), over the others.
    """

    def __init__(self, ax: Axes3D, geometry: BoundGeometry, alpha: float = 1.0,
                 zorder: float = 1.0, tint: str | None = None,
                 highlight: Mapping[str, str] | None = None):
        from matplotlib.colors import to_rgb
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        self.geometry = geometry
        self.alpha = alpha
        self._tint = tint
        self._rgb = (_link_colors(geometry, highlight) if tint is None else
                     np.tile(np.array(to_rgb(tint)), (len(geometry.faces), 1)))
        self._edges = alpha >= 1.0  # edges of translucent faces would add up to dark lines
        self.collection = Poly3DCollection(np.zeros((0, 3, 3)),
                                           linewidths=0.25 if self._edges else 0.0, zorder=zorder)
        ax.add_collection3d(self.collection)

    def set_highlight(self, highlight: Mapping[str, str] | None) -> None:
        """Colour chosen links by name (``None``: every link its own colour again).

        Takes effect at the next :meth:`set_pose`; an artist with a ``tint`` keeps it.
        """
        if self._tint is None:
            self._rgb = _link_colors(self.geometry, highlight)

    def set_pose(self, frame_poses: npt.ArrayLike) -> Array:
        """Move every link to its pose; returns the world vertices ``(V, 3)``.

        Args:
            frame_poses: Poses ``(m, 4, 4)`` of all frames (``arm.fk_frames(q)``).
        """
        v = self.geometry.pose_vertices(frame_poses)
        tris = v[self.geometry.faces]
        n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-15)
        shade = 0.42 + 0.58 * np.abs(n @ _LIGHT)
        rgba = np.column_stack([self._rgb * shade[:, None], np.full(len(tris), self.alpha)])
        self.collection.set_verts(list(tris))
        self.collection.set_facecolor(rgba)
        if self._edges:
            self.collection.set_edgecolor(rgba)  # hides the seams between triangles
        return v


class FrameTriad:
    """Axes of a frame drawn as red (x), green (y), blue (z) lines, optionally labelled.

    Args:
        ax: 3-D axes.
        length: Length of each axis line [m].
        label: Text written at the frame origin, or ``""``.
        linestyle: A matplotlib line style.
    """

    def __init__(self, ax: Axes3D, length: float, label: str = "", linestyle: str = "-"):
        self.length = length
        self.lines = [ax.plot([], [], [], color=c, linewidth=1.6, linestyle=linestyle,
                              zorder=10)[0] for c in _AXIS_COLORS]
        self.text = ax.text(0.0, 0.0, 0.0, label, fontsize=6, zorder=11) if label else None

    def set_pose(self, pose: npt.ArrayLike) -> None:
        """Place the triad at a ``(4, 4)`` pose."""
        t = np.asarray(pose, dtype=float)
        o = t[:3, 3]
        for k, line in enumerate(self.lines):
            e = o + t[:3, k] * self.length
            line.set_data_3d([o[0], e[0]], [o[1], e[1]], [o[2], e[2]])
        if self.text is not None:
            self.text.set_position_3d(tuple(o))


def draw_target(ax: Axes3D, pose: npt.ArrayLike, length: float, oriented: bool) -> None:
    """Draw a goal: a star at its position, and a dashed triad when its orientation matters."""
    t = np.asarray(pose, dtype=float)
    ax.plot([t[0, 3]], [t[1, 3]], [t[2, 3]], marker="*", markersize=11, color=_TARGET_COLOR,
            linestyle="none", zorder=12, label="target")
    if oriented:
        FrameTriad(ax, length, linestyle="--").set_pose(t)


def point_to_polyline(points: npt.ArrayLike, polyline: npt.ArrayLike) -> Array:
    """Distance [m] of each point ``(n, 3)`` from a polyline ``(k, 3)`` (k >= 1)."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    line = np.asarray(polyline, dtype=float).reshape(-1, 3)
    if len(line) == 1:
        return np.asarray(np.linalg.norm(p - line[0], axis=1))
    best = np.full(len(p), np.inf)
    for a, b in itertools.pairwise(line):
        d = b - a
        s = np.clip(((p - a) @ d) / max(float(d @ d), 1e-30), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(p - (a + s[:, None] * d), axis=1))
    return best


def draw_path(ax: Axes3D, geometry: BoundGeometry, qs: npt.ArrayLike, *,
              line: npt.ArrayLike | None = None, frame: str | None = None,
              ghosts: int = 3, highlight: Mapping[str, str] | None = None) -> Array:
    """Draw a planned move: the planned line, the IK samples' tool positions, ghost poses.

    Args:
        ax: 3-D axes.
        geometry: The arm's bound geometry.
        qs: Joint values of the IK samples along the path ``(N, dof)``.
        line: The planned Cartesian path ``(k, 3)`` [m] (e.g. start and end of a straight
            line); ``None`` draws none.
        frame: The frame that follows the path; the tool frame when ``None``.
        ghosts: How many translucent intermediate poses to draw (the last pose is drawn solid).
        highlight: Colours of chosen links of the last pose by name (e.g. a pair in contact).

    Returns:
        The positions ``(N, 3)`` [m] of ``frame`` at the samples.
    """
    arm = geometry.arm
    q = arm.as_batch(qs)
    pts = arm.fk_batch(q, frame)[:, :3, 3]
    if line is not None:
        lp = np.asarray(line, dtype=float).reshape(-1, 3)
        ax.plot(lp[:, 0], lp[:, 1], lp[:, 2], color="black", linestyle="--", linewidth=1.2,
                zorder=9, label="planned")
    ax.plot(pts[:, 0], pts[:, 1], pts[:, 2], color="#0072B2", marker="o", markersize=2.5,
            linestyle="none", zorder=9.5, label="IK samples")
    if ghosts > 0 and len(q) > 1:
        for i in np.linspace(0, len(q) - 1, ghosts + 1).astype(int)[:-1]:
            ArmArtist(ax, geometry, alpha=0.15, zorder=0.5, tint="#8FA3B8").set_pose(
                arm.fk_frames(q[i]))
    ArmArtist(ax, geometry, zorder=1.0, highlight=highlight).set_pose(arm.fk_frames(q[-1]))
    return pts
