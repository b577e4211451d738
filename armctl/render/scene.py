"""The scene around an arm in pictures: the table, the obstacles, and the pair in contact.

:func:`scene_drawing` gathers what a picture of one pose shows of the scene: every obstacle as
a triangle mesh in the arm's base frame (obstacles placed in the world frame are moved by the
scene's ``base_in_world``), the height of the table, and the checked pair with the least room
at the pose (from :class:`armctl.collision.CollisionModel`, computed by the interpreted kernels:
one pose costs milliseconds and loads no compiler). When that pair is in contact both of its
members are drawn red: the link, and the other link, the obstacle or the table.

matplotlib is imported inside the drawing functions only.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from armctl.collision.contact import Clearance
from armctl.collision.model import CollisionModel
from armctl.collision.single import clearance_once
from armctl.config.scene import TABLE, SceneFrame, SceneSpec
from armctl.kinematics.model import KinematicModel
from armctl.render.draw import Bounds
from armctl.render.shapes import TriMesh, box_mesh, shape_mesh
from armctl.typing import Array

if TYPE_CHECKING:
    from mpl_toolkits.mplot3d import Axes3D
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

__all__ = [
    "CONTACT_COLOR",
    "OBSTACLE_COLOR",
    "TABLE_COLOR",
    "SceneArtist",
    "SceneDrawing",
    "SceneMesh",
    "draw_scene",
    "obstacle_meshes",
    "scene_drawing",
    "table_mesh",
]

#: Colour of the members of a pair in contact (links, obstacles, the table).
CONTACT_COLOR = "#D62728"
#: Colour of the obstacles.
OBSTACLE_COLOR = "#009E73"
#: Colour of the table.
TABLE_COLOR = "#B59B6B"
_OBSTACLE_ALPHA = 0.55
_TABLE_ALPHA = 0.22
_CONTACT_ALPHA = 0.8
#: Thickness of the drawn table top, as a fraction of the half edge of the picture's cube.
_TABLE_THICKNESS = 0.02
#: Direction of the light that shades the faces (as the arm's, see :mod:`armctl.render.draw`).
_LIGHT = np.array([-0.35, -0.55, 0.76]) / np.linalg.norm([-0.35, -0.55, 0.76])


@dataclass(frozen=True, eq=False)
class SceneMesh:
    """One obstacle as triangles.

    Attributes:
        name: The obstacle's name (as in contact reports).
        mesh: Its surface in the arm's base frame [m].
    """

    name: str
    mesh: TriMesh


@dataclass(frozen=True, eq=False)
class SceneDrawing:
    """What a picture of one pose shows of the scene.

    Attributes:
        scene: The scene.
        obstacles: The obstacles' meshes in the base frame.
        table_height: Height of the table top in the base frame [m]; ``None``: no table.
        clearance: The checked pair with the least room at the pose (``None``: no pair is
            checked).
    """

    scene: SceneSpec
    obstacles: tuple[SceneMesh, ...]
    table_height: float | None
    clearance: Clearance | None

    @property
    def in_contact(self) -> bool:
        """Whether the pair with the least room is closer than its padding."""
        return self.clearance is not None and self.clearance.margin < 0.0

    @property
    def highlighted(self) -> frozenset[str]:
        """The names drawn in :data:`CONTACT_COLOR`: the pair in contact (empty when free)."""
        if not self.in_contact:
            return frozenset()
        assert self.clearance is not None  # mypy: in_contact says so
        return frozenset((self.clearance.a, self.clearance.b))

    def points(self) -> Array:
        """Points a picture should show: the obstacles' vertices ``(n, 3)`` [m]."""
        if not self.obstacles:
            return np.zeros((0, 3))
        return np.vstack([o.mesh.vertices for o in self.obstacles])


def obstacle_meshes(scene: SceneSpec, config: Path | None = None) -> tuple[SceneMesh, ...]:
    """Every obstacle of ``scene`` as a triangle mesh in the arm's base frame.

    Args:
        scene: The scene.
        config: The file that describes the scene (for error messages about mesh files),
            when the scene does not name its own.

    Raises:
        MeshLoadError: A mesh file that cannot be read.
    """
    world_to_base = np.linalg.inv(scene.base_in_world.matrix())
    out = []
    for ob in scene.obstacles:
        mesh = shape_mesh(ob.shape, ob.name, scene.file or config)  # in the obstacle's frame
        if ob.frame is SceneFrame.WORLD:
            mesh = mesh.transformed(world_to_base)
        out.append(SceneMesh(ob.name, mesh))
    return tuple(out)


def table_mesh(height: float, bounds: Bounds) -> TriMesh:
    """The table top as a thin slab under ``z = height``, as wide as the picture's cube.

    Args:
        height: Height of the table top in the base frame [m].
        bounds: The cube the picture shows.
    """
    thick = _TABLE_THICKNESS * bounds.half
    c = bounds.centre
    slab = box_mesh((2.0 * bounds.half, 2.0 * bounds.half, thick))
    return TriMesh(slab.vertices + np.array([c[0], c[1], height - thick / 2.0]), slab.faces)


def scene_drawing(arm: KinematicModel, q: npt.ArrayLike,
                  scene: SceneSpec | None = None) -> SceneDrawing:
    """The scene to draw with the arm at ``q``, and its pair with the least room.

    Args:
        arm: The arm.
        q: Joint values ``(dof,)`` [rad]/[m].
        scene: The scene; ``None``: the arm's ``scene:`` section, else a table at the base.

    Raises:
        InputError: ``q`` of the wrong length or not finite.
        SceneError: An obstacle name used twice.
        MeshLoadError: A mesh file that cannot be read.
    """
    model = CollisionModel.of(arm, scene)
    sc = model.scene
    return SceneDrawing(sc, obstacle_meshes(sc, arm.spec.file),
                        None if sc.table is None else sc.table.height,
                        clearance_once(model, q))


def _shaded(mesh: TriMesh, color: str, alpha: float) -> Array:
    """Face colours ``(F, 4)``: ``color`` lit from above, with opacity ``alpha``."""
    from matplotlib.colors import to_rgb

    tris = mesh.vertices[mesh.faces]
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-15)
    shade = 0.55 + 0.45 * np.abs(n @ _LIGHT)
    rgb = np.array(to_rgb(color))
    return np.column_stack([rgb[None, :] * shade[:, None], np.full(len(tris), alpha)])


class SceneArtist:
    """The table and the obstacles on 3-D axes, recoloured when a pair is in contact.

    The table is drawn under the arm (a translucent slab as wide as the picture), each obstacle
    behind or in front of the arm by depth (:meth:`order`), translucent so that links behind
    it stay visible.

    Args:
        ax: 3-D axes.
        obstacles: The obstacles' meshes in the base frame.
        table_height: Height of the table top [m]; ``None``: no table.
        bounds: The cube the picture shows.

    Attributes:
        axes: The axes drawn on.
        collections: The artist of each object, by name (``"table"`` for the table).
    """

    def __init__(self, ax: Axes3D, obstacles: Sequence[SceneMesh], table_height: float | None,
                 bounds: Bounds):
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        self._meshes: dict[str, TriMesh] = {}
        self.collections: dict[str, Poly3DCollection] = {}
        if table_height is not None:
            self._meshes[TABLE] = table_mesh(table_height, bounds)
        for ob in obstacles:
            self._meshes[ob.name] = ob.mesh
        for name, mesh in self._meshes.items():
            coll = Poly3DCollection(list(mesh.vertices[mesh.faces]), linewidths=0.0,
                                    zorder=0.2 if name == TABLE else _BEHIND)
            ax.add_collection3d(coll)
            self.collections[name] = coll
        self.axes = ax
        self._hot: frozenset[str] | None = None
        self.set_contact(frozenset())

    def order(self, ax: Axes3D, arm_points: npt.ArrayLike) -> None:
        """Draw each obstacle in front of the arm or behind it, by depth.

        In front when its centre is nearer the camera than the arm's, else behind. Each
        collection is drawn whole in a fixed order (the arm's own triangles are sorted by depth
        within its one collection), so an obstacle between the camera and the arm would
        otherwise hide behind it; its translucency shows the arm through it.

        Args:
            ax: The axes (their camera's elevation and azimuth).
            arm_points: Points of the posed arm ``(N, 3)`` [m] (its vertices).
        """
        elev, azim = np.radians(ax.elev), np.radians(ax.azim)
        toward = np.array([np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim),
                           np.sin(elev)])
        arm_depth = float(np.mean(np.asarray(arm_points, dtype=float).reshape(-1, 3) @ toward))
        for name, coll in self.collections.items():
            if name == TABLE:
                continue
            near = float(self._meshes[name].vertices.mean(axis=0) @ toward) > arm_depth
            coll.set_zorder(_IN_FRONT if near else _BEHIND)

    def set_contact(self, names: frozenset[str]) -> None:
        """Draw the objects named in ``names`` in :data:`CONTACT_COLOR`, the others plainly."""
        if names == self._hot:
            return
        for name, coll in self.collections.items():
            if name in names:
                color, alpha = CONTACT_COLOR, _CONTACT_ALPHA
            elif name == TABLE:
                color, alpha = TABLE_COLOR, _TABLE_ALPHA
            else:
                color, alpha = OBSTACLE_COLOR, _OBSTACLE_ALPHA
            coll.set_facecolor(_shaded(self._meshes[name], color, alpha))
        self._hot = names


#: Drawing orders of an obstacle behind the arm (drawn at 1.0) and in front of it.
_BEHIND, _IN_FRONT = 0.6, 1.5


def draw_scene(ax: Axes3D, drawing: SceneDrawing, bounds: Bounds,
               arm_points: npt.ArrayLike | None = None) -> dict[str, Poly3DCollection]:
    """Draw the table and the obstacles on 3-D axes; the pair in contact in red.

    Args:
        ax: 3-D axes.
        drawing: What to draw (:func:`scene_drawing`).
        bounds: The cube the picture shows (the table is drawn as wide).
        arm_points: Points of the posed arm: obstacles nearer the camera are drawn in front
            of it (:meth:`SceneArtist.order`).

    Returns:
        The artist of each object drawn, by name (``"table"`` for the table).
    """
    artist = SceneArtist(ax, drawing.obstacles, drawing.table_height, bounds)
    artist.set_contact(drawing.highlighted)
    if arm_points is not None:
        artist.order(ax, arm_points)
    return artist.collections
