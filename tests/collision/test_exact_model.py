"""The exact narrow phase in the collision model: the real shapes decide where capsules overlap."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import armctl
from armctl.collision import CollisionModel
from armctl.collision.exact import signed_distance, table_distance
from armctl.config.scene import Obstacle, SceneSpec, TableSpec
from armctl.config.schema import Box, Cylinder, Origin
from armctl.ik import PositionGoal
from armctl.kinematics.linkshapes import GeometryRole, link_shapes

OBSTACLES = (Obstacle("post", Cylinder(0.03, 0.2, Origin((0.22, 0.0, 0.1)))),
             Obstacle("crate", Box((0.1, 0.1, 0.08), Origin((0.0, 0.25, 0.04)))))


def _truth_margin(arm: armctl.Arm, scene: SceneSpec, allowed: set[frozenset[str]],
                  q: np.ndarray) -> float:
    """The least distance minus padding over every checked pair, shape by shape (coal)."""
    frames = arm.fk_frames(q)
    shapes = link_shapes(arm.spec, GeometryRole.COLLISION)
    fixed = {name for name in shapes if arm.tree.anchor[arm.frame_index(name)] < 0}
    best = np.inf
    for la, lb in itertools.combinations(shapes, 2):
        if frozenset((la, lb)) in allowed or (la in fixed and lb in fixed):
            continue
        pa, pb = frames[arm.frame_index(la)], frames[arm.frame_index(lb)]
        for sa in shapes[la].shapes:
            for sb in shapes[lb].shapes:
                best = min(best, signed_distance(sa, pa, sb, pb).distance)
    for link, ls in shapes.items():
        pose = frames[arm.frame_index(link)]
        for s in ls.shapes:
            if scene.table is not None and link not in fixed \
                    and frozenset((link, "table")) not in allowed:
                best = min(best, table_distance(scene.table.height, s, pose).distance
                           - scene.padding)
            for ob in scene.obstacles:
                if frozenset((link, ob.name)) not in allowed:
                    best = min(best, signed_distance(s, pose, ob.shape, np.eye(4)).distance
                               - scene.padding)
    return float(best)


@pytest.mark.parametrize("name", ["so101", "ur5e"])
def test_exact_free_agrees_with_the_shapes_measured_one_by_one(name: str) -> None:
    arm = armctl.load_arm(name)
    scene = SceneSpec(TableSpec(0.0), OBSTACLES, exact=True)
    model = CollisionModel.of(arm, scene)
    capsules = CollisionModel.of(arm, SceneSpec(TableSpec(0.0), OBSTACLES))
    allowed = {p.key for p in model.allowed.allowed}
    rng = np.random.default_rng(7)
    lo = np.where(np.isfinite(arm.lower), arm.lower, -np.pi)
    hi = np.where(np.isfinite(arm.upper), arm.upper, np.pi)
    agree = 0
    for q in rng.uniform(lo, hi, (40, arm.dof)):
        truth = _truth_margin(arm, scene, allowed, q)
        if abs(truth) < 1e-6:
            continue
        assert model.free(q) == (truth >= 0.0), (q, truth)
        agree += 1
    assert agree >= 35
    # capsules contain the shapes: never free where the exact check is not, and stricter often
    qs = rng.uniform(lo, hi, (400, arm.dof))
    exact, coarse = model.free_batch(qs), capsules.free_batch(qs)
    assert not np.any(coarse & ~exact)
    assert np.count_nonzero(exact & ~coarse) >= 1


def test_exact_segments_still_find_a_thin_wall() -> None:
    arm = armctl.load_arm("so101")
    wall = Obstacle("sheet", Box((0.12, 0.002, 0.15), Origin((0.22, 0.0, 0.075))))
    model = CollisionModel.of(arm, SceneSpec(TableSpec(0.0), (wall,), exact=True))
    left = arm.ik(PositionGoal(np.array([0.2, 0.12, 0.06])), q0=np.zeros(6)).q
    right = arm.ik(PositionGoal(np.array([0.2, -0.12, 0.06])), q0=np.zeros(6)).q
    assert model.free(left) and model.free(right)
    hit = model.first_contact_on_segment(left, right)
    assert hit is not None and "sheet" in (hit.a, hit.b)
    assert model.first_contact_on_samples([0.0, 1.0], [left, right],
                                          [np.abs(right - left)]) is not None


def test_a_table_above_the_first_joint_is_refused() -> None:
    from armctl.collision import SceneError

    arm = armctl.load_arm("so101")
    with pytest.raises(SceneError, match=r"table top \(z=0.75 m.*above the arm's first joint"):
        CollisionModel.of(arm, SceneSpec(TableSpec(0.75)))
    assert CollisionModel.of(arm, SceneSpec(TableSpec(-0.01))).free(arm.named_pose("home"))
