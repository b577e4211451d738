"""The exact narrow phase: the real shapes decide where the capsules say "contact".

Capsules contain the shapes they stand for, so a pair whose capsules keep their padding is free;
a pair whose capsules do not may still be free when its shapes are boxes, cylinders or meshes.
With a scene's ``exact: true`` (:attr:`~armctl.config.scene.SceneSpec.exact`), every such pair is
measured again between the real shapes with the collision library (:mod:`armctl.collision.exact`,
coal), and that distance counts. Pairs whose shapes the kernels hold exactly (capsules and
spheres on links; the table, spheres, capsules and boxes in the scene) are never measured twice.

Motions are certified the same way as with capsules alone (a pair's distance changes no faster
than its shapes move, whatever the shapes), with the exact distances in place of the capsules'
where they were measured.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from armctl.collision.contact import ContactKind
from armctl.collision.exact import (
    ExactShape,
    MeshMode,
    exact_shape,
    signed_distance,
    table_distance,
)
from armctl.config.scene import Obstacle, SceneFrame, SceneSpec
from armctl.config.schema import Box, Capsule, Geometry, Sphere
from armctl.kinematics.linkshapes import GeometryRole, link_shapes
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["ExactPairs"]


class CollisionModel(Protocol):
    """What the narrow phase reads of :class:`armctl.collision.model.CollisionModel`."""

    model: KinematicModel
    scene: SceneSpec
    obstacle_specs: tuple[Obstacle | None, ...]
    levers: Array

    @property
    def pair_count(self) -> int: ...

    def pair_capsules(self, idx: int) -> tuple[int, int, ContactKind]: ...

    def capsule_link(self, capsule: int) -> str: ...

    def required(self) -> Array: ...

    def slacks_batch(self, qs: Array) -> Array: ...


class ExactPairs:
    """Exact distances for the pairs of a collision model whose capsules are approximations.

    Args:
        model: The collision model.
        mesh_mode: How meshes are measured (their convex hull by default).

    Raises:
        MissingExtraError: If coal is not installed (``pip install 'armctl[collision]'``).
        MeshLoadError: A mesh file that cannot be read.
    """

    def __init__(self, model: CollisionModel, mesh_mode: MeshMode = MeshMode.HULL):
        self.model = model
        spec = model.model.spec
        shapes: list[tuple[str, Geometry]] = []
        for name, ls in link_shapes(spec, GeometryRole.COLLISION).items():
            shapes.extend((name, s) for s in ls.shapes)
        if len(shapes) != model.levers.shape[0]:  # pragma: no cover - same source as capsules
            raise RuntimeError("the link shapes and the capsules disagree")
        self._cap_shapes = shapes
        self._built: dict[int, ExactShape] = {}
        self._obs_built: dict[int, ExactShape] = {}
        self._mesh_mode = mesh_mode
        world_to_base = np.linalg.inv(model.scene.base_in_world.matrix())
        self._obs_pose = [np.eye(4) if ob is None or ob.frame is SceneFrame.BASE
                          else world_to_base for ob in model.obstacle_specs]
        cap_exact = [isinstance(s, Capsule | Sphere) for _, s in shapes]
        obs_exact = [ob is None or isinstance(ob.shape, Sphere | Capsule | Box)
                     for ob in model.obstacle_specs]
        needs = []
        for idx in range(model.pair_count):
            i, j, kind = model.pair_capsules(idx)
            other = cap_exact[j] if kind is ContactKind.SELF else obs_exact[j]
            needs.append(not (cap_exact[i] and other))
        #: Per checked pair: whether its capsules stand for other shapes (then it is measured).
        self.needs: np.ndarray = np.array(needs, dtype=bool)
        if self.needs.any():  # fail now, not mid-motion, without the library
            self._shape(model.pair_capsules(int(np.flatnonzero(self.needs)[0]))[0])

    def _shape(self, capsule: int) -> ExactShape:
        if capsule not in self._built:
            link, shape = self._cap_shapes[capsule]
            self._built[capsule] = exact_shape(shape, self._mesh_mode, link,
                                               self.model.model.spec.file)
        return self._built[capsule]

    def _obstacle(self, j: int) -> ExactShape:
        if j not in self._obs_built:
            ob = self.model.obstacle_specs[j]
            assert ob is not None
            self._obs_built[j] = exact_shape(ob.shape, self._mesh_mode, ob.name,
                                             self.model.scene.file)
        return self._obs_built[j]

    def distance(self, frames: Array, idx: int) -> float:
        """Exact distance between the shapes of checked pair ``idx`` [m] (negative: overlap).

        Args:
            frames: ``(m, 4, 4)`` poses of every frame of the arm (``fk_frames``).
            idx: The pair.
        """
        cm = self.model
        km = cm.model
        i, j, kind = cm.pair_capsules(idx)
        pose_i = frames[km.frame_index(cm.capsule_link(i))]
        if kind is ContactKind.SELF:
            pose_j = frames[km.frame_index(cm.capsule_link(j))]
            return signed_distance(self._shape(i), pose_i, self._shape(j), pose_j).distance
        ob = cm.obstacle_specs[j]
        if ob is None:
            assert cm.scene.table is not None
            return table_distance(cm.scene.table.height, self._shape(i), pose_i).distance
        return signed_distance(self._shape(i), pose_i, self._obstacle(j),
                               self._obs_pose[j]).distance

    def refine(self, q: Array, slacks: Array) -> Array:
        """``slacks`` with the exact slack of every measured pair whose capsules say contact."""
        todo = np.flatnonzero((slacks < 0.0) & self.needs)
        if not len(todo):
            return slacks
        frames = self.model.model.fk_frames(q)
        required = self.model.required()
        out = np.array(slacks, dtype=float)
        for idx in todo:
            out[idx] = max(out[idx], self.distance(frames, int(idx)) - required[idx])
        return out

    def first_problem(self, qs: Array, step: Array) -> tuple[int, int, int, float]:
        """Like the kernel ``samples_first_problem``, with the exact distances where measured.

        Returns:
            ``(status, i, pair, slack)``: 0 free and certified; 1 sample ``i`` in contact; 2
            the step from sample ``i`` not certified.
        """
        cm = self.model
        n = len(qs)
        if n == 0 or cm.pair_count == 0:
            return 0, -1, -1, 0.0
        sl = cm.slacks_batch(qs)
        for row in np.flatnonzero((sl < 0.0).any(axis=1)):
            sl[row] = self.refine(qs[row], sl[row])
        cap_move = np.asarray(step, dtype=float) @ cm.levers.T  # (n - 1, capsules)
        a = np.array([cm.pair_capsules(p)[0] for p in range(cm.pair_count)])
        b = np.array([cm.pair_capsules(p)[1] for p in range(cm.pair_count)])
        selfs = np.array([cm.pair_capsules(p)[2] is ContactKind.SELF
                          for p in range(cm.pair_count)])
        for r in range(n):
            k = int(np.argmin(sl[r]))
            if sl[r, k] < 0.0:
                return 1, r, k, float(sl[r, k])
            if r > 0:
                move = cap_move[r - 1, a] + np.where(selfs, cap_move[r - 1, np.where(selfs, b, 0)],
                                                     0.0)
                v = sl[r - 1] + sl[r] - move
                w = int(np.argmin(v))
                if v[w] < 0.0:
                    return 2, r - 1, w, float(min(sl[r - 1, w], sl[r, w]))
        return 0, -1, -1, 0.0
