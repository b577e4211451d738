"""The reachable workspace: a cloud of frame positions from random joint values, and its plot.

The cloud comes from forward kinematics of configurations sampled uniformly inside the joint
limits. Its volume is estimated two ways: the occupied voxels of a grid, surface voxels counted
half (an estimate, low where the cloud is too sparse to fill its voxels), and the convex hull
(fills holes and concave parts, so it overestimates non-convex workspaces).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from armctl.errors import InputError
from armctl.kinematics.model import KinematicModel
from armctl.render.binding import BoundGeometry
from armctl.render.draw import ArmArtist, Bounds, Camera, setup_axes
from armctl.render.plots import check_output, new_figure, save_figure, style_axes
from armctl.typing import Array

__all__ = ["Workspace", "WorkspacePlot", "plot_workspace", "sample_workspace", "voxel_volume"]


@dataclass(frozen=True, eq=False)
class Workspace:
    """A sampled reachable workspace.

    Attributes:
        arm: The arm.
        frame: The frame whose positions were sampled.
        points: Positions ``(n, 3)`` [m] in the base frame.
        lower: Smallest x, y, z [m].
        upper: Largest x, y, z [m].
        max_reach: Largest distance from the base origin [m].
        voxel: Edge of the volume grid's voxels [m].
        voxel_volume: Volume of the occupied voxels, surface voxels counted half [m^3].
        hull_volume: Volume of the convex hull [m^3]; ``None`` for a flat cloud or without scipy.
    """

    arm: KinematicModel
    frame: str
    points: Array
    lower: Array
    upper: Array
    max_reach: float
    voxel: float
    voxel_volume: float
    hull_volume: float | None


def _hull_volume(points: Array) -> float | None:
    try:
        from scipy.spatial import ConvexHull, QhullError
    except ImportError:
        return None
    try:
        return float(ConvexHull(points).volume)
    except (QhullError, ValueError):  # flat (planar) or degenerate cloud
        return None


def sample_workspace(arm: KinematicModel, samples: int = 20000, frame: str | None = None,
                     seed: int = 0, voxel: float | None = None) -> Workspace:
    """Sample the reachable positions of a frame.

    Args:
        arm: The arm.
        samples: Number of random configurations.
        frame: The frame; the tool frame when ``None``.
        seed: Random seed.
        voxel: Voxel edge [m] of the volume estimate; when ``None``, the largest extent divided
            into ``(samples / 10) ** (1/3)`` cells (4 to 60), about ten samples per cell.

    Raises:
        InputError: For fewer than 10 samples or a non-positive voxel size.
        UnknownNameError: For an unknown frame.
    """
    if samples < 10:
        raise InputError(f"workspace: need at least 10 samples, got {samples}")
    if voxel is not None and not voxel > 0:
        raise InputError(f"workspace: the voxel size must be positive, got {voxel}")
    name = frame or arm.tool
    arm.frame_index(name)
    qs = arm.sample(np.random.default_rng(seed), samples)
    pts = np.ascontiguousarray(arm.fk_batch(qs, name)[:, :3, 3])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    cells_per_axis = min(max(round((samples / 10.0) ** (1.0 / 3.0)), 4), 60)
    size = voxel or max(float((hi - lo).max()) / cells_per_axis, 1e-4)
    return Workspace(arm, name, pts, lo, hi, float(np.linalg.norm(pts, axis=1).max()), size,
                     voxel_volume(pts, size), _hull_volume(pts))


def voxel_volume(points: Array, voxel: float) -> float:
    """Volume [m^3] of the voxels of edge ``voxel`` [m] that hold a point of ``points`` ``(n, 3)``.

    Voxels on the surface of the occupied set (with an empty face neighbour) count half, since the
    surface cuts them through on average.
    """
    idx = np.floor((points - points.min(axis=0)) / voxel).astype(np.int64) + 1
    grid = np.zeros(tuple(idx.max(axis=0) + 2), dtype=bool)
    grid[idx[:, 0], idx[:, 1], idx[:, 2]] = True
    inner = grid.copy()
    for axis in range(3):
        for shift in (1, -1):
            inner &= np.roll(grid, shift, axis=axis)
    n_occupied = int(grid.sum())
    n_surface = n_occupied - int(inner.sum())
    return float((n_occupied - 0.5 * n_surface) * voxel**3)


@dataclass(frozen=True)
class WorkspacePlot:
    """What :func:`plot_workspace` drew.

    Attributes:
        path: The file written.
        z_slice: Height [m] of the x-y slice.
        y_slice: Offset [m] of the x-z slice.
        slab: Thickness [m] of both slices.
    """

    path: Path
    z_slice: float
    y_slice: float
    slab: float


def plot_workspace(ws: Workspace, out_path: str | Path, *, z_slice: float | None = None,
                   y_slice: float | None = None, slab: float | None = None,
                   size: float = 4.2) -> WorkspacePlot:
    """Plot a workspace: the 3-D cloud with the arm, an x-y slice and an x-z slice.

    A slice shows the points within ``slab / 2`` of its plane in colour, over the projection of
    the whole cloud in grey.

    Args:
        ws: The sampled workspace.
        out_path: The image file.
        z_slice: Height [m] of the x-y slice; the middle of the z extent when ``None``.
        y_slice: Offset [m] of the x-z slice; the middle of the y extent when ``None``.
        slab: Slice thickness [m]; 5 % of the largest extent when ``None``.
        size: Size of one panel [in].
    """
    out = check_output(out_path)
    mid = (ws.lower + ws.upper) / 2.0
    z0 = float(mid[2]) if z_slice is None else z_slice
    y0 = float(mid[1]) if y_slice is None else y_slice
    h = slab if slab is not None else max(0.05 * float((ws.upper - ws.lower).max()), 1e-4)
    if not h > 0:
        raise InputError(f"workspace: the slab thickness must be positive, got {h}")
    fig, _ = new_figure(1, 1, size=(size * 3.3, size))
    fig.clear()
    grid = fig.add_gridspec(1, 3, width_ratios=(1.25, 1.0, 1.0))
    ax3 = fig.add_subplot(grid[0, 0], projection="3d")
    pts = ws.points
    show = pts[:: max(len(pts) // 4000, 1)]
    geo = BoundGeometry(ws.arm)
    q_mid = ws.arm.middle()
    arm_verts = ArmArtist(ax3, geo, alpha=0.9, zorder=2).set_pose(ws.arm.fk_frames(q_mid))
    setup_axes(ax3, Bounds.around(np.vstack([pts, arm_verts])), Camera("cloud", 25.0, -50.0))
    ax3.scatter(show[:, 0], show[:, 1], show[:, 2], s=1.0, c=show[:, 2], cmap="viridis",
                alpha=0.35, zorder=1, depthshade=False)
    ax3.set_title(f"{len(pts)} samples of {ws.frame!r}", fontsize=9)
    for k, (axis, val, other) in enumerate(((2, z0, 1), (1, y0, 2))):
        ax = fig.add_subplot(grid[0, 1 + k])
        near = np.abs(pts[:, axis] - val) <= h / 2.0
        ax.scatter(pts[:, 0], pts[:, other], s=0.6, color="#cccccc", rasterized=True)
        ax.scatter(pts[near, 0], pts[near, other], s=1.5, color="#0072B2", rasterized=True)
        ax.plot([0.0], [0.0], marker="+", color="black", markersize=9)
        ax.set_aspect("equal", adjustable="datalim")
        plane = "x-y" if axis == 2 else "x-z"
        coord = "z" if axis == 2 else "y"
        style_axes(ax, f"{plane} slice at {coord} = {val:.3f} m (±{h / 2:.3f} m), "
                   f"{int(near.sum())} points", "x [m]", f"{'y' if other == 1 else 'z'} [m]")
    fig.suptitle(f"{ws.arm.name}: reachable workspace", fontsize=10)
    save_figure(fig, out)
    return WorkspacePlot(out, z0, y0, h)
