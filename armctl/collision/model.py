"""The collision model of an arm in its scene: which pairs are checked, and the checks.

:class:`CollisionModel` covers every link with the capsules of
:mod:`armctl.kinematics.capsules` (conservative: each contains the shape it stands for), turns
the scene (the table, boxes, spheres, capsules; cylinders as the capsule around them, meshes
as the box around their vertices along their principal axes) into primitives, and leaves out
the pairs of the allowed-collision matrix (:mod:`armctl.collision.allowed`). A configuration
is free when every checked pair keeps its padding: the scene's padding between a link and an
obstacle or the table, none between two links.

Motions are checked continuously, not only at samples: a point of a link moves no farther than
its lever arms times the joints' travel (an upper bound over every configuration), so a pair
whose distances at the two ends of a step add up to more than how far the pair can move over
the step cannot touch in between. Steps that this cannot certify are split until they can, or
until the contact is found.
"""

from __future__ import annotations

import copy
import logging
import math
import weakref
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from armctl.collision import _kernels as K
from armctl.collision.contact import Clearance, Contact, ContactKind
from armctl.collision.errors import SceneError
from armctl.collision.primitives import PrimitiveKind, obstacle_primitive
from armctl.config.scene import TABLE, CollisionSpec, Obstacle, SceneSpec
from armctl.config.schema import JointType
from armctl.errors import InputError
from armctl.kinematics.capsules import collision_capsules
from armctl.kinematics.compiled_tree import JOINT_COLUMNS
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.collision.narrow import ExactPairs

__all__ = ["CollisionModel", "Refine", "register_finder", "scene_of"]

logger = logging.getLogger(__name__)

#: Default scene when an arm has no ``scene:`` section: a table at the base, 5 mm padding.
_DEFAULT_SCENE = SceneSpec()

#: Refines a step of a sampled motion: given the times of its two ends, denser samples of it
#: ``(ts, qs, step)`` (both ends included; see :meth:`CollisionModel.first_contact_on_samples`).
Refine = Callable[[float, float], tuple[Array, Array, Array]]

#: How much deeper than at its start a pair that starts in contact may go [m].
ESCAPE = 1e-3

#: Capsule travel [m] below which a step that cannot be certified counts as a contact.
RESOLUTION = 1e-5


#: Finds the allowed-collision matrix of an arm whose file has none (by sampling). Registered by
#: :mod:`armctl.collision.allowed` (imported with the package) with :func:`register_finder`, so
#: that this module, which that one builds on, does not import it.
_FINDER: list[Callable[[KinematicModel, SceneSpec], CollisionSpec]] = []


def register_finder(finder: Callable[[KinematicModel, SceneSpec], CollisionSpec]) -> None:
    """Set how :meth:`CollisionModel.of` finds the matrix of an arm whose file has none."""
    _FINDER[:] = [finder]


def scene_of(model: KinematicModel) -> SceneSpec:
    """The arm's scene: its ``scene:`` section, or a table at the base with 5 mm padding."""
    return model.spec.scene if model.spec.scene is not None else _DEFAULT_SCENE


@dataclass(frozen=True)
class _Prim:
    kind: int
    data: tuple[float, ...]
    centre: tuple[float, float, float]
    radius: float


def _primitive(ob: Obstacle, world_to_base: Array, config: Any) -> _Prim:
    """An obstacle as a kernel primitive in the base frame (conservative for cylinders, meshes)."""
    p = obstacle_primitive(ob, world_to_base, config)
    c = tuple(float(v) for v in p.centre)
    if p.kind is PrimitiveKind.SPHERE:
        return _Prim(K.K_SPHERE, (*p.centre, p.radius), c, p.radius)  # type: ignore[arg-type]
    if p.kind is PrimitiveKind.CAPSULE:
        return _Prim(K.K_CAPSULE, (*p.a, *p.b, p.radius), c,  # type: ignore[arg-type]
                     p.bounding_radius)
    return _Prim(K.K_BOX, (*p.rotation.reshape(-1), *p.centre, *p.half), c,  # type: ignore[arg-type]
                 p.bounding_radius)


class CollisionModel:
    """An arm, its scene and its allowed-collision matrix, packed for the compiled checks.

    Build one with :meth:`of`. Every method takes joint vectors ``q`` of ``model.nq`` entries
    in [rad]/[m] (a universal joint's two angles, a ball joint's unit quaternion ``w, x, y,
    z``: the layout of :class:`~armctl.kinematics.model.KinematicModel`) and gives distances
    in [m]; joint travels of motions are per tangent entry (``model.nv``).

    Attributes:
        model: The arm.
        scene: The scene checked against.
        allowed: The allowed-collision matrix in force.
        links: The links that have capsules, in capsule-owner order.
        obstacles: The obstacle names (``"table"`` first when there is a table).
    """

    def __init__(self, model: KinematicModel, scene: SceneSpec, allowed: CollisionSpec):
        self.model = model
        self.scene = scene
        self.allowed = allowed
        tree = model.tree
        n = len(model.joint_names)  # joints; q has model.nq entries, tangents model.nv
        nv = model.nv
        spec = model.spec
        allowed_keys = {p.key for p in allowed.allowed}

        # capsules in the frames of the joints that carry them (-1: the base)
        links: list[str] = []
        cap_link: list[int] = []
        cap_body: list[int] = []
        cap_rows: list[list[float]] = []
        for name, caps in collision_capsules(spec).items():
            k = model.frame_index(name)
            body = int(tree.anchor[k])
            off = tree.frame_offset(k)
            links.append(name)
            for cap in caps:
                a = off[:3, :3] @ np.asarray(cap.a) + off[:3, 3]
                b = off[:3, :3] @ np.asarray(cap.b) + off[:3, 3]
                cap_link.append(len(links) - 1)
                cap_body.append(body)
                cap_rows.append([*a, *b, cap.radius])
        self.links = tuple(links)
        self._cap_link = np.asarray(cap_link, dtype=np.int64)
        self._cap_body = np.asarray(cap_body, dtype=np.int64)
        kcap = len(cap_rows)

        # obstacles
        world_to_base = np.asarray(np.linalg.inv(scene.base_in_world.matrix()), dtype=np.float64)
        prims: list[_Prim] = []
        names: list[str] = []
        if scene.table is not None:
            roots = [j for j in range(n) if tree.parent[j] < 0]
            lowest = min((float(tree.joint_origin(j)[2, 3]) for j in roots), default=math.inf)
            if scene.table.height > lowest:
                raise SceneError(
                    f"the table top (z={scene.table.height:g} m in the arm's base frame) is above "
                    f"the arm's first joint (z={lowest:g} m): the arm would stand inside the "
                    "table. The height is in the base frame (about 0 for an arm standing on the "
                    "table; a world height belongs to base_in_world)")
            prims.append(_Prim(K.K_TABLE, (scene.table.height,), (0.0, 0.0, 0.0), math.inf))
            names.append(TABLE)
        for ob in scene.obstacles:
            if ob.name in names:
                raise SceneError(f"obstacle name {ob.name!r} is used twice in the scene; give "
                                 "each obstacle its own name")
            prims.append(_primitive(ob, world_to_base, scene.file or spec.file))
            names.append(ob.name)
        self.obstacles = tuple(names)
        #: The scene's obstacles in the order of :attr:`obstacles` (``None`` for the table).
        self.obstacle_specs: tuple[Obstacle | None, ...] = (
            ((None,) if scene.table is not None else ()) + tuple(scene.obstacles))

        # pairs
        self_pairs = [(i, j) for i in range(kcap) for j in range(i + 1, kcap)
                      if cap_link[i] != cap_link[j]
                      and not (cap_body[i] < 0 and cap_body[j] < 0)
                      and frozenset((links[cap_link[i]], links[cap_link[j]])) not in allowed_keys]
        scene_pairs = [(c, o) for c in range(kcap) for o in range(len(prims))
                       if not (cap_body[c] < 0 and prims[o].kind == K.K_TABLE)
                       and frozenset((links[cap_link[c]], names[o])) not in allowed_keys]
        self._pairs: list[tuple[int, int, ContactKind]] = (
            [(i, j, ContactKind.SELF) for i, j in self_pairs]
            + [(c, o, ContactKind.SCENE) for c, o in scene_pairs])

        # levers: how far a point of each capsule moves per unit travel of each tangent entry
        # (a universal joint's two angles, a ball joint's three angular velocity components in
        # its moved frame: a rotation by a vector turns a point by at most its length, which is
        # at most the sum of its components' magnitudes)
        lever = np.zeros((kcap, nv))
        for c in range(kcap):
            body = cap_body[c]
            if body < 0:
                continue
            chain: list[int] = []
            j = body
            while j >= 0:
                chain.append(j)
                j = int(tree.parent[j])
            chain.reverse()
            ends = max(float(np.linalg.norm(cap_rows[c][0:3])),
                       float(np.linalg.norm(cap_rows[c][3:6])))
            for pos, j in enumerate(chain):
                cols = model.v_index(j)
                if tree.is_prismatic(j):
                    lever[c, cols] = 1.0
                    continue
                reach = ends
                for m in chain[pos + 1:]:
                    reach += float(np.linalg.norm(tree.joint_origin(m)[:3, 3]))
                    if tree.is_prismatic(m):
                        at = model.q_index(m).start
                        travel = max(abs(tree.lower[at]), abs(tree.upper[at]))
                        reach += travel if math.isfinite(travel) else 10.0
                lever[c, cols] = reach

        # pack
        width = max(K.WIDTH, nv)
        nobs = len(prims)
        cap0 = n
        lev0 = cap0 + kcap
        obs0 = lev0 + kcap
        misc = obs0 + nobs
        npairs = len(self._pairs)
        alw0 = misc + 1
        f = np.zeros((alw0 + max(1, -(-npairs // width)), width))
        f[:n, :JOINT_COLUMNS] = tree.joints  # whole rows: multi-DOF joints step with all
        for c, row in enumerate(cap_rows):
            f[cap0 + c, :7] = row
        f[lev0:lev0 + kcap, :nv] = lever
        #: ``(capsules, nv)``: how far a point of each capsule moves per unit travel of each
        #: tangent entry, an upper bound over every configuration ([m/rad]; 1 for prismatic
        #: joints; a universal joint has two columns, a ball joint three).
        self.levers: Array = lever
        self.levers.setflags(write=False)
        for o, p in enumerate(prims):
            f[obs0 + o, :len(p.data)] = p.data
            f[obs0 + o, K.BOUND:K.BOUND + 3] = p.centre
            f[obs0 + o, K.BOUND + 3] = p.radius
            f[obs0 + o, K.AABB:K.AABB + 6] = K.obstacle_aabb(p.kind, p.data)
        f[misc, 0] = scene.padding
        f[misc, 1] = 0.0
        head = np.zeros(K.HEADER, dtype=np.int64)
        blocks = [np.asarray(tree.parent, dtype=np.int64), self._cap_body,
                  np.asarray(self_pairs, dtype=np.int64).reshape(-1),
                  np.asarray([p.kind for p in prims], dtype=np.int64),
                  np.asarray(scene_pairs, dtype=np.int64).reshape(-1),
                  K.pair_records(tree.parent, self._cap_body, self_pairs, scene_pairs,
                                 [p.kind for p in prims])]
        head[[K.H_N, K.H_K, K.H_P, K.H_O, K.H_S]] = n, kcap, len(self_pairs), nobs, len(scene_pairs)
        head[[K.H_CAP, K.H_LEV, K.H_OBS, K.H_MISC, K.H_ALW]] = cap0, lev0, obs0, misc, alw0
        at = K.HEADER
        for key, block in zip((K.H_PAR, K.H_CB, K.H_SP, K.H_OK, K.H_OP, K.H_ORD), blocks,
                              strict=True):
            head[key] = at
            at += block.size
        self._F = np.ascontiguousarray(f)
        self._I = np.concatenate([head, *blocks]).astype(np.int64)
        self._F.setflags(write=False)
        self._I.setflags(write=False)
        self._scratch = np.empty(max(len(self._pairs), 1))
        #: Whether a line between configurations has arcs (ball joints: slerp).
        self._arcs = any(t is JointType.BALL for t in model.joint_types)
        #: The exact narrow phase (with the scene's ``exact``), else ``None``.
        self.exact: ExactPairs | None = None
        if scene.exact:
            from armctl.collision.narrow import ExactPairs

            self.exact = ExactPairs(self)

    # ---- construction -------------------------------------------------------------------------
    @classmethod
    def of(cls, model: KinematicModel, scene: SceneSpec | None = None,
           allowed: CollisionSpec | None = None) -> CollisionModel:
        """The collision model of an arm (cached per arm, scene and matrix).

        Args:
            model: The arm.
            scene: The scene; ``None``: the arm's ``scene:`` section, else a table at the base
                with 5 mm padding.
            allowed: The allowed-collision matrix; ``None``: the arm's ``collision:`` section,
                else one found by sampling (logged; ``armctl collisions CONFIG --generate``
                writes one into the file).

        Raises:
            SceneError: An obstacle name used twice.
            MeshLoadError: A mesh file that cannot be read.
        """
        sc = scene_of(model) if scene is None else scene
        if allowed is not None:
            acm = allowed
        elif model.spec.collision is not None:
            acm = model.spec.collision
        elif _FINDER:
            acm = _FINDER[0](model, sc)
        else:  # pragma: no cover - the package's __init__ registers the finder
            raise RuntimeError("import armctl.collision (it registers the matrix finder)")
        per_model = _CACHE.setdefault(model, {})
        key = (id(sc), id(acm))
        hit = per_model.get(key)
        if hit is not None and hit.scene is sc and hit.allowed is acm:
            return hit
        out = cls(model, sc, acm)
        per_model[key] = out
        return out

    def escaping(self, q: npt.ArrayLike) -> CollisionModel:
        """This model, letting the pairs in contact at ``q`` get out of contact.

        A motion that starts with a pair in contact (an arm put down on the table with torque
        off, hand-guided into itself) could not move at all under :meth:`free`. The model
        returned allows each such pair the depth it has at ``q`` plus :data:`ESCAPE`: it may
        separate, never go deeper. Every other pair keeps its padding.
        """
        qq = self._q(q)
        sl = self.slacks(qq)
        if self.exact is not None and len(sl):
            sl = self.exact.refine(qq, sl)
        if not len(sl) or float(sl.min()) >= 0.0:
            return self
        out = copy.copy(self)
        f = np.array(self._F)
        w = f.shape[1]
        row0 = int(self._I[K.H_ALW])
        for idx in np.flatnonzero(sl < 0.0):
            f[row0 + int(idx) // w, int(idx) % w] = -float(sl[idx]) + ESCAPE
        f.setflags(write=False)
        out._F = f
        if self.exact is not None:
            out.exact = copy.copy(self.exact)
            out.exact.model = out
        return out

    def required(self) -> Array:
        """Per checked pair, the distance it must keep [m]: its padding less its allowance."""
        n = len(self._pairs)
        w = self._F.shape[1]
        row0 = int(self._I[K.H_ALW])
        allow = self._F[row0:row0 + max(1, -(-n // w))].reshape(-1)[:n]
        pads = np.array([self._padding(kind) for _, _, kind in self._pairs])
        return pads - allow

    # ---- names --------------------------------------------------------------------------------
    @property
    def pair_count(self) -> int:
        """How many pairs are checked (link-link and link-obstacle)."""
        return len(self._pairs)

    @property
    def packed(self) -> tuple[Array, npt.NDArray[np.int64]]:
        """The read-only arrays ``(F, I)`` the kernels take (:mod:`armctl.collision._kernels`)."""
        return self._F, self._I

    def pair_capsules(self, idx: int) -> tuple[int, int, ContactKind]:
        """Checked pair ``idx`` as indices: ``(capsule, capsule or obstacle, kind)``."""
        return self._pairs[idx]

    def capsule_link(self, capsule: int) -> str:
        """The link a capsule covers."""
        return self.links[int(self._cap_link[capsule])]

    def pair_names(self, idx: int) -> tuple[str, str, ContactKind]:
        """The names of checked pair ``idx``: ``(link, link or obstacle, kind)``."""
        i, j, kind = self._pairs[idx]
        a = self.links[int(self._cap_link[i])]
        b = self.links[int(self._cap_link[j])] if kind is ContactKind.SELF else self.obstacles[j]
        return a, b, kind

    def _padding(self, kind: ContactKind) -> float:
        return self.scene.padding if kind is ContactKind.SCENE else 0.0

    def _contact(self, idx: int, slack: float, q: Array, time: float | None) -> Contact:
        a, b, kind = self.pair_names(idx)
        pad = self._padding(kind)
        return Contact(kind, a, b, float(slack) + pad, pad, np.array(q, dtype=float), time,
                       idx)

    # ---- one configuration --------------------------------------------------------------------
    def _q(self, q: npt.ArrayLike) -> Array:
        return self.model.as_q(q)

    def _exact_least(self, q: Array) -> tuple[float, int]:
        """The least slack and its pair, with the exact narrow phase (``exact`` is set)."""
        assert self.exact is not None
        sl = self.exact.refine(q, self.slacks(q))
        if not len(sl):
            return math.inf, -1
        k = int(np.argmin(sl))
        return float(sl[k]), k

    def clearance(self, q: npt.ArrayLike) -> Clearance | None:
        """The checked pair with the least room at ``q`` (``None`` when nothing is checked).

        With the exact narrow phase, pairs whose capsules overlap are measured between their
        real shapes; the others report their capsules' distance (a lower bound).
        """
        qq = self._q(q)
        if self.exact is not None:
            slack, idx = self._exact_least(qq)
            dist = slack + float(self.required()[idx]) if idx >= 0 else math.inf
        else:
            _, idx, dist = K.min_slack(qq, self._F, self._I, -math.inf)
        if idx < 0:
            return None
        a, b, kind = self.pair_names(int(idx))
        return Clearance(float(dist), self._padding(kind), a, b, kind)

    def contact(self, q: npt.ArrayLike) -> Contact | None:
        """The pair deepest inside its padding at ``q``, or ``None`` when ``q`` is free."""
        qq = self._q(q)
        if self.exact is not None:
            slack, idx = self._exact_least(qq)
        else:
            slack, idx, _ = K.min_slack(qq, self._F, self._I, -math.inf)
        if idx < 0 or slack >= 0.0:
            return None
        return self._contact(int(idx), slack, qq, None)

    def free(self, q: npt.ArrayLike) -> bool:
        """Whether no checked pair at ``q`` is closer than its padding."""
        qq = self._q(q)
        slack, _, _ = K.min_slack(qq, self._F, self._I, 0.0)
        if slack < 0.0 and self.exact is not None:
            slack, _ = self._exact_least(qq)
        return bool(slack >= 0.0)

    def free_batch(self, qs: npt.ArrayLike) -> npt.NDArray[np.bool_]:
        """:meth:`free` for each row of ``qs`` ``(N, nq)``.

        Rows are not checked as :meth:`free` checks ``q`` (a ball joint's quaternion is used
        as its rotation whatever its norm); a row with a NaN or infinite value is not free.
        """
        arr = np.ascontiguousarray(qs, dtype=np.float64).reshape(-1, self.model.nq)
        out = np.empty(arr.shape[0], dtype=np.bool_)
        K.free_batch(arr, self._F, self._I, out)
        if self.exact is not None:
            for r in np.flatnonzero(~out):
                out[r] = self._exact_least(arr[r])[0] >= 0.0
        return out

    def slacks(self, q: npt.ArrayLike) -> Array:
        """Every checked pair's distance minus its padding at ``q`` [m] (see :meth:`pair_names`)."""
        out = np.empty(len(self._pairs))
        K.slacks(self._q(q), self._F, self._I, out)
        return out

    def slacks_batch(self, qs: npt.ArrayLike) -> Array:
        """:meth:`slacks` for each row of ``qs`` ``(N, nq)``: ``(N, pairs)``."""
        arr = np.ascontiguousarray(qs, dtype=np.float64).reshape(-1, self.model.nq)
        out = np.empty((arr.shape[0], len(self._pairs)))
        K.slacks_batch(arr, self._F, self._I, out)
        return out

    # ---- motions ------------------------------------------------------------------------------
    def first_contact_on_segment(self, q0: npt.ArrayLike, q1: npt.ArrayLike) -> Contact | None:
        """The first contact on the straight joint-space line ``q0``-``q1``, or ``None``.

        Checked continuously: no contact can hide between the points checked. ``time`` of the
        contact is the fraction of the line [0-1]. A ball joint follows the shortest arc
        between its two rotations (:meth:`~armctl.kinematics.model.KinematicModel.interpolate`).
        """
        a, b = self._q(q0), self._q(q1)
        if self.exact is not None or self._arcs:
            return self._sampled_segment(a, b)
        u, idx, slack = K.segment_first_contact(a, b, self._F, self._I, RESOLUTION)
        if u < 0.0:
            return None
        return self._contact(int(idx), slack, a + u * (b - a), float(u))

    def _sampled_segment(self, a: Array, b: Array) -> Contact | None:
        """:meth:`first_contact_on_segment` through the sampled check.

        For the exact narrow phase, and for arms with ball joints (whose line is the shortest
        arc, which the compiled bisection does not follow).
        """
        km = self.model
        if self._arcs:
            tangent = km.difference(a, b)
            span = np.abs(tangent)

            def at(us: Array) -> Array:
                return np.array([km.integrate(a, u * tangent) for u in us])
        else:
            span = np.abs(b - a)

            def at(us: Array) -> Array:
                return np.asarray(a + us[:, None] * (b - a), dtype=float)

        def refine(u0: float, u1: float) -> tuple[Array, Array, Array]:
            us = np.linspace(u0, u1, 9)
            return us, at(us), np.tile(span * (us[1] - us[0]), (8, 1))

        return self.first_contact_on_samples(*refine(0.0, 1.0), refine, depth=24)

    def segment_free(self, q0: npt.ArrayLike, q1: npt.ArrayLike) -> bool:
        """Whether the straight joint-space line ``q0``-``q1`` is free (continuously)."""
        if self.exact is not None or self._arcs:
            return self.first_contact_on_segment(q0, q1) is None
        u, _, _ = K.segment_first_contact(self._q(q0), self._q(q1), self._F, self._I,
                                          RESOLUTION)
        return bool(u < 0.0)

    def first_contact_on_samples(self, ts: npt.ArrayLike, qs: npt.ArrayLike,
                                 step: npt.ArrayLike, refine: Refine | None = None,
                                 depth: int = 8) -> Contact | None:
        """The first contact along a sampled motion, checked continuously, or ``None``.

        Args:
            ts: ``(N,)`` sample times [s].
            qs: ``(N, nq)`` samples.
            step: ``(N - 1, nv)``: per step between samples an upper bound of how far each
                tangent entry travels (the length of its path) [rad]/[m]; for a ball joint,
                of each component of its angular velocity in its moved frame (the integral
                of its magnitude over the step).
            refine: Gives denser samples of a step that its end samples cannot certify;
                ``None``: such a step counts as a contact.
            depth: How many times a step may be refined.

        Returns:
            The first contact (its time, pair and depth), else ``None``.
        """
        t = np.asarray(ts, dtype=np.float64)
        q = np.ascontiguousarray(qs, dtype=np.float64).reshape(len(t), self.model.nq)
        s = np.ascontiguousarray(step, dtype=np.float64).reshape(max(len(t) - 1, 0),
                                                                 self.model.nv)
        if not (np.isfinite(q).all() and np.isfinite(s).all() and np.isfinite(t).all()):
            raise InputError("a motion to check has a NaN or infinite sample; every joint value "
                             "and travel must be a finite number")
        start = 0
        while start < len(t):
            if self.exact is not None:
                status, i, idx, slack = self.exact.first_problem(q[start:], s[start:])
            else:
                status, i, idx, slack = K.samples_first_problem(q[start:], s[start:], self._F,
                                                                self._I)
            if status == 0:
                return None
            i += start
            if status == 1 and i == 0:
                return self._contact(int(idx), slack, q[0], float(t[0]))
            lo = i - 1 if status == 1 else i
            if refine is not None and depth > 0:
                ft, fq, fs = refine(float(t[lo]), float(t[lo + 1]))
                found = self.first_contact_on_samples(ft, fq, fs, refine, depth - 1)
                if found is not None:
                    return found
                if status == 1:  # the refined step ends in contact at sample i (found above)
                    return self._contact(int(idx), slack, q[i], float(t[i]))  # pragma: no cover
                start = lo + 1
                continue
            at = i if status == 1 else lo + 1
            return self._contact(int(idx), min(slack, 0.0) if status == 1 else slack, q[at],
                                 float(t[at]))
        return None


_CACHE: weakref.WeakKeyDictionary[KinematicModel, dict[tuple[int, int], CollisionModel]] = (
    weakref.WeakKeyDictionary())
