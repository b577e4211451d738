"""Detours of an arm with a ball shoulder, an elbow and a universal wrist around obstacles.

Independent truth: coal's distances between the arm's capsules, posed by a chain of scipy
matrices from the arm file, and the scene's obstacles (the helpers of
tests/collision/test_multi_dof.py); scipy rotations for the ball joint's slerp, swing and
angular speed; the collision checker at dense samples of the timed trajectory.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation, Slerp

import armctl
from armctl.collision import CollisionModel
from armctl.motion import DetourOptions, MotionLimits, Planner, plan_detour
from armctl.motion.interpolate import Interpolation
from armctl.motion.rrt_connect import JointSpace

ARM = Path(__file__).resolve().parents[1] / "collision" / "multi_dof_arm.yaml"
BUILTIN = DetourOptions(planner=Planner.BUILTIN, time_budget=5.0)


def _rot(quats: np.ndarray) -> Rotation:
    return Rotation.from_quat(np.roll(np.atleast_2d(quats), -1, axis=1))


def _blocked_pair(arm: armctl.Arm, cm: CollisionModel, seed: int) -> tuple[np.ndarray,
                                                                           np.ndarray]:
    """Free start and goal whose straight joint path (the shoulder on its arc) collides."""
    rng = np.random.default_rng(seed)
    for _ in range(2000):
        a, b = arm.sample(rng), arm.sample(rng)
        if cm.free(a) and cm.free(b) and not cm.segment_free(a, b):
            return a, b
    raise AssertionError("no blocked pair found")


def _same(arm: armctl.Arm, a: np.ndarray, b: np.ndarray) -> float:
    """The largest difference of two configurations (a quaternion and its negative agree)."""
    return float(np.max(np.abs(arm.difference(a, b))))


@pytest.fixture(scope="module")
def arm() -> armctl.Arm:
    return armctl.load_arm(ARM)


@pytest.fixture(scope="module")
def cm(arm: armctl.Arm) -> CollisionModel:
    return CollisionModel.of(arm)


def _dense(plan: object, dt: float = 0.002) -> tuple[np.ndarray, np.ndarray]:
    traj = plan.trajectory  # type: ignore[attr-defined]
    ts = np.append(np.arange(0.0, traj.duration, dt), traj.duration)
    return ts, traj.sample_many(ts)[0]


def test_the_search_space_moves_on_the_shortest_arcs(arm: armctl.Arm) -> None:
    space = JointSpace(arm, arm.lower, arm.upper)
    rng = np.random.default_rng(4)
    sh = arm.q_index("shoulder")
    for _ in range(5):
        a, b = arm.sample(rng), arm.sample(rng)
        # distance: the norm of the tangent step (the shoulder's geodesic angle by scipy)
        angle = (_rot(a[sh]).inv() * _rot(b[sh])).magnitude()[0]
        scalar = np.delete(b - a, np.r_[sh])
        assert space.distance(a, b) == pytest.approx(math.hypot(angle, *scalar), abs=1e-9)
        assert space.distance(a, b) == pytest.approx(np.linalg.norm(arm.difference(a, b)),
                                                     abs=1e-9)
        us = np.linspace(0.0, 1.0, 6)
        pts = space.interpolate_many(a, b, us)
        slerp = Slerp([0.0, 1.0], Rotation.concatenate([_rot(a[sh]), _rot(b[sh])]))
        assert (_rot(pts[:, sh]).inv() * slerp(us)).magnitude().max() < 1e-9
        assert np.allclose(np.delete(pts, np.r_[sh], axis=1),
                           np.delete(a, np.r_[sh]) + us[:, None] * scalar, atol=1e-12)


def test_a_detour_around_the_scene_is_free_and_ends_where_asked(arm: armctl.Arm,
                                                                cm: CollisionModel) -> None:
    from tests.collision.test_multi_dof import padding, truth_distances

    start, goal = _blocked_pair(arm, cm, seed=1)
    limits = MotionLimits.from_model(arm)
    plan = plan_detour(cm, start, goal, limits, options=BUILTIN)
    path = plan.extra["path"]
    assert len(path) >= 3  # a way around, not the blocked straight path
    ts, qs = _dense(plan)
    assert _same(arm, qs[0], start) < 1e-9 and _same(arm, qs[-1], goal) < 1e-9
    assert np.allclose(np.linalg.norm(qs[:, arm.q_index("shoulder")], axis=1), 1.0, atol=1e-9)
    # free at every 2 ms sample by the checker, and by coal at some of them
    assert cm.free_batch(qs).all()
    doc = yaml.safe_load(ARM.read_text())
    pad = padding(cm)
    for q in qs[:: max(1, len(qs) // 12)]:
        assert np.all(truth_distances(cm, doc, q) >= pad - 1e-6)
    # every segment of the path was free along the shoulder's arc
    assert all(cm.segment_free(a, b) for a, b in itertools.pairwise(path))
    # the shoulder's angular speed (scipy, by differences) under its limit
    rot = _rot(qs[:, arm.q_index("shoulder")])
    speed = (rot[:-1].inv() * rot[1:]).magnitude() / np.diff(ts)
    assert speed.max() <= limits.velocity[arm.v_index("shoulder").start] * 1.03
    # with linear interpolation the shoulder rests at every vertex (its turn changes axis there)
    for w in plan.waypoints:
        _, qd, _ = plan.trajectory.sample(w.time)
        assert np.linalg.norm(qd[arm.v_index("shoulder")]) < 1e-6


def test_the_same_seed_gives_the_same_detour(arm: armctl.Arm, cm: CollisionModel) -> None:
    start, goal = _blocked_pair(arm, cm, seed=2)
    limits = MotionLimits.from_model(arm)
    a = plan_detour(cm, start, goal, limits, options=BUILTIN)
    b = plan_detour(cm, start, goal, limits, options=BUILTIN)
    assert np.array_equal(a.extra["path"], b.extra["path"])
    assert a.extra["path_length"] == pytest.approx(
        sum(np.linalg.norm(arm.difference(p, q))
            for p, q in itertools.pairwise(a.extra["path"])))


def test_a_cubic_detour_is_free(arm: armctl.Arm, cm: CollisionModel) -> None:
    start, goal = _blocked_pair(arm, cm, seed=3)
    plan = plan_detour(cm, start, goal, MotionLimits.from_model(arm),
                       options=DetourOptions(planner=Planner.BUILTIN, time_budget=5.0,
                                             interpolation=Interpolation.CUBIC))
    _, qs = _dense(plan)
    assert cm.free_batch(qs).all()
    assert _same(arm, qs[-1], goal) < 1e-9


def _swing_twist(rot: Rotation) -> tuple[np.ndarray, np.ndarray]:
    """Swing (the z axis's angle from its rest direction) and twist about z [rad], by scipy."""
    z = np.array([0.0, 0.0, 1.0])
    moved = rot.apply(z)
    swing = np.arccos(np.clip(moved @ z, -1.0, 1.0))
    across = np.cross(z, moved)
    norm = np.linalg.norm(across, axis=1)
    axis = np.where(norm[:, None] > 1e-12, across / np.maximum(norm, 1e-300)[:, None],
                    [1.0, 0.0, 0.0])
    twist = (Rotation.from_rotvec(axis * swing[:, None]).inv() * rot).as_rotvec() @ z
    return swing, twist


def test_a_detour_keeps_the_ball_joint_inside_its_limits(tmp_path: Path) -> None:
    doc = yaml.safe_load(ARM.read_text())
    swing_max, twist_max = 1.4, 2.8
    doc["joints"][0]["limits"] = {"swing": swing_max,
                                  "twist": {"lower": -twist_max, "upper": twist_max}}
    del doc["poses"]["bent"]  # swings beyond the cone
    path = tmp_path / "cone_arm.yaml"
    path.write_text(yaml.safe_dump(doc))
    arm = armctl.load_arm(path)
    cm = CollisionModel.of(arm)
    sh = arm.q_index("shoulder")

    def inside(quats: np.ndarray) -> bool:
        swing, twist = _swing_twist(_rot(quats))
        return bool(swing.max() <= swing_max + 1e-9 and np.abs(twist).max() <= twist_max + 1e-9)

    # a start and goal whose shoulder's shortest arc (scipy's slerp) leaves the twist range,
    # though the arm does not collide along it
    rng = np.random.default_rng(0)
    us = np.linspace(0.0, 1.0, 400)
    for _ in range(5000):
        start, goal = arm.sample(rng), arm.sample(rng)
        arc = Slerp([0.0, 1.0], Rotation.concatenate([_rot(start[sh]), _rot(goal[sh])]))(us)
        if (cm.free(start) and cm.free(goal) and cm.segment_free(start, goal)
                and not inside(np.roll(arc.as_quat(), 1, axis=1))):
            break
    else:
        raise AssertionError("no such pair found")
    plan = plan_detour(cm, start, goal, MotionLimits.from_model(arm), options=BUILTIN)
    assert len(plan.extra["path"]) >= 3  # not the straight arc
    _, qs = _dense(plan)
    assert cm.free_batch(qs).all()
    assert inside(qs[:, sh])
    assert _same(arm, qs[-1], goal) < 1e-9


def test_an_arm_of_universal_joints_is_searched_in_its_box(tmp_path: Path) -> None:
    doc = yaml.safe_load(ARM.read_text())
    shoulder = doc["joints"][0]
    shoulder.update(type="universal", axes=[[0, 0, 1], [0, 1, 0]],
                    limits=[{"lower": -3, "upper": 3}, {"lower": -1.5, "upper": 1.5}])
    del shoulder["axis"]
    doc["poses"] = {}
    path = tmp_path / "universal_arm.yaml"
    path.write_text(yaml.safe_dump(doc))
    arm = armctl.load_arm(path)
    cm = CollisionModel.of(arm)
    start, goal = _blocked_pair(arm, cm, seed=0)
    plan = plan_detour(cm, start, goal, MotionLimits.from_model(arm), options=BUILTIN)
    assert len(plan.extra["path"]) >= 3
    _, qs = _dense(plan)
    assert cm.free_batch(qs).all()
    assert np.all(qs >= arm.lower - 1e-9) and np.all(qs <= arm.upper + 1e-9)
    assert np.abs(qs[0] - start).max() < 1e-12 and np.abs(qs[-1] - goal).max() < 1e-9
