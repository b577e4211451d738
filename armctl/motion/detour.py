"""A way around: a collision-free joint path from start to goal, timed and checked before motion.

:func:`plan_detour` searches a path with RRT-Connect (OMPL's, or armctl's own, reproducible one of
:mod:`armctl.motion.rrt_connect`), every straight segment of it checked continuously by the
collision model; shortens it by shortcutting; times it under the velocity, acceleration and
jerk limits; and checks the timed trajectory again, continuously (the model bounds how far every
link moves between two samples from the joints' travel between them), and against the limits.
Where the timing blends past a vertex and the blend cuts into an obstacle, the arm stops at that
vertex instead (then it follows the checked segments exactly), so the result is either free or
refused; a refused plan moves nothing.

An arm with universal and ball joints is searched on its configuration space
(:class:`~armctl.motion.rrt_connect.JointSpace`, armctl's own RRT-Connect: OMPL's is given only
vector spaces here): samples inside the limits (a ball joint's swing cone and twist range),
distances in the tangent space, every segment along the shortest arc of each ball joint, checked
continuously by the collision model along that arc and against the ball joints' limits at
samples no more than :data:`LIMIT_SPACING` apart. The path is timed by
:func:`~armctl.motion.multi_dof.plan_layout_run`: with :attr:`Interpolation.LINEAR` each ball
joint turns on the great circle of each segment and rests at every vertex (the axis of its turn
changes there), the scalar coordinates blend through the vertices unless a blend collides.
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, replace
from enum import Enum
from typing import Protocol

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError, PlanningError
from armctl.kinematics.model import KinematicModel
from armctl.motion.errors import DetourError
from armctl.motion.interpolate import Interpolation, plan_run
from armctl.motion.layout import GeodesicMove, JointLayout
from armctl.motion.limits import MotionLimits, check_speed, check_trajectory
from armctl.motion.multi_dof import plan_layout_run
from armctl.motion.plan import MotionPlan, Waypoint
from armctl.motion.rrt_connect import (
    JointSpace,
    SearchResult,
    finite_box,
    ompl_rrt_connect,
    path_length,
    rrt_connect,
    shortcut,
)
from armctl.motion.trajectory import Chain, RuckigTrajectory, Trajectory
from armctl.typing import Array

__all__ = ["CollisionChecker", "DetourOptions", "Planner", "plan_detour", "sample_steps"]

log = logging.getLogger(__name__)

#: Sampling step of the continuous check of the timed trajectory [s].
CHECK_DT = 0.002
#: Slack on the acceleration limit in the bound of a joint's travel between samples [-].
_ACCEL_SLACK = 1.1
_HINT = ("give the planner more time (a larger time budget: DetourOptions(time_budget=...), "
         "--plan-time on the command line), move or shrink the obstacles, or choose another goal")


#: Denser samples ``(ts, qs, step)`` of the motion between two times [s] (both included).
Refine = Callable[[float, float], tuple[Array, Array, Array]]


class CollisionChecker(Protocol):
    """What the planner needs of a collision model (:class:`armctl.collision.CollisionModel`)."""

    def free(self, q: Array) -> bool:
        """Whether configuration ``q`` ``(dof,)`` is free of collisions."""

    def first_contact_on_segment(self, q0: Array, q1: Array) -> object | None:
        """The first contact along the straight joint-space segment, or ``None`` (continuous)."""

    def first_contact_on_samples(self, ts: Array, qs: Array, step: Array,
                                 refine: Refine | None = None) -> object | None:
        """The first contact along a sampled motion, or ``None``.

        ``step[i, j]`` bounds how far joint ``j`` travels between samples ``i`` and ``i + 1``;
        ``refine(t0, t1)`` gives denser samples of a step that its ends cannot certify.
        """


class Planner(Enum):
    """Which RRT-Connect searches the path."""

    AUTO = "auto"  # OMPL's when it is installed (the plan extra), else armctl's own
    OMPL = "ompl"  # OMPL's RRTConnect (needs the plan extra); not reproducible per plan
    BUILTIN = "builtin"  # armctl's seeded RRT-Connect: the same seed gives the same path


@dataclass(frozen=True)
class DetourOptions:
    """How to plan a detour.

    Attributes:
        time_budget: Time allowed for the search and the shortcutting [s], counted from the
            call; a search that has not found a free path by then fails. Timing and checking
            the path found come on top (milliseconds).
        seed: Seed of the random sampling (of the search with :attr:`Planner.BUILTIN`, and of
            the shortcutting with either planner).
        simplify: Shorten the path found by shortcutting.
        planner: The search (:attr:`Planner.AUTO`: OMPL's when installed, else armctl's).
        interpolation: How the path's vertices are joined in time; the arm stops at a vertex
            where a blend would collide.
    """

    time_budget: float = 1.0
    seed: int = 0
    simplify: bool = True
    planner: Planner = Planner.AUTO
    interpolation: Interpolation = Interpolation.LINEAR

    def __post_init__(self) -> None:
        if not (isinstance(self.time_budget, (int, float)) and 0.0 < self.time_budget < 3600.0):
            raise InputError(f"time budget {self.time_budget!r} s must be a number of seconds "
                             "above 0 and below 3600")
        if not isinstance(self.planner, Planner):
            raise InputError(f"planner {self.planner!r} is not one of "
                             f"{', '.join(p.value for p in Planner)}")


def sample_steps(ts: Array, qd: Array, limits: MotionLimits) -> Array:
    """A bound on how far each joint travels between consecutive samples ``(N - 1, dof)``.

    Between samples ``i`` and ``i + 1`` (``h`` apart) a joint's speed is at most
    ``|v_i| + a t`` and at most ``|v_{i+1}| + a (h - t)`` (``a`` its acceleration limit, with
    a 10% slack); the travel is at most the area under the lower of the two lines, and never
    more than ``h`` times the velocity limit (with the same slack).

    Args:
        ts: Sample times ``(N,)`` [s].
        qd: Joint velocities at the samples ``(N, dof)``.
        limits: The hard limits.
    """
    h = np.diff(ts)[:, None]
    v0 = np.abs(qd[:-1])
    v1 = np.abs(qd[1:])
    acc = limits.acceleration[None, :] * _ACCEL_SLACK
    # where the two lines cross, within the step
    cross = np.clip((v1 - v0 + acc * h) / (2.0 * acc), 0.0, h)
    by_acc = v0 * cross + acc * cross**2 / 2.0 + v1 * (h - cross) + acc * (h - cross) ** 2 / 2.0
    by_vel = h * limits.velocity[None, :] * _ACCEL_SLACK
    return np.asarray(np.minimum(by_acc, by_vel))


def _sample_times(traj: Trajectory) -> Array:
    n = max(2, int(np.ceil(traj.duration / CHECK_DT)) + 1)
    return np.unique(np.concatenate([np.linspace(0.0, traj.duration, n), traj.breakpoints()]))


#: Extra distance [m] the search keeps from obstacles and the table beyond the scene's
#: padding, so that the timed trajectory, which may blend past the path's vertices, is not
#: checked where the path grazes its padding.
PLANNING_MARGIN = 0.003

_MARGIN_MODELS: weakref.WeakKeyDictionary[object, CollisionChecker] = weakref.WeakKeyDictionary()


def _with_margin(checker: CollisionChecker, start: Array, goal: Array) -> CollisionChecker:
    """The collision model with :data:`PLANNING_MARGIN` added to its padding, for the search.

    Only for an :class:`armctl.collision.model.CollisionModel` whose start and goal are free
    with the margin; otherwise the checker itself.
    """
    from armctl.collision.model import CollisionModel

    if not isinstance(checker, CollisionModel):
        return checker
    padded = _MARGIN_MODELS.get(checker)
    if padded is None:
        scene = dataclasses.replace(checker.scene,
                                    padding=checker.scene.padding + PLANNING_MARGIN)
        padded = CollisionModel(checker.model, scene, checker.allowed)
        _MARGIN_MODELS[checker] = padded
    return padded if padded.free(start) and padded.free(goal) else checker


#: Spacing [rad]/[m] of the configurations tested one by one along a segment before its
#: continuous check: a segment that collides at one of them is refused without it.
PROBE_SPACING = 0.1
_MAX_PROBES = 64


#: Largest spacing [rad] of the samples at which a segment of an arm with ball joints is
#: checked against the ball joints' swing and twist limits.
LIMIT_SPACING = 0.01


@dataclass(frozen=True, eq=False)
class _Sphere:
    """The configuration space of an arm with ball joints and the layout of its limits."""

    space: JointSpace
    layout: JointLayout

    def inside(self, qs: Array) -> bool:
        """Whether every configuration ``(n, nq)`` is inside the ball joints' limits."""
        return self.layout.ball_violation(qs) is None

    def segment_inside(self, a: Array, b: Array) -> bool:
        """Whether the segment stays inside the ball joints' limits (dense samples)."""
        n = max(2, int(np.ceil(self.space.distance(a, b) / LIMIT_SPACING)) + 1)
        return self.inside(self.space.interpolate_many(a, b, np.linspace(0.0, 1.0, n)))


def _segment_check(checker: CollisionChecker, sphere: _Sphere | None = None
                   ) -> Callable[[Array, Array], bool]:
    """The test of a straight segment used by the search and the shortcutting.

    With a model that checks many configurations at once (``free_batch``), points every
    :data:`PROBE_SPACING` along the segment are tested first: most segments the search tries
    collide, and a colliding point refuses one at a fraction of the cost of the continuous
    check, which still decides every segment that passes. The continuous check is the model's
    ``segment_free`` when it has one (no contact report to build), else
    ``first_contact_on_segment``. With ball joints (``sphere``) the probes lie on the
    shortest arcs and the segment must also stay inside the ball joints' limits.
    """
    direct = getattr(checker, "segment_free", None)
    if callable(direct):
        def continuous(a: Array, b: Array) -> bool:
            return bool(direct(a, b))
    else:
        def continuous(a: Array, b: Array) -> bool:
            return checker.first_contact_on_segment(a, b) is None
    batch = getattr(checker, "free_batch", None)
    if sphere is not None:
        space = sphere.space

        def on_arcs(a: Array, b: Array) -> bool:
            if not sphere.segment_inside(a, b):
                return False
            if callable(batch):
                n = int(min(max(np.ceil(space.distance(a, b) / PROBE_SPACING), 2),
                            _MAX_PROBES))
                u = np.linspace(0.0, 1.0, n + 1)[1:-1]
                if not np.all(batch(space.interpolate_many(a, b, u))):
                    return False
            return continuous(a, b)
        return on_arcs
    if not callable(batch):
        return continuous

    def probed(a: Array, b: Array) -> bool:
        d = b - a
        n = int(min(max(np.ceil(float(np.sqrt(d @ d)) / PROBE_SPACING), 2), _MAX_PROBES))
        u = np.linspace(0.0, 1.0, n + 1)[1:-1]
        if not np.all(batch(a + u[:, None] * d)):
            return False
        return continuous(a, b)
    return probed


def _has_ompl() -> bool:
    """Whether OMPL's Python bindings can be imported (without importing them)."""
    import importlib.util

    return importlib.util.find_spec("ompl") is not None


def _missing_ompl(exc: ImportError) -> Exception:
    from armctl.collision.errors import MissingExtraError

    err = MissingExtraError("detour planning with OMPL's RRT-Connect", "ompl", "plan")
    err.__cause__ = exc
    return err


def _search(options: DetourOptions, q0: Array, q1: Array, lo: Array, hi: Array,
            checker: CollisionChecker, deadline: float, rng: np.random.Generator,
            sphere: _Sphere | None = None) -> SearchResult:
    if sphere is not None:
        def inside_free(q: Array) -> bool:
            return sphere.inside(q[None, :]) and bool(checker.free(q))

        return rrt_connect(q0, q1, lo, hi, inside_free, _segment_check(checker, sphere),
                           deadline, rng, space=sphere.space)

    def state_free(q: Array) -> bool:
        return bool(checker.free(q))

    segment_free = _segment_check(checker)
    if options.planner is Planner.OMPL:
        try:
            return ompl_rrt_connect(q0, q1, lo, hi, state_free, segment_free,
                                    deadline - time.perf_counter())
        except ImportError as exc:
            raise _missing_ompl(exc) from exc
    return rrt_connect(q0, q1, lo, hi, state_free, segment_free, deadline, rng)



def plan_detour(checker: CollisionChecker, q0: npt.ArrayLike, q1: npt.ArrayLike,
                limits: MotionLimits, speed: float = 1.0,
                options: DetourOptions | None = None) -> MotionPlan:
    """A collision-free motion from ``q0`` to ``q1`` around obstacles, checked before motion.

    Args:
        checker: The collision model (the arm with its scene).
        q0: Start joint values (the present position) ``(nq,)`` [rad]/[m] (a ball joint's
            unit quaternion ``w, x, y, z``).
        q1: Goal joint values.
        limits: The arm's hard limits (the search stays inside the position limits).
        speed: Speed factor, 0.01 to 1, applied to the velocity, acceleration and jerk limits.
        options: Planner, time budget, seed; ``None``: the defaults.

    Returns:
        The checked plan; ``extra`` holds the joint path (``"path"``, its vertices), its
        length (``"path_length"``), the planner, the number of states searched, and the time
        [s] spent searching, shortcutting, timing with the continuous check, and checking the
        limits (``"search_time"``, ``"shortcut_time"``, ``"timing_time"``,
        ``"limit_check_time"``).

    Raises:
        DetourError: If no free path was found within the time budget (nothing moved).
        CollisionError: If the start or the goal itself collides.
        LimitViolation: If the goal is outside the joint limits.
        MissingExtraError: For :attr:`Planner.OMPL` without OMPL installed.
        InputError: For a bad speed factor, joint vectors of the wrong size, or, for an arm
            with ball joints, :attr:`Planner.OMPL` or a checker without the arm's model.
    """
    t0 = time.perf_counter()
    opts = options or DetourOptions()
    check_speed(speed)
    sphere = _sphere_of(checker, limits, opts)
    if opts.planner is Planner.AUTO:
        opts = replace(opts, planner=Planner.OMPL if _has_ompl() and sphere is None
                       else Planner.BUILTIN)
    start = np.asarray(q0, dtype=float).reshape(-1)
    goal = np.asarray(q1, dtype=float).reshape(-1)
    nq = limits.dof if limits.layout is None else limits.layout.nq
    if start.size != nq or goal.size != nq:
        names = limits.names if limits.layout is None else limits.layout.q_names
        raise InputError(f"start and goal need {nq} joint values "
                         f"({', '.join(names)}); got {start.size} and {goal.size}")
    if sphere is not None:
        start = sphere.space.model.normalize(start)
        goal = sphere.space.model.normalize(goal)
    limits.check_position(goal, "goal of the detour")
    for q, what in ((start, "start"), (goal, "goal")):
        if not checker.free(q):
            _raise_collision(checker, q, f"the {what} of the detour", limits.names)
    deadline = t0 + opts.time_budget
    rng = np.random.default_rng(opts.seed)
    lo, hi = finite_box(limits.lower, limits.upper, start, goal)
    if sphere is not None:
        sphere = _Sphere(JointSpace(sphere.space.model, lo, hi), sphere.layout)
    name = f"RRT-Connect ({opts.planner.value})"
    if checker.first_contact_on_segment(start, goal) is None and (
            sphere is None or sphere.segment_inside(start, goal)):
        found = SearchResult(np.vstack([start, goal]), 0.0, 2)
        planning = checker
    else:
        planning = _with_margin(checker, start, goal)
        found = _search(opts, start, goal, lo, hi, planning, deadline, rng, sphere)
    if found.path is None:
        raise DetourError(f"no path found within the time budget ({found.states} states "
                          "searched)", opts.time_budget, time.perf_counter() - t0, name, _HINT)
    path = found.path
    t1 = time.perf_counter()
    space = None if sphere is None else sphere.space
    if opts.simplify:
        path = shortcut(path, _segment_check(planning, sphere), rng, deadline, space=space)
    t2 = time.perf_counter()
    traj, knots, stops = _time_and_check(checker, path, limits, speed, opts.interpolation,
                                         space)
    t3 = time.perf_counter()
    if traj is None:
        raise DetourError("the timed trajectory collides or leaves the joint limits even when "
                          "stopping at every vertex of the free path", opts.time_budget,
                          time.perf_counter() - t0, name,
                          "lower the speed factor or report the case")
    # a ball joint's spline run (cubic, min-jerk) is C1 on the sphere: its angular
    # acceleration steps at the vertices, so its jerk is not bounded (its great-circle turns are)
    n = check_trajectory(traj, limits, check_jerk=True,
                         hint="lower the speed factor or check the limits",
                         ball_jerk=sphere is None or opts.interpolation is Interpolation.LINEAR)
    wps = tuple(Waypoint(float(knots[k]), path[k].copy(),
                         "start" if k == 0 else "goal" if k == len(path) - 1 else f"via {k}",
                         k in stops) for k in range(len(path)))
    elapsed = time.perf_counter() - t0
    extra: dict[str, object] = {
        "path": path, "planner": opts.planner.value, "states": found.states,
        "path_length": path_length(path, space), "search_time": found.time,
        "shortcut_time": t2 - t1, "timing_time": t3 - t2,
        "limit_check_time": elapsed - (t3 - t0),
    }
    log.debug("detour: %d vertices, %.3f s long, planned in %.4f s", len(path), traj.duration,
              elapsed)
    return MotionPlan(traj, limits, (), wps, elapsed, n,
                      f"detour through {len(path) - 2} via{'' if len(path) == 3 else 's'}", extra)


def _sphere_of(checker: CollisionChecker, limits: MotionLimits, opts: DetourOptions
               ) -> _Sphere | None:
    """The configuration space of an arm with ball joints (``None``: a vector space).

    Raises:
        InputError: For ball joints with OMPL asked for, or with a checker that does not
            carry the arm's model.
    """
    layout = limits.layout
    if layout is None or not layout.balls:
        return None
    if opts.planner is Planner.OMPL:
        raise InputError("OMPL's RRT-Connect is given joint vectors here, and a ball joint "
                         f"({', '.join(b.name for b in layout.balls)}) is a unit quaternion: "
                         "plan the detour with armctl's own search "
                         "(DetourOptions(planner=Planner.BUILTIN), --planner builtin)")
    model = getattr(checker, "model", None)
    if not isinstance(model, KinematicModel):
        raise InputError("a detour of an arm with ball joints needs a collision model that "
                         "carries the arm's model (armctl.collision.CollisionModel)")
    return _Sphere(JointSpace(model, limits.lower, limits.upper), layout)


def _time_and_check(checker: CollisionChecker, path: Array, limits: MotionLimits,
                    speed: float, kind: Interpolation, space: JointSpace | None = None
                    ) -> tuple[Trajectory | None, Array, set[int]]:
    """Time the path; where a blend past a vertex collides, stop at that vertex and retime.

    (The same for a blend that swings past a position limit.)

    The path is timed as runs between stops (at first only its ends). A run of one segment
    that stays on its straight segment is free because the segment was checked free; any
    other run is checked continuously along its samples, and the vertex nearest in time to
    its first contact becomes a stop. Only the runs that change are timed again.

    Returns:
        The trajectory (``None`` if a one-segment run leaves its segment and collides), the
        time at each vertex, and the vertices where the arm stops.
    """
    scaled = limits.scaled(speed)
    stops = [0, len(path) - 1]
    runs: dict[tuple[int, int], tuple[Trajectory, Array]] = {}
    while True:
        hit = None
        for a, b in itertools.pairwise(stops):
            if (a, b) in runs:
                continue
            if limits.layout is None:
                traj, knots = plan_run(path[a: b + 1], scaled, kind)
            else:
                traj, knots = plan_layout_run(path[a: b + 1], scaled, kind)
            contact_time = _run_contact(checker, traj, path[a: b + 1], limits, space)
            if contact_time is None:
                runs[a, b] = (traj, knots)
                continue
            if b == a + 1:
                return None, np.zeros(len(path)), set(stops)
            # Stop at the vertex whose blend holds the contact: the nearest one in time.
            inner = range(1, b - a)
            hit = a + min(inner, key=lambda i: abs(float(knots[i]) - contact_time))
            break
        if hit is None:
            break
        stops = sorted({*stops, hit})
    parts = [runs[a, b][0] for a, b in itertools.pairwise(stops)]
    times = [np.zeros(1)]
    offset = 0.0
    for (a, b), part in zip(itertools.pairwise(stops), parts, strict=True):
        times.append(runs[a, b][1][1:] + offset)
        offset += part.duration
    return (parts[0] if len(parts) == 1 else Chain(parts)), np.concatenate(times), set(stops)


#: Largest distance [rad]/[m] of a sample from its straight segment for the run to count as
#: following the segment (relative to the segment's length).
_ON_SEGMENT = 1e-9


def _run_contact(checker: CollisionChecker, traj: Trajectory, pts: Array,
                 limits: MotionLimits, space: JointSpace | None = None) -> float | None:
    """When a run of the path first collides or leaves the position limits [s from its start].

    ``None`` if it is free and inside the limits.
    """
    ts = _sample_times(traj)
    qs, qd, _ = traj.sample_many(ts)
    outside = _leaves_limits(traj, ts, qs, limits)
    if outside is not None:
        return outside
    if len(pts) == 2 and space is not None:
        if _on_arc(space, pts[0], pts[1], qs):
            return None
    elif len(pts) == 2:
        # One segment at rest at both ends: if every sample lies on the segment and moves
        # one way along it, the run follows the segment, which was checked free.
        d = pts[1] - pts[0]
        length = float(np.linalg.norm(d))
        u = (qs - pts[0]) @ d / max(length**2, 1e-300)
        off = np.linalg.norm(qs - pts[0] - u[:, None] * d, axis=1)
        if (np.all(off <= _ON_SEGMENT * max(length, 1.0)) and np.all(np.diff(u) >= -1e-12)
                and u[0] >= -1e-12 and u[-1] <= 1.0 + 1e-12):
            return None
    try:
        contact = checker.first_contact_on_samples(ts, qs, sample_steps(ts, qd, limits),
                                                   _refiner(traj, limits))
    except _Uncertified as exc:
        # Too many steps to refine (a pair that grazes its padding for a long stretch): the
        # run counts as colliding there, so the arm stops at the nearest vertex instead.
        return float(exc.details["time"])
    if contact is None:
        return None
    t = getattr(contact, "time", None)
    return float(t) if t is not None else 0.0


def _on_arc(space: JointSpace, a: Array, b: Array, qs: Array) -> bool:
    """Whether samples ``qs`` lie on the segment from ``a`` to ``b``, moving one way along it.

    A ball joint's segment is its shortest arc.

    A point a fraction ``u`` along the segment is ``u`` times its length from ``a`` in the
    tangent space (the scalar coordinates and the ball joints' angles all go at a uniform
    rate in ``u``): each sample's fraction is its distance from ``a`` over the length, and the
    sample must be the segment's point at that fraction.
    """
    length = space.distance(a, b)
    dist = space.distances(qs, a)
    if length <= 0.0:
        return bool(np.all(dist <= _ON_SEGMENT))
    u = dist / length
    if not (np.all(np.diff(u) >= -1e-12) and u[-1] <= 1.0 + 1e-9):
        return False
    on = space.interpolate_many(a, b, np.minimum(u, 1.0))
    return bool(np.max(space.row_distances(on, qs)) <= 1e-7 * max(length, 1.0))


def _leaves_limits(traj: Trajectory, ts: Array, qs: Array, limits: MotionLimits
                   ) -> float | None:
    """When a run swings past a position limit (a blend overshooting a vertex), or ``None``.

    Checks the samples, and the exact position extrema of each S-curve piece; for a piece
    that leaves the limits, the time of its end (start or end) closer to the crossed limit.
    """
    lo = limits.lower - _LIMIT_TOL
    hi = limits.upper + _LIMIT_TOL
    bad = np.flatnonzero(np.any((qs < lo) | (qs > hi), axis=1))
    if bad.size:
        return float(ts[bad[0]])
    if limits.layout is not None:
        ball = limits.layout.ball_violation(qs)
        if ball is not None:
            return float(ts[ball[0]])
    parts = traj.parts if isinstance(traj, Chain) else (traj,)
    starts = traj.offsets if isinstance(traj, Chain) else np.zeros(1)
    for part, t0 in zip(parts, starts, strict=False):
        if isinstance(part, GeodesicMove):
            sq = part.layout.scalar_q
            pmin, pmax = part.position_extrema()
            over = np.flatnonzero((pmin[sq] < lo[sq]) | (pmax[sq] > hi[sq]))
            if over.size:
                j = int(sq[over[0]])
                bound = limits.lower[j] if pmin[j] < lo[j] else limits.upper[j]
                q_a, q_b = part.sample(0.0)[0], part.sample(part.duration)[0]
                near_start = abs(q_a[j] - bound) <= abs(q_b[j] - bound)
                return float(t0) + (0.0 if near_start else part.duration)
            continue
        if not isinstance(part, RuckigTrajectory):
            continue
        pmin, pmax = part.position_extrema()
        over = np.flatnonzero((pmin < lo) | (pmax > hi))
        if over.size:
            j = int(over[0])
            bound = limits.lower[j] if pmin[j] < lo[j] else limits.upper[j]
            near_start = abs(part.start[j] - bound) <= abs(part.end[j] - bound)
            return float(t0) + (0.0 if near_start else part.duration)
    return None


#: Slack of the position check of a run [rad]/[m] (that of the final limit check).
_LIMIT_TOL = 1e-9

#: Most refinements of one run's check before the run counts as colliding.
MAX_REFINES = 400


class _Uncertified(PlanningError):
    """The continuous check of a run needs more refinements than :data:`MAX_REFINES`.

    Caught inside this module (never raised out of it); ``details["time"]``: where [s].
    """


def _refiner(traj: Trajectory, limits: MotionLimits) -> Refine:
    """Eight times denser samples of ``traj`` between two times, with their travel bounds.

    Raises :class:`_Uncertified` from the :data:`MAX_REFINES`-th call on.
    """
    calls = 0

    def refine(ta: float, tb: float) -> tuple[Array, Array, Array]:
        nonlocal calls
        calls += 1
        if calls > MAX_REFINES:
            raise _Uncertified("too many refinements", {"time": ta})
        ts = np.linspace(ta, tb, 9)
        qs, qd, _ = traj.sample_many(ts)
        return ts, qs, sample_steps(ts, qd, limits)
    return refine


def _raise_collision(checker: CollisionChecker, q: Array, what: str,
                     names: tuple[str, ...]) -> None:
    from armctl.collision.contact import Contact
    from armctl.collision.errors import CollisionError

    contact = checker.first_contact_on_segment(q, q)
    if isinstance(contact, Contact):
        raise CollisionError(what, contact, names, "start from or move to a free configuration")
    raise DetourError(f"{what} collides", 0.0, 0.0, "none",
                      "start from or move to a free configuration")
