"""Joint paths around obstacles: RRT-Connect searches and shortcutting of the path found.

Two searches give the same kind of answer, a list of joint vectors whose straight joint-space
segments are all free of collisions (each one checked continuously by the collision model):

* :func:`ompl_rrt_connect`: OMPL's RRT-Connect through its Python bindings (the ``plan`` extra);
* :func:`rrt_connect`: the same algorithm (two trees grown towards random samples and towards
  each other) in NumPy, seeded, so that a seed gives the same path every time. OMPL's bindings
  do not let a caller seed its planners' samplers per plan, so only this one is reproducible.

:func:`shortcut` then shortens a path by replacing stretches with straight segments that are
free, and drops the vertices it no longer needs.

Both work in the box of an arm of 1-DOF joints, and, given a :class:`JointSpace`, on the
configuration space of an arm with universal and ball joints (armctl's own search only): samples
by :meth:`~armctl.kinematics.model.KinematicModel.sample` (a ball joint's rotation uniform over
its limits), distances in the tangent space (a ball joint counts its geodesic angle [rad], as a
rotary joint counts its angle), steps and segments along
:meth:`~armctl.kinematics.model.KinematicModel.interpolate` (a ball joint on its shortest arc).
"""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.config.schema import JointType
from armctl.kinematics.model import KinematicModel
from armctl.motion.quaternions import conj, quat_exp, quat_log, quat_multiply
from armctl.typing import Array

__all__ = ["JointSpace", "SearchResult", "SegmentFree", "ompl_rrt_connect", "rrt_connect",
           "shortcut"]


#: ``segment_free(q0, q1)``: whether the straight joint-space segment from ``q0`` to ``q1``
#: (both ends included) is free of collisions.
SegmentFree = Callable[[Array, Array], bool]
#: ``state_free(q)``: whether one configuration is free of collisions.
StateFree = Callable[[Array], bool]

#: Step of a tree towards a sample, as a fraction of the diagonal of the joint box [-]
#: (OMPL's default range for RRT-Connect).
RANGE_FRACTION = 0.2
#: Vertices closer than this are merged [rad]/[m].
_SAME = 1e-9


@dataclass(frozen=True)
class SearchResult:
    """What a search found.

    Attributes:
        path: ``(n, dof)`` joint vectors from start to goal, or ``None`` if none was found in
            time.
        time: Wall time spent [s].
        states: How many configurations the trees hold at the end (both trees).
    """

    path: Array | None
    time: float
    states: int


def default_range(lower: Array, upper: Array) -> float:
    """The default step of the trees [rad]/[m]: :data:`RANGE_FRACTION` of the box diagonal."""
    return RANGE_FRACTION * float(np.linalg.norm(upper - lower))


class JointSpace:
    """The configuration space of an arm with ball joints, as the search moves in it.

    Scalar entries of ``q`` (1-DOF joints, a universal joint's angles) are sampled uniformly in
    a box (the limits; a turn around the start and goal for continuous joints) and measured and
    joined linearly; a ball joint's quaternion is sampled uniformly over the rotations inside its
    limits, measured by its geodesic angle ``2 acos |<q_a, q_b>|`` [rad] and joined on its
    shortest arc (slerp), as :meth:`KinematicModel.interpolate` joins it.

    Args:
        model: The arm.
        lower: Lowest values ``(nq,)`` of the scalar entries to sample (finite; the ball joints'
            entries are ignored).
        upper: Highest values ``(nq,)``.
    """

    def __init__(self, model: KinematicModel, lower: Array, upper: Array):
        self.model = model
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        balls = [model.q_index(i) for i, t in enumerate(model.joint_types)
                 if t is JointType.BALL]
        self.balls: tuple[slice, ...] = tuple(balls)
        mask = np.ones(model.nq, dtype=bool)
        for sl in balls:
            mask[sl] = False
        self.scalar: npt.NDArray[np.intp] = np.flatnonzero(mask)

    def sample(self, rng: np.random.Generator) -> Array:
        """A random configuration ``(nq,)``: scalar entries in the box, balls inside limits."""
        q = self.model.sample(rng)
        q[self.scalar] = rng.uniform(self.lower[self.scalar], self.upper[self.scalar])
        return q

    def distances(self, pts: Array, q: Array) -> Array:
        """Tangent-space distances ``(n,)`` of configurations ``(n, nq)`` from ``q`` ``(nq,)``."""
        d = pts[:, self.scalar] - q[self.scalar]
        out = np.einsum("ij,ij->i", d, d)
        for sl in self.balls:
            c = np.minimum(np.abs(pts[:, sl] @ q[sl]), 1.0)
            out += (2.0 * np.arccos(c)) ** 2
        return np.asarray(np.sqrt(out))

    def row_distances(self, a: Array, b: Array) -> Array:
        """Tangent-space distances ``(n,)`` between the rows of ``a`` and ``b`` ``(n, nq)``."""
        d = a[:, self.scalar] - b[:, self.scalar]
        out = np.einsum("ij,ij->i", d, d)
        for sl in self.balls:
            c = np.minimum(np.abs(np.einsum("ij,ij->i", a[:, sl], b[:, sl])), 1.0)
            out += (2.0 * np.arccos(c)) ** 2
        return np.asarray(np.sqrt(out))

    def distance(self, a: Array, b: Array) -> float:
        """The tangent-space distance of two configurations [rad]/[m]."""
        return float(self.distances(a[None, :], b)[0])

    def interpolate(self, a: Array, b: Array, u: float) -> Array:
        """The configuration a fraction ``u`` from ``a`` to ``b`` (balls on the shortest arc)."""
        return self.interpolate_many(a, b, np.array([u]))[0]

    def interpolate_many(self, a: Array, b: Array, us: Array) -> Array:
        """Configurations ``(n, nq)`` at fractions ``us`` ``(n,)`` from ``a`` to ``b``."""
        u = np.asarray(us, dtype=float)
        out = np.tile(a, (u.size, 1))
        out[:, self.scalar] = a[self.scalar] + u[:, None] * (b[self.scalar] - a[self.scalar])
        for sl in self.balls:
            rot = quat_log(quat_multiply(conj(a[sl]), b[sl]))
            quats = quat_multiply(a[sl], quat_exp(u[:, None] * rot))
            out[:, sl] = quats / np.linalg.norm(quats, axis=1, keepdims=True)
        return out


class _Tree:
    """Joint vectors with their parent's index, in a growing array."""

    def __init__(self, root: Array, capacity: int = 256):
        self.q = np.empty((capacity, root.size))
        self.parent = np.empty(capacity, dtype=np.int64)
        self.q[0] = root
        self.parent[0] = -1
        self.n = 1

    def add(self, q: Array, parent: int) -> int:
        if self.n == self.q.shape[0]:
            self.q = np.concatenate([self.q, np.empty_like(self.q)])
            self.parent = np.concatenate([self.parent, np.empty_like(self.parent)])
        self.q[self.n] = q
        self.parent[self.n] = parent
        self.n += 1
        return self.n - 1

    def nearest(self, q: Array, space: JointSpace | None = None) -> int:
        if space is not None:
            return int(np.argmin(space.distances(self.q[: self.n], q)))
        d = self.q[: self.n] - q
        return int(np.argmin(np.einsum("ij,ij->i", d, d)))

    def branch(self, i: int) -> list[Array]:
        """The vectors from the root to vertex ``i``."""
        out = []
        while i >= 0:
            out.append(self.q[i])
            i = int(self.parent[i])
        return out[::-1]


def _steer(a: Array, b: Array, step: float, space: JointSpace | None = None
           ) -> tuple[Array, bool]:
    """The point ``step`` from ``a`` towards ``b`` (``b`` when closer), and whether it is ``b``."""
    if space is not None:
        dist = space.distance(a, b)
        if dist <= step:
            return b, True
        return space.interpolate(a, b, step / dist), False
    d = b - a
    dist = float(np.sqrt(d @ d))
    if dist <= step:
        return b, True
    return a + d * (step / dist), False


def rrt_connect(start: Array, goal: Array, lower: Array, upper: Array,
                state_free: StateFree, segment_free: SegmentFree, deadline: float,
                rng: np.random.Generator, step: float | None = None,
                space: JointSpace | None = None) -> SearchResult:
    """RRT-Connect: two trees, from the start and from the goal, grown until they meet.

    Each round samples a configuration uniformly in the joint box, extends one tree by one step
    towards it and, if that step is free, grows the other tree towards the new vertex for as
    long as its steps are free; then the trees swap roles. Start and goal must be free.

    Args:
        start: Start ``(dof,)`` [rad]/[m].
        goal: Goal ``(dof,)``.
        lower: Lowest joint values ``(dof,)`` (finite).
        upper: Highest joint values ``(dof,)`` (finite).
        state_free: The check of one configuration.
        segment_free: The continuous check of a straight segment.
        deadline: ``time.perf_counter()`` value at which to give up [s].
        rng: The random generator (seeded by the caller).
        step: Longest step of a tree [rad]/[m]; ``None``: :func:`default_range`.
        space: The configuration space of an arm with ball joints (``None``: the box of an
            arm of 1-DOF joints, ``start`` and ``goal`` of ``dof`` entries). With it, ``lower``
            and ``upper`` bound the scalar entries, and :func:`default_range` is taken over
            the scalar entries' box and pi per ball joint.

    Returns:
        The path (start and goal included), or no path when the deadline passed.
    """
    t0 = time.perf_counter()
    if step is None:
        step = (default_range(lower, upper) if space is None
                else RANGE_FRACTION * math.hypot(
                    float(np.linalg.norm(space.upper[space.scalar] - space.lower[space.scalar])),
                    math.pi * math.sqrt(len(space.balls))))
    trees = (_Tree(np.asarray(start, dtype=float)), _Tree(np.asarray(goal, dtype=float)))
    grow, other = 0, 1
    while time.perf_counter() < deadline:
        sample = rng.uniform(lower, upper) if space is None else space.sample(rng)
        a = trees[grow]
        i = a.nearest(sample, space)
        q, _ = _steer(a.q[i], sample, step, space)
        if not (state_free(q) and segment_free(a.q[i], q)):
            grow, other = other, grow
            continue
        new = a.add(q, i)
        b = trees[other]
        # Connect: the other tree walks towards the new vertex while its steps are free.
        j = b.nearest(q, space)
        while True:
            qb, reached = _steer(b.q[j], q, step, space)
            if not ((reached or state_free(qb)) and segment_free(b.q[j], qb)):
                break
            if reached:
                left, right = a.branch(new), b.branch(j)
                if grow == 1:
                    left, right = right, left
                path = np.array(left + right[::-1])
                return SearchResult(path, time.perf_counter() - t0, trees[0].n + trees[1].n)
            j = b.add(qb, j)
        grow, other = other, grow
    return SearchResult(None, time.perf_counter() - t0, trees[0].n + trees[1].n)


def ompl_rrt_connect(start: Array, goal: Array, lower: Array, upper: Array,
                     state_free: StateFree, segment_free: SegmentFree, budget: float,
                     step: float | None = None) -> SearchResult:
    """OMPL's RRT-Connect with the same checks (the motion validator is the continuous check).

    Args:
        start: Start ``(dof,)`` [rad]/[m].
        goal: Goal ``(dof,)``.
        lower: Lowest joint values ``(dof,)`` (finite).
        upper: Highest joint values ``(dof,)`` (finite).
        state_free: The check of one configuration.
        segment_free: The continuous check of a straight segment.
        budget: Time allowed [s].
        step: Longest step of a tree [rad]/[m]; ``None``: OMPL's default (the same as
            :func:`default_range`).

    Returns:
        The path, or no path when none was found within the budget.

    Raises:
        ImportError: If OMPL is not installed.
    """
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    t0 = time.perf_counter()
    ou.setLogLevel(ou.LOG_NONE)  # OMPL prints to the terminal; armctl reports through errors
    dof = int(start.size)
    space = ob.RealVectorStateSpace(dof)
    bounds = ob.RealVectorBounds(dof)
    for k in range(dof):
        bounds.setLow(k, float(lower[k]))
        bounds.setHigh(k, float(upper[k]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)

    def valid(state: object) -> bool:
        return state_free(np.array(state[0:dof]))  # type: ignore[index]

    class _Segments(ob.MotionValidator):
        def checkMotion(self, s1: object, s2: object) -> bool:
            return segment_free(np.array(s1[0:dof]), np.array(s2[0:dof]))  # type: ignore[index]

    si.setStateValidityChecker(valid)
    validator = _Segments(si)
    si.setMotionValidator(validator)
    si.setup()
    pdef = ob.ProblemDefinition(si)
    s = si.allocState()
    g = si.allocState()
    s[0:dof] = [float(v) for v in start]
    g[0:dof] = [float(v) for v in goal]
    pdef.setStartAndGoalStates(s, g)
    planner = og.RRTConnect(si)
    if step is not None:
        planner.setRange(float(step))
    planner.setProblemDefinition(pdef)
    planner.setup()
    status = planner.solve(max(budget - (time.perf_counter() - t0), 1e-3))
    path = None
    if pdef.hasExactSolution():
        states = pdef.getSolutionPath().getStates()
        path = np.array([st[0:dof] for st in states], dtype=float)
    data = ob.PlannerData(si)
    planner.getPlannerData(data)
    n = int(data.numVertices())
    del status  # the states belong to Python (freeing them here would free them twice)
    return SearchResult(path, time.perf_counter() - t0, n)


def _steps(pts: Array, space: JointSpace | None) -> Array:
    """Lengths ``(n - 1,)`` of a path's segments."""
    if space is None:
        return np.asarray(np.linalg.norm(np.diff(pts, axis=0), axis=1))
    return np.array([space.distance(a, b) for a, b in itertools.pairwise(pts)])


def _lengths(pts: Array, space: JointSpace | None = None) -> Array:
    if space is None:
        return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    return np.concatenate([[0.0], np.cumsum(_steps(pts, space))])


def _point_at(pts: Array, cum: Array, s: float, space: JointSpace | None = None
              ) -> tuple[int, Array]:
    """The segment index ``i`` holding arc length ``s`` and the point there."""
    i = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, pts.shape[0] - 2))
    h = cum[i + 1] - cum[i]
    u = 0.0 if h <= 0.0 else (s - cum[i]) / h
    if space is not None:
        return i, space.interpolate(pts[i], pts[i + 1], min(max(u, 0.0), 1.0))
    return i, pts[i] + (pts[i + 1] - pts[i]) * min(max(u, 0.0), 1.0)


def _dedupe(pts: Array, space: JointSpace | None = None) -> Array:
    keep = np.concatenate([[True], _steps(pts, space) > _SAME])
    keep[-1] = True
    out = pts[keep]
    if out.shape[0] >= 2 and _steps(out[-2:], space)[0] <= _SAME:
        out = np.delete(out, -2, axis=0)
    return out


def reduce_vertices(pts: Array, segment_free: SegmentFree, deadline: float) -> Array:
    """Greedy: from each kept vertex, jump to the farthest later vertex in free sight."""
    out = [pts[0]]
    i = 0
    n = pts.shape[0]
    while i < n - 1:
        j = i + 1
        for k in range(n - 1, i + 1, -1):
            if time.perf_counter() > deadline:
                break
            if segment_free(pts[i], pts[k]):
                j = k
                break
        out.append(pts[j])
        i = j
    return np.array(out)


def shortcut(path: Array, segment_free: SegmentFree, rng: np.random.Generator,
             deadline: float, attempts: int | None = None, space: JointSpace | None = None
             ) -> Array:
    """A shorter path: free straight segments between points of the path replace stretches.

    First each vertex is joined to the farthest later vertex that it sees (a free straight
    segment); then pairs of random points along the path are joined where the segment between
    them is free; last, vertices whose neighbours see each other are dropped. Every segment of
    the result has been checked free, or lies on a segment that was.

    Args:
        path: ``(n, dof)`` joint vectors whose segments are free.
        segment_free: The continuous check of a straight segment.
        rng: The random generator (seeded by the caller).
        deadline: ``time.perf_counter()`` value at which to stop [s] (the path so far is kept).
        attempts: Random pairs to try; ``None``: ``max(20, 4 n)`` for ``n`` vertices.
        space: The configuration space of an arm with ball joints (lengths in the tangent
            space, points along the shortest arcs); ``None``: the box of 1-DOF joints.

    Returns:
        The shorter path, with the same first and last vertex.
    """
    pts = _dedupe(np.asarray(path, dtype=float), space)
    if pts.shape[0] <= 2:
        return pts
    pts = reduce_vertices(pts, segment_free, deadline)
    tries = max(20, 4 * pts.shape[0]) if attempts is None else attempts
    for _ in range(tries):
        if pts.shape[0] <= 2 or time.perf_counter() > deadline:
            break
        cum = _lengths(pts, space)
        total = float(cum[-1])
        s1, s2 = np.sort(rng.uniform(0.0, total, 2))
        i, p1 = _point_at(pts, cum, float(s1), space)
        j, p2 = _point_at(pts, cum, float(s2), space)
        if j <= i:
            continue  # on one segment: already straight
        # Only worth it if it saves length (the bend between them is not already straight).
        old = (cum[i + 1] - s1) + (s2 - cum[j]) + (cum[j] - cum[i + 1])
        direct = (float(np.linalg.norm(p2 - p1)) if space is None
                  else space.distance(p1, p2))
        if direct >= old * (1.0 - 1e-6):
            continue
        if segment_free(p1, p2):
            pts = _dedupe(np.vstack([pts[: i + 1], p1, p2, pts[j + 1:]]), space)
    # Drop vertices that the shortcuts made unnecessary.
    k = 1
    while k < pts.shape[0] - 1 and time.perf_counter() <= deadline:
        if segment_free(pts[k - 1], pts[k + 1]):
            pts = np.delete(pts, k, axis=0)
        else:
            k += 1
    return pts


def path_length(path: Array, space: JointSpace | None = None) -> float:
    """Length of a joint path, the sum of its segments' lengths [rad]/[m].

    Euclidean, or in the tangent space of ``space`` (a ball joint's geodesic angle).
    """
    return float(_lengths(np.asarray(path, dtype=float), space)[-1]) if len(path) > 1 else 0.0


def finite_box(lower: Array, upper: Array, *points: Array) -> tuple[Array, Array]:
    """Joint bounds to sample in: the limits, with a turn around the points for unlimited joints.

    Continuous joints (infinite limits) get a box of one turn either side of the given
    configurations; every box is widened to hold the points themselves.
    """
    pts = np.vstack(points)
    lo = np.where(np.isfinite(lower), lower, pts.min(axis=0) - math.pi)
    hi = np.where(np.isfinite(upper), upper, pts.max(axis=0) + math.pi)
    return np.minimum(lo, pts.min(axis=0)), np.maximum(hi, pts.max(axis=0))
