"""The compiled collision kernels against independent truth.

* Distances between primitives against dense sampling in NumPy: segment-segment (a grid of
  points on both), segment-point, and segment-box (points along the segment, their closed-form
  distance to the box, or depth inside it).
* The culled checks (``free``, ``free_batch``, ``clearance``) against the unculled per-pair
  slacks, and those against capsules placed by the kinematics (``fk_all``) and sampled.
* Continuous checks: a wall 2 mm thick that the straight joint-space line between two free
  configurations passes through, and a sampled motion whose samples are coarser than the wall.
* The interpreted kernels give the same numbers as the compiled ones.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from brute_depth import segment_box_depth

import armctl
from armctl.collision import _kernels as K
from armctl.collision.contact import ContactKind
from armctl.collision.model import RESOLUTION, CollisionModel
from armctl.config.scene import Obstacle, SceneSpec
from armctl.config.schema import Box, Cylinder, Origin, Sphere
from armctl.kinematics.capsules import collision_capsules

INF = 1e300


# ---- NumPy brute force ----------------------------------------------------------------------
def _brute_seg_seg(p: np.ndarray, d: np.ndarray, r: np.ndarray, e: np.ndarray,
                   n: int = 801) -> float:
    s = np.linspace(0.0, 1.0, n)
    a = p + s[:, None] * d
    b = r + s[:, None] * e
    return float(np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1)).min())


def _brute_seg_box(a: np.ndarray, d: np.ndarray, rot: np.ndarray, t: np.ndarray,
                   half: np.ndarray, n: int = 50001) -> float:
    """Distance of the sampled segment to the box, or minus its penetration depth."""
    pts = (a + np.linspace(0.0, 1.0, n)[:, None] * d - t) @ rot  # in the box frame
    out = np.abs(pts) - half
    gap = np.sqrt((np.maximum(out, 0.0) ** 2).sum(1)).min()
    return float(gap) if gap > 0.0 else -segment_box_depth(pts[[0, -1]], half)


def _random_rotation(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


# ---- primitives -----------------------------------------------------------------------------
def _segment_cases(rng: np.random.Generator) -> list[tuple[np.ndarray, ...]]:
    cases = [tuple(rng.uniform(-0.3, 0.3, 3) for _ in range(4)) for _ in range(12)]
    p, d = rng.uniform(-0.3, 0.3, 3), rng.uniform(-0.3, 0.3, 3)
    cases.append((p, d, p + np.array([0.0, 0.05, 0.0]), 0.7 * d))  # parallel, overlapping in s
    cases.append((p, d, p + 1.5 * d + np.array([0.0, 0.02, 0.0]), -d))  # parallel, end to end
    cases.append((p, np.zeros(3), rng.uniform(-0.3, 0.3, 3), d))  # a point and a segment
    cases.append((p, np.zeros(3), p + np.array([0.1, 0.0, 0.0]), np.zeros(3)))  # two points
    cross = np.array([0.2, 0.0, 0.0])
    cases.append((p, d, p + 0.5 * d - cross / 2.0, cross))  # crossing
    return cases


def test_segment_segment_distance_matches_dense_sampling() -> None:
    rng = np.random.default_rng(1)
    for p, d, r, e in _segment_cases(rng):
        got = K._seg_seg(*p, *d, *r, *e)
        want = _brute_seg_seg(p, d, r, e)
        resolution = (np.linalg.norm(d) + np.linalg.norm(e)) / (2 * 800)
        assert got <= want + 1e-12  # never more than any pair of points
        assert want - got <= resolution + 1e-12


def test_segment_point_distance_matches_dense_sampling() -> None:
    rng = np.random.default_rng(2)
    for _ in range(20):
        a, d, x = (rng.uniform(-0.3, 0.3, 3) for _ in range(3))
        got = K._seg_point(*a, *d, *x)
        pts = a + np.linspace(0.0, 1.0, 100001)[:, None] * d
        want = float(np.linalg.norm(pts - x, axis=1).min())
        assert got <= want + 1e-12
        assert want - got <= np.linalg.norm(d) / 100000 + 1e-12


def _box_cases(rng: np.random.Generator) -> list[tuple[np.ndarray, ...]]:
    cases: list[tuple[np.ndarray, ...]] = []
    for k in range(30):
        rot = _random_rotation(rng) if k % 4 else np.eye(3)
        t = rng.uniform(-0.2, 0.2, 3)
        half = rng.uniform(0.001, 0.1, 3)
        if k % 3 == 0:  # through the box
            a = t + rng.uniform(-0.2, 0.2, 3)
            d = 2.0 * (t + rng.uniform(-0.5, 0.5, 3) * half - a)
        elif k % 3 == 1:  # wholly inside
            a = t + rot @ (rng.uniform(-0.8, 0.8, 3) * half)
            d = rot @ (rng.uniform(-0.8, 0.8, 3) * half) + t - a
        else:  # anywhere near
            a, d = t + rng.uniform(-0.3, 0.3, 3), rng.uniform(-0.3, 0.3, 3)
        cases.append((a, d, rot, t, half))
    return cases


def _box_data(rot: np.ndarray, t: np.ndarray, half: np.ndarray) -> tuple[float, ...]:
    return tuple(float(v) for v in (*rot.reshape(-1), *t, *half))


def test_segment_box_distance_and_depth_match_dense_sampling() -> None:
    rng = np.random.default_rng(3)
    signs = set()
    for a, d, rot, t, half in _box_cases(rng):
        got = K._seg_box(*a, *d, _box_data(rot, t, half), INF)
        want = _brute_seg_box(a, d, rot, t, half)
        signs.add(want > 0.0)
        # apart: the exact gap is at or below every sample's; inside: the exact depth is the
        # least over every direction, the search's is over some (so never less)
        if want > 0.0:
            assert got <= want + 1e-12
            assert want - got <= np.linalg.norm(d) / 50000 + 1e-12
        else:
            assert want - 1e-12 <= got <= want + 1e-6
    assert signs == {True, False}  # both apart and inside were exercised


def test_segment_box_cutoff_gives_a_lower_bound_or_the_exact_value() -> None:
    rng = np.random.default_rng(4)
    for a, d, rot, t, half in _box_cases(rng):
        data = _box_data(rot, t, half)
        exact = K._seg_box(*a, *d, data, INF)
        for cutoff in (-0.05, 0.0, 0.01, 0.1):
            got = K._seg_box(*a, *d, data, cutoff)
            if got < cutoff:
                assert got == exact
            else:
                assert got <= exact + 1e-15


# ---- whole checks ---------------------------------------------------------------------------
def _scene(reach: float) -> SceneSpec:
    obs = (
        Obstacle("box", Box(size=(0.2 * reach, 0.1 * reach, 0.3 * reach),
                            origin=Origin(xyz=(0.4 * reach, 0.1 * reach, 0.2 * reach),
                                          rpy=(0.3, -0.2, 0.9)))),
        Obstacle("ball", Sphere(radius=0.1 * reach,
                                origin=Origin(xyz=(-0.3 * reach, 0.3 * reach, 0.4 * reach)))),
        Obstacle("post", Cylinder(radius=0.05 * reach, length=0.6 * reach,
                                  origin=Origin(xyz=(0.0, -0.45 * reach, 0.3 * reach),
                                                rpy=(0.4, 0.0, 0.0)))),
    )
    return SceneSpec(obstacles=obs)


@pytest.fixture(scope="module", params=["ur5e", "so101"])
def arm_model(request: pytest.FixtureRequest) -> tuple[armctl.Arm, CollisionModel]:
    arm = armctl.load_arm(request.param)
    return arm, CollisionModel.of(arm, scene=_scene(arm.reach(arm.tool)))


def test_culled_checks_agree_with_every_pair_computed(
        arm_model: tuple[armctl.Arm, CollisionModel]) -> None:
    arm, cm = arm_model
    qs = arm.sample(np.random.default_rng(5), 3000)
    sl = cm.slacks_batch(qs)
    want = sl.min(axis=1) >= 0.0
    assert 0.05 < want.mean() < 0.95  # both free and colliding configurations
    assert np.array_equal(cm.free_batch(qs), want)
    for q, row, free in zip(qs[:500], sl[:500], want[:500], strict=True):
        assert cm.free(q) == free
        c = cm.clearance(q)
        assert c is not None
        assert c.distance - c.padding == pytest.approx(row.min(), abs=1e-15)
        assert (cm.contact(q) is None) == free


def test_slacks_match_capsules_placed_by_the_kinematics_and_sampled(
        arm_model: tuple[armctl.Arm, CollisionModel]) -> None:
    arm, cm = arm_model
    caps = collision_capsules(arm.spec)
    scene = cm.scene
    obstacles = {ob.name: ob for ob in scene.obstacles}
    n = 201
    s = np.linspace(0.0, 1.0, n)
    for q in arm.sample(np.random.default_rng(6), 3):
        poses = arm.fk_all(q)
        pts: dict[str, list[tuple[np.ndarray, float, float]]] = {}
        for link, cs in caps.items():
            t = poses[link]
            for c in cs:
                a = t[:3, :3] @ np.asarray(c.a) + t[:3, 3]
                b = t[:3, :3] @ np.asarray(c.b) + t[:3, 3]
                pts.setdefault(link, []).append((a + s[:, None] * (b - a), c.radius,
                                                 float(np.linalg.norm(b - a)) / (n - 1)))
        want: dict[tuple[str, str], tuple[float, float]] = {}
        for link, items in pts.items():
            for other, others in pts.items():
                for pa, ra, ha in items:
                    for pb, rb, hb in others:
                        dist = float(np.sqrt(((pa[:, None] - pb[None]) ** 2).sum(-1)).min())
                        key = (link, other)
                        old = want.get(key, (math.inf, 0.0))
                        want[key] = (min(old[0], dist - ra - rb), max(old[1], ha + hb))
            for name, ob in obstacles.items():
                for pa, ra, ha in items:
                    m = ob.shape.origin.matrix()
                    loc = (pa - m[:3, 3]) @ m[:3, :3]
                    if isinstance(ob.shape, Box):
                        half = np.asarray(ob.shape.size) / 2.0
                        out = np.abs(loc) - half
                        gap = np.sqrt((np.maximum(out, 0.0) ** 2).sum(1))
                        dist = float(gap.min()) if gap.min() > 0 else float(out.max(1).min())
                    elif isinstance(ob.shape, Sphere):
                        dist = float(np.linalg.norm(loc, axis=1).min()) - ob.shape.radius
                    else:  # the model checks a cylinder as the capsule around it
                        assert isinstance(ob.shape, Cylinder)
                        z = np.clip(loc[:, 2], -ob.shape.length / 2, ob.shape.length / 2)
                        dist = float(np.linalg.norm(loc - np.outer(z, [0, 0, 1]), axis=1).min()
                                     - ob.shape.radius)
                    key = (link, name)
                    old = want.get(key, (math.inf, 0.0))
                    want[key] = (min(old[0], dist - ra), max(old[1], ha))
            if scene.table is not None:
                lowest = min(float(p[:, 2].min()) - r for p, r, _ in items)
                want[(link, "table")] = (lowest - scene.table.height, 0.0)
        got: dict[tuple[str, str], float] = {}
        for idx, v in enumerate(cm.slacks(q)):
            a, b, kind = cm.pair_names(idx)
            pad = scene.padding if kind is ContactKind.SCENE else 0.0
            got[(a, b)] = min(got.get((a, b), math.inf), float(v) + pad)
        assert got
        for key, dist in got.items():
            ref, resolution = want[key]
            assert dist <= ref + 1e-9, key  # never farther than sampled points
            if ref > 0.0:
                assert ref - dist <= resolution + 1e-9, key
            else:  # in contact: both agree on it (depths differ in meaning for boxes)
                assert dist < 1e-9, key


def test_a_configuration_with_nan_or_inf_is_never_free(
        arm_model: tuple[armctl.Arm, CollisionModel]) -> None:
    arm, cm = arm_model
    qs = np.repeat(arm.middle()[None], 4, axis=0)
    qs[1, 0] = math.nan
    qs[2, -1] = math.inf
    got = cm.free_batch(qs)
    assert not got[1] and not got[2]
    assert got[0] == got[3] == cm.free(qs[0])


def test_continuous_check_of_random_lines_against_dense_samples(
        arm_model: tuple[armctl.Arm, CollisionModel]) -> None:
    _check_lines_against_dense_samples(*arm_model)


@pytest.mark.parametrize("name", ["panda", "ur5e"])
def test_continuous_self_check_of_random_lines_against_dense_samples(name: str) -> None:
    # no table, no obstacles: only the arm against itself (pairs whose chains share joints)
    arm = armctl.load_arm(name)
    _check_lines_against_dense_samples(arm, CollisionModel.of(arm, scene=SceneSpec(table=None)))


@pytest.mark.parametrize("name", ["panda", "ur5e"])
def test_pairs_never_approach_faster_than_their_motion_bound(name: str) -> None:
    # the bound behind the continuous checks: over a step, no pair's slack changes by more
    # than the pair's levers times the joints' travel (self pairs: without the joints that
    # carry both capsules)
    arm = armctl.load_arm(name)
    cm = CollisionModel.of(arm, scene=_scene(arm.reach(arm.tool)))
    coef = np.empty((cm.pair_count, arm.dof))
    K._pair_levers(cm._F, cm._I, coef)
    rng = np.random.default_rng(11)
    q0 = arm.sample(rng, 300)
    q1 = q0 + rng.uniform(-0.3, 0.3, q0.shape)
    change = np.abs(cm.slacks_batch(q1) - cm.slacks_batch(q0))
    bound = np.abs(q1 - q0) @ coef.T
    assert (change <= bound + 1e-12).all()
    assert (change / np.maximum(bound, 1e-12)).max() > 0.2  # the bound is not idle


def _check_lines_against_dense_samples(arm: armctl.Arm, cm: CollisionModel) -> None:
    rng = np.random.default_rng(10)
    qs = arm.sample(rng, 400)
    starts = qs[cm.free_batch(qs)]
    found = lines = 0
    for i in range(min(len(starts) - 1, 200)):
        if lines >= 30 and 0 < found < lines:
            break
        lines += 1
        q0 = starts[i]
        q1 = q0 + rng.uniform(0.05, 0.6) * (starts[i + 1] - q0)
        c = cm.first_contact_on_segment(q0, q1)
        u = np.linspace(0.0, 1.0, 2001)
        free = cm.free_batch(q0 + u[:, None] * (q1 - q0))
        if c is None:
            assert free.all()  # nothing between the samples either
        else:
            found += 1
            assert c.time is not None
            # no sample before the reported contact is in contact
            assert free[u < c.time - 1e-6].all()
            # in contact there, or (a piece too short to certify) within the resolution of it
            assert not cm.free(c.q) or c.distance - c.padding < RESOLUTION
    assert 0 < found < lines  # both outcomes were exercised


# ---- continuous checks ----------------------------------------------------------------------
SWEEP = 0.9  # [rad] of the first joint on either side of the wall


def _through_wall(arm: armctl.Arm) -> tuple[np.ndarray, np.ndarray, np.ndarray, SceneSpec]:
    """A configuration ``q`` whose tool is in a 2 mm wall; q0, q1 turn the first joint by
    -/+ SWEEP from it, free of the wall and everything else."""
    plain = CollisionModel.of(arm, scene=SceneSpec())
    rng = np.random.default_rng(7)
    e = np.eye(arm.dof)[0]
    for _ in range(5000):
        q = arm.sample(rng)
        p = arm.fk(q)[:3, 3]
        if (p[2] > 0.12 and math.hypot(p[0], p[1]) > 0.6 * arm.reach(arm.tool)
                and plain.free_batch(q + np.outer(np.linspace(-SWEEP, SWEEP, 37), e)).all()):
            break
    else:  # pragma: no cover - the search is deterministic
        raise AssertionError("no configuration found for the wall test")
    yaw = math.atan2(p[1], p[0])
    wall = Obstacle("wall", Box(size=(0.03, 0.002, 0.03),
                                origin=Origin(xyz=(float(p[0]), float(p[1]), float(p[2])),
                                              rpy=(0.0, 0.0, yaw))))
    return q - SWEEP * e, q, q + SWEEP * e, SceneSpec(obstacles=(wall,))


@pytest.fixture(scope="module", params=["ur5e", "so101"])
def wall_case(request: pytest.FixtureRequest) -> tuple[armctl.Arm, CollisionModel,
                                                       np.ndarray, np.ndarray, float]:
    arm = armctl.load_arm(request.param)
    q0, mid, q1, scene = _through_wall(arm)
    cm = CollisionModel.of(arm, scene=scene)
    assert cm.free(q0) and cm.free(q1) and not cm.free(mid)
    # the wall is thin: checks at a few samples of the line miss it
    assert cm.free_batch(np.linspace(q0, q1, 4)).all()
    dense = cm.free_batch(np.linspace(q0, q1, 20001))
    assert not dense.all()
    u_first = float(np.argmin(dense)) / 20000
    return arm, cm, q0, q1, u_first


def test_straight_line_through_a_thin_wall_is_caught(wall_case: tuple) -> None:
    arm, cm, q0, q1, u_first = wall_case
    c = cm.first_contact_on_segment(q0, q1)
    assert c is not None
    assert c.b == "wall" and c.kind is ContactKind.SCENE
    assert c.time is not None
    assert u_first - 1.0 / 20000 - 1e-6 <= c.time <= u_first + 1e-4
    np.testing.assert_allclose(c.q, q0 + c.time * (q1 - q0), atol=1e-12)
    assert not cm.segment_free(q0, q1)
    # the same line without the wall is free all along
    plain = CollisionModel.of(arm, scene=SceneSpec())
    assert plain.first_contact_on_segment(q0, q1) is None


def test_sampled_motion_coarser_than_the_wall_is_caught(wall_case: tuple) -> None:
    arm, cm, q0, q1, u_first = wall_case
    ts = np.linspace(0.0, 1.0, 4)  # time = fraction of the line
    qs = np.linspace(q0, q1, 4)
    step = np.abs(np.diff(qs, axis=0))

    def refine(t0: float, t1: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ft = np.linspace(t0, t1, 9)
        fq = q0 + ft[:, None] * (q1 - q0)
        return ft, fq, np.abs(np.diff(fq, axis=0))

    crossing = int(u_first * 3)  # the step that holds the first contact
    coarse = cm.first_contact_on_samples(ts, qs, step)
    assert coarse is not None  # a step that cannot be certified counts as a contact
    assert coarse.time is not None and coarse.time <= ts[crossing + 1]
    fine = cm.first_contact_on_samples(ts, qs, step, refine=refine)
    assert fine is not None and fine.b == "wall"
    assert fine.time is not None
    assert u_first - 1.0 / 20000 - 1e-6 <= fine.time <= u_first + 1.0 / 24 + 1e-9
    plain = CollisionModel.of(arm, scene=SceneSpec())
    assert plain.first_contact_on_samples(ts, qs, step, refine=refine) is None


# ---- interpreted kernels --------------------------------------------------------------------
def test_interpreted_kernels_give_the_compiled_numbers(
        arm_model: tuple[armctl.Arm, CollisionModel]) -> None:
    arm, cm = arm_model
    F, I = cm._F, cm._I  # noqa: E741
    qs = arm.sample(np.random.default_rng(8), 60)
    for name in ("min_slack",):
        py = K.interpreted(name)
        for q in qs:
            for stop in (-math.inf, 0.0):
                assert py(q, F, I, stop) == K.min_slack(q, F, I, stop)
    a, b = np.empty(cm.pair_count), np.empty(cm.pair_count)
    K.slacks(qs[0], F, I, a)
    K.interpreted("slacks")(qs[0], F, I, b)
    assert np.array_equal(a, b)
    fa, fb = np.empty(len(qs), dtype=np.bool_), np.empty(len(qs), dtype=np.bool_)
    K.free_batch(qs, F, I, fa)
    K.interpreted("free_batch")(qs, F, I, fb)
    assert np.array_equal(fa, fb) and 0 < fa.sum() < len(qs)


def test_capsules_are_placed_where_the_kinematics_puts_them() -> None:
    arm = armctl.load_arm("panda")
    cm = CollisionModel.of(arm, scene=SceneSpec())
    caps = [c for cs in collision_capsules(arm.spec).values() for c in cs]
    links = [link for link, cs in collision_capsules(arm.spec).items() for _ in cs]
    q = arm.sample(np.random.default_rng(9))
    T, C = np.empty((arm.dof, 12)), np.empty((K.CW, len(caps)))
    K._place(q, cm._F, cm._I, T, C)
    poses = arm.fk_all(q)
    for i, (link, c) in enumerate(zip(links, caps, strict=True)):
        t = poses[link]
        np.testing.assert_allclose(C[0:3, i], t[:3, :3] @ np.asarray(c.a) + t[:3, 3], atol=1e-14)
        np.testing.assert_allclose(C[3:6, i], t[:3, :3] @ np.asarray(c.b) + t[:3, 3], atol=1e-14)
        assert C[6, i] == c.radius
