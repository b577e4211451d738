"""Detour planning: a free path around obstacles, timed under the limits, checked before motion."""

from __future__ import annotations

import itertools
import sys
import time
from dataclasses import dataclass

import numpy as np
import pytest

from armctl.collision.errors import CollisionError, MissingExtraError
from armctl.motion.detour import DetourOptions, Planner, plan_detour, sample_steps
from armctl.motion.errors import DetourError
from armctl.motion.interpolate import Interpolation
from armctl.motion.limits import MotionLimits, check_trajectory

# ---- a stand-in collision model: axis-aligned boxes in joint space, checked exactly ----------


@dataclass
class Hit:
    time: float


class JointBoxes:
    """Obstacles as open boxes ``lo < q < hi`` in joint space, with exact continuous checks."""

    def __init__(self, boxes: list[tuple[list[float], list[float]]]):
        self.boxes = [(np.asarray(lo, float), np.asarray(hi, float)) for lo, hi in boxes]

    def inside(self, q: np.ndarray) -> bool:
        return any(bool(np.all((q > lo) & (q < hi))) for lo, hi in self.boxes)

    def free(self, q: np.ndarray) -> bool:
        return not self.inside(np.asarray(q, float))

    def _entry(self, a: np.ndarray, b: np.ndarray) -> float | None:
        """Smallest u in [0, 1] where a + u (b - a) is inside a box (slab method)."""
        best = None
        d = b - a
        for lo, hi in self.boxes:
            t0, t1 = 0.0, 1.0
            for j in range(a.size):
                if abs(d[j]) < 1e-15:
                    if not lo[j] < a[j] < hi[j]:
                        t0, t1 = 1.0, 0.0
                        break
                    continue
                u0, u1 = sorted(((lo[j] - a[j]) / d[j], (hi[j] - a[j]) / d[j]))
                t0, t1 = max(t0, u0), min(t1, u1)
            if t0 < t1 and (best is None or t0 < best):
                best = t0
        return best

    def first_contact_on_segment(self, q0, q1):
        u = self._entry(np.asarray(q0, float), np.asarray(q1, float))
        return None if u is None else Hit(u)

    def first_contact_on_samples(self, ts, qs, step, refine=None, depth=8):
        ts, qs, step = np.asarray(ts), np.asarray(qs), np.asarray(step)
        for i in range(len(ts) - 1):
            if self.inside(qs[i]):
                return Hit(float(ts[i]))
            # the joints stay within step of both ends: this box holds the motion in between
            lo = np.maximum(qs[i], qs[i + 1]) - step[i]
            hi = np.minimum(qs[i], qs[i + 1]) + step[i]
            if any(np.all((hi > blo) & (lo < bhi)) for blo, bhi in self.boxes):
                if refine is None or depth == 0:
                    return Hit(float(ts[i]))
                found = self.first_contact_on_samples(*refine(float(ts[i]), float(ts[i + 1])),
                                                      refine, depth - 1)
                if found is not None:
                    return found
        if self.inside(qs[-1]):
            return Hit(float(ts[-1]))
        return None


def joint_limits(dof: int = 2) -> MotionLimits:
    return MotionLimits(tuple(f"j{i}" for i in range(dof)), np.full(dof, -2.0), np.full(dof, 2.0),
                        np.full(dof, 1.5), np.full(dof, 4.0), np.full(dof, 40.0),
                        ("rad",) * dof)


WALL = JointBoxes([([-0.3, -1.2], [0.3, 1.2])])  # a wall across the straight line, gaps at |y|>1.2


def dense_free(traj, boxes: JointBoxes, dt: float = 2e-4) -> bool:
    """Independent check: every sample at ``dt`` is outside the boxes."""
    ts = np.arange(0.0, traj.duration + dt, dt)
    qs, _, _ = traj.sample_many(np.minimum(ts, traj.duration))
    return not any(boxes.inside(q) for q in qs)


@pytest.mark.parametrize("planner", [Planner.OMPL, Planner.BUILTIN])
def test_detour_around_wall_is_free_and_within_limits(planner: Planner) -> None:
    lim = joint_limits()
    q0, q1 = np.array([-1.0, 0.0]), np.array([1.0, 0.0])
    assert WALL.first_contact_on_segment(q0, q1) is not None  # the direct line hits the wall
    plan = plan_detour(WALL, q0, q1, lim, options=DetourOptions(seed=3, planner=planner))
    traj = plan.trajectory
    assert np.allclose(traj.start, q0) and np.allclose(traj.end, q1)
    assert dense_free(traj, WALL)
    check_trajectory(traj, lim, dt=0.0005, check_jerk=True)  # raises on any violation
    path = plan.extra["path"]
    assert all(WALL.first_contact_on_segment(a, b) is None for a, b in itertools.pairwise(path))
    # the detour passes one of the gaps: some sample beyond the wall's half-height
    qs, _, _ = traj.sample_many(np.linspace(0.0, traj.duration, 400))
    assert np.max(np.abs(qs[:, 1])) >= 1.2


def test_same_seed_same_plan_and_shortcutting_shortens() -> None:
    lim = joint_limits()
    q0, q1 = np.array([-1.0, 0.0]), np.array([1.0, 0.0])
    opts = DetourOptions(seed=11, planner=Planner.BUILTIN)
    a = plan_detour(WALL, q0, q1, lim, options=opts)
    b = plan_detour(WALL, q0, q1, lim, options=opts)
    np.testing.assert_array_equal(a.extra["path"], b.extra["path"])
    assert a.duration == b.duration
    raw = plan_detour(WALL, q0, q1, lim, options=DetourOptions(seed=11, planner=Planner.BUILTIN,
                                                               simplify=False))
    assert a.extra["path_length"] <= raw.extra["path_length"] + 1e-12
    # the shortest way round passes two corners of the wall, (-0.3, 1.2) and (0.3, 1.2) or
    # their mirror images: within 5% of that
    shortest = 2 * np.hypot(0.7, 1.2) + 0.6
    assert shortest - 1e-9 <= a.extra["path_length"] < 1.05 * shortest


def test_blend_that_cuts_a_corner_stops_at_the_vertex() -> None:
    # A corridor with one bend round the corner (0.9, 0.9) of a box: the shortened path grazes
    # that corner, and a blend past the vertex there would cut into the box, so the arm must
    # stop at it (the timed motion then follows the checked segments).
    boxes = JointBoxes([([-2.1, -2.1], [0.9, 0.9]), ([-2.1, 1.1], [2.1, 2.1]),
                        ([1.1, -2.1], [2.1, 0.9])])
    lim = joint_limits()
    q0, q1 = np.array([-1.5, 1.0]), np.array([1.0, -1.5])
    plan = plan_detour(boxes, q0, q1, lim,
                       options=DetourOptions(seed=0, planner=Planner.BUILTIN,
                                             interpolation=Interpolation.LINEAR))
    assert dense_free(plan.trajectory, boxes)
    check_trajectory(plan.trajectory, lim, dt=0.0005, check_jerk=True)
    inner = [w for w in plan.waypoints[1:-1] if w.stop]
    assert inner, "no stop at the bend"
    # without the stop, the blended timing of the same path cuts into the box
    from armctl.motion.interpolate import plan_run

    blended, _ = plan_run(plan.extra["path"], lim, Interpolation.LINEAR)
    assert not dense_free(blended, boxes)


def test_enclosed_goal_fails_within_budget_and_says_nothing_moved() -> None:
    g = 0.8
    shell = [([g - 0.3, g - 0.3], [g + 0.3, g - 0.2]), ([g - 0.3, g + 0.2], [g + 0.3, g + 0.3]),
             ([g - 0.3, g - 0.3], [g - 0.2, g + 0.3]), ([g + 0.2, g - 0.3], [g + 0.3, g + 0.3])]
    boxes = JointBoxes([(lo, hi) for lo, hi in shell])
    lim = joint_limits()
    for planner in (Planner.BUILTIN, Planner.OMPL):
        t0 = time.perf_counter()
        with pytest.raises(DetourError, match="nothing was moved") as info:
            plan_detour(boxes, [-1.0, -1.0], [g, g], lim,
                        options=DetourOptions(time_budget=0.2, planner=planner))
        assert time.perf_counter() - t0 < 0.2 + 1.0  # slack for a loaded machine
        assert info.value.details["budget"] == 0.2
        assert "time budget" in str(info.value)


def test_goal_outside_limits_and_bad_options_are_refused() -> None:
    from armctl.errors import InputError
    from armctl.motion.errors import LimitViolation

    lim = joint_limits()
    with pytest.raises(LimitViolation):
        plan_detour(WALL, [-1.0, 0.0], [2.5, 0.0], lim)
    with pytest.raises(InputError, match="time budget"):
        DetourOptions(time_budget=0.0)
    with pytest.raises(InputError, match="joint values"):
        plan_detour(WALL, [-1.0, 0.0, 0.0], [1.0, 0.0], lim)


def test_missing_ompl_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in [m for m in sys.modules if m == "ompl" or m.startswith("ompl.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "ompl", None)  # makes `import ompl` raise ImportError
    with pytest.raises(MissingExtraError, match=r"pip install 'armctl\[plan\]'"):
        plan_detour(WALL, [-1.0, 0.0], [1.0, 0.0], joint_limits(),
                    options=DetourOptions(planner=Planner.OMPL))
    # the builtin planner needs no OMPL, and the default (AUTO, what --plan uses) falls back to it
    plan = plan_detour(WALL, [-1.0, 0.0], [1.0, 0.0], joint_limits(),
                       options=DetourOptions(planner=Planner.BUILTIN))
    assert dense_free(plan.trajectory, WALL)
    monkeypatch.setattr("armctl.motion.detour._has_ompl", lambda: False)
    plan = plan_detour(WALL, [-1.0, 0.0], [1.0, 0.0], joint_limits())
    assert plan.extra["planner"] == "builtin" and dense_free(plan.trajectory, WALL)


def test_auto_uses_ompl_when_it_is_installed() -> None:
    assert DetourOptions().planner is Planner.AUTO
    plan = plan_detour(WALL, [-1.0, 0.0], [1.0, 0.0], joint_limits())
    assert plan.extra["planner"] == "ompl" and dense_free(plan.trajectory, WALL)


def test_sample_steps_bound_the_travel_between_samples() -> None:
    # Motions within the acceleration limit (random smooth and bang-bang ones): the bound holds
    # against the travel integrated finely, and is tight for constant acceleration.
    lim = joint_limits(1)
    amax = float(lim.acceleration[0])
    rng = np.random.default_rng(5)
    fine = np.linspace(0.0, 0.4, 40001)
    for _ in range(20):
        w, ph, v0 = rng.uniform(2.0, 30.0), rng.uniform(0, 6.3), rng.uniform(-1.0, 1.0)
        acc = amax * np.sign(np.sin(w * fine + ph)) if rng.random() < 0.5 else (
            amax * np.sin(w * fine + ph))
        vel = v0 + np.concatenate([[0.0], np.cumsum((acc[1:] + acc[:-1]) / 2 * np.diff(fine))])
        vel = np.clip(vel, -lim.velocity[0], lim.velocity[0])
        ts = fine[::2000]
        step = sample_steps(ts, vel[::2000, None], lim)[:, 0]
        speed = np.abs(vel)
        seg = np.concatenate([[0.0], np.cumsum((speed[1:] + speed[:-1]) / 2 * np.diff(fine))])
        travel = np.diff(seg[::2000])
        assert np.all(step >= travel - 1e-9)
    ts = np.linspace(0.0, 0.3, 7)
    step = sample_steps(ts, (amax * ts)[:, None], lim)[:, 0]
    exact = np.diff(amax * ts**2 / 2.0)
    assert np.all(step <= exact + 0.1 * amax * np.diff(ts) ** 2)


# ---- the real collision model: an arm and a box ---------------------------------------------


def test_so101_detour_around_a_box_clears_it_by_independent_distances() -> None:
    from armctl import load_arm
    from armctl.collision.model import CollisionModel
    from armctl.config.scene import Obstacle, SceneSpec, TableSpec
    from armctl.config.schema import Box, Origin
    from armctl.kinematics.capsules import arm_capsules, segment_box_distance, world_segments

    arm = load_arm("so101")
    lim = MotionLimits.from_model(arm)
    q0 = np.array([-1.2, -0.3, 0.4, 0.6, 0.0, 0.0])[: arm.dof]
    q1 = np.array([1.2, -0.3, 0.4, 0.6, 0.0, 0.0])[: arm.dof]
    mid = arm.fk((q0 + q1) / 2)[:3, 3]
    size = (0.06, 0.06, 0.06)
    scene = SceneSpec(TableSpec(), (Obstacle("block", Box(size, Origin(tuple(mid)))),))
    cm = CollisionModel.of(arm, scene)
    assert cm.free(q0) and cm.free(q1)
    assert cm.first_contact_on_segment(q0, q1) is not None
    plan = plan_detour(cm, q0, q1, lim, options=DetourOptions(seed=1, planner=Planner.BUILTIN))
    check_trajectory(plan.trajectory, lim, dt=0.001, check_jerk=True)
    # independent truth: every capsule keeps the padding from the box at dense samples
    caps = arm_capsules(arm)
    radius = np.array([c.radius for c in caps])
    lo, hi = mid - np.array(size) / 2, mid + np.array(size) / 2
    ts = np.linspace(0.0, plan.duration, int(plan.duration / 0.004) + 2)
    qs, _, _ = plan.trajectory.sample_many(ts)
    half_diagonal = float(np.linalg.norm(size)) / 2
    worst, exact_checks = np.inf, 0  # a lower bound of the distance [m]
    for q in qs:
        a, b = world_segments(arm, q, caps)
        # a lower bound first (the box's bounding sphere), the exact distance where it is near
        ab = b - a
        u = np.clip(np.einsum("ij,ij->i", mid - a, ab) / np.maximum(
            np.einsum("ij,ij->i", ab, ab), 1e-300), 0.0, 1.0)
        rough = np.linalg.norm(a + u[:, None] * ab - mid, axis=1) - half_diagonal - radius
        near = rough < scene.padding + 0.02
        worst = min(worst, float(np.min(rough[~near], initial=np.inf)))
        for k in np.flatnonzero(near):
            exact_checks += 1
            worst = min(worst, segment_box_distance(a[k], b[k], lo, hi) - radius[k])
    assert worst >= scene.padding - 1e-6


def test_so101_start_in_collision_names_the_pair() -> None:
    from armctl import load_arm
    from armctl.collision.model import CollisionModel
    from armctl.config.scene import Obstacle, SceneSpec, TableSpec
    from armctl.config.schema import Box, Origin

    arm = load_arm("so101")
    q0 = np.zeros(arm.dof)
    tip = arm.fk(q0)[:3, 3]
    scene = SceneSpec(TableSpec(), (Obstacle("post", Box((0.05, 0.05, 0.05), Origin(tuple(tip)))),))
    cm = CollisionModel.of(arm, scene)
    with pytest.raises(CollisionError, match="start of the detour"):
        plan_detour(cm, q0, q0 + 0.3, MotionLimits.from_model(arm))
