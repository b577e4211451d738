"""The collision checker on arms with universal and ball joints, against independent truth.

* Link poses: the frames the collision kernels place capsules with, against the numeric
  forward kinematics and against a chain of 4x4 matrices built here from the arm file with
  scipy rotations (a ball joint's quaternion through ``Rotation.from_quat``), on random
  configurations with ball joints turned far, at the old gimbal-lock angle (the middle of three
  axes at 90 degrees) and near a half turn.
* Distances: every checked pair's distance against coal, the capsules and obstacles posed by
  that scipy chain (the table against the lowest point of a capsule, by hand); ``free``,
  ``contact`` and ``clearance`` against the same distances.
* The exact narrow phase: free exactly when the real shapes (a box, a cylinder, spheres,
  capsules) posed by the scipy chain keep their paddings, in coal.
* Continuous checks along the shortest arc of a ball joint, against dense samples of the arc;
  an arm laid on the table by its ball joint may rise, not sink.
* The figure with ball shoulders and hips: the same distances as the bundled three-axis figure
  at the same rotations, and the same distances as coal.
* The allowed-collision matrix and ``armctl collisions`` on the test arm.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml
from chain_truth import by_name, chain_poses, origin
from scipy.spatial.transform import Rotation

from armctl.collision import CollisionModel, generate_allowed
from armctl.collision import _kernels as K
from armctl.collision.allowed import adjacent_pairs
from armctl.collision.contact import ContactKind
from armctl.collision.single import clearance_once
from armctl.config import bundled_configs_dir, load_spec
from armctl.config.scene import AllowedPair, AllowReason, CollisionSpec, SceneSpec
from armctl.config.schema import JointType
from armctl.kinematics.capsules import collision_capsules
from armctl.kinematics.model import KinematicModel

coal = pytest.importorskip("coal")

ARM = Path(__file__).with_name("multi_dof_arm.yaml")
FIGURE = bundled_configs_dir() / "figure.yaml"


# ---- coal, posed by the chain -----------------------------------------------------------------
def _transform(t: np.ndarray):
    return coal.Transform3s(np.ascontiguousarray(t[:3, :3]), np.ascontiguousarray(t[:3, 3]))


def _capsule_geometry(a: np.ndarray, b: np.ndarray, radius: float):
    """A coal capsule between world points a and b, and its pose."""
    d = b - a
    length = float(np.linalg.norm(d))
    t = np.eye(4)
    t[:3, 3] = (a + b) / 2
    if length > 1e-12:
        t[:3, :3] = Rotation.align_vectors([d / length], [[0.0, 0.0, 1.0]])[0].as_matrix()
    return coal.Capsule(radius, length), t


def _obstacle_geometry(ob: dict):
    t = origin(ob.get("origin"))
    if ob["shape"] == "box":
        return coal.Box(*[float(v) for v in ob["size"]]), t
    if ob["shape"] == "sphere":
        return coal.Capsule(float(ob["radius"]), 0.0), t
    if ob["shape"] == "capsule":
        return coal.Capsule(float(ob["radius"]), float(ob["length"])), t
    raise AssertionError(ob["shape"])


def _coal_distance(ga, ta: np.ndarray, gb, tb: np.ndarray) -> float:
    req = coal.DistanceRequest()
    req.enable_signed_distance = True
    res = coal.DistanceResult()
    return float(coal.distance(ga, _transform(ta), gb, _transform(tb), req, res))


def truth_distances(cm: CollisionModel, doc: dict, q: np.ndarray) -> np.ndarray:
    """Per checked pair of ``cm`` its distance [m]: coal (links, obstacles) or by hand (table)."""
    model = cm.model
    poses = chain_poses(doc, by_name(model, q))
    caps = [(link, c) for link, cs in collision_capsules(model.spec).items() for c in cs]
    world = []
    for link, c in caps:
        t = poses[link]
        world.append((t[:3, :3] @ np.asarray(c.a) + t[:3, 3], t[:3, :3] @ np.asarray(c.b)
                      + t[:3, 3], c.radius))
    obstacles = {ob["name"]: ob for ob in (doc.get("scene") or {}).get("obstacles", [])}
    out = np.empty(cm.pair_count)
    for idx in range(cm.pair_count):
        i, j, kind = cm.pair_capsules(idx)
        a, b, r = world[i]
        if kind is ContactKind.SELF:
            out[idx] = _coal_distance(*_capsule_geometry(a, b, r),
                                      *_capsule_geometry(*world[j]))
        elif cm.obstacles[j] == "table":
            out[idx] = min(a[2], b[2]) - r - cm.scene.table.height
        else:
            out[idx] = _coal_distance(*_capsule_geometry(a, b, r),
                                      *_obstacle_geometry(obstacles[cm.obstacles[j]]))
    return out


def padding(cm: CollisionModel) -> np.ndarray:
    return np.array([cm.scene.padding if cm.pair_capsules(i)[2] is ContactKind.SCENE else 0.0
                     for i in range(cm.pair_count)])


# ---- configurations ---------------------------------------------------------------------------
def far_configurations(model: KinematicModel, rng: np.random.Generator, count: int) -> np.ndarray:
    """Random configurations; every ball joint turned far: uniform rotations, the gimbal-lock
    angle of three axes (x-y-z with the middle one at +-90 deg), and near a half turn."""
    qs = model.sample(rng, count)
    special = [Rotation.from_euler("XYZ", [0.7, math.pi / 2, -0.4]),
               Rotation.from_euler("XYZ", [-1.1, -math.pi / 2, 2.0]),
               Rotation.from_rotvec(np.array([0.3, -0.8, 0.52]) / np.linalg.norm(
                   [0.3, -0.8, 0.52]) * (math.pi - 1e-3)),
               Rotation.from_rotvec([0.0, 0.0, math.pi])]
    for j, jtype in enumerate(model.joint_types):
        if jtype is not JointType.BALL:
            continue
        sl = model.q_index(j)
        rots = Rotation.random(count, random_state=int(rng.integers(1 << 31)))
        quats = np.roll(rots.as_quat(), 1, axis=1)
        for k, r in enumerate(special):
            quats[k] = np.roll(r.as_quat(), 1)
        qs[:, sl] = quats
    return qs


@pytest.fixture(scope="module")
def arm() -> KinematicModel:
    return KinematicModel(load_spec(ARM))


@pytest.fixture(scope="module")
def doc() -> dict:
    return yaml.safe_load(ARM.read_text(encoding="utf-8"))


def adjacent_only(model: KinematicModel) -> CollisionSpec:
    """A matrix that leaves out the links joined by a joint, and nothing else."""
    return CollisionSpec(tuple(AllowedPair(*sorted(k), AllowReason.ADJACENT, f"joint {j!r}")
                               for k, j in adjacent_pairs(model).items()))


@pytest.fixture(scope="module")
def cm(arm: KinematicModel) -> CollisionModel:
    """Every pair checked but those joined by a joint, the file's scene."""
    return CollisionModel.of(arm, allowed=adjacent_only(arm))


# ---- link poses -------------------------------------------------------------------------------
@pytest.mark.parametrize("run", ["compiled", "interpreted"])
def test_link_poses_are_the_kinematics_and_an_independent_chain(
        arm: KinematicModel, doc: dict, cm: CollisionModel, run: str) -> None:
    place = K._place_any if run == "compiled" else K.interpreted("_place_any")
    f, i = cm.packed
    caps = [(link, c) for link, cs in collision_capsules(arm.spec).items() for c in cs]
    qs = far_configurations(arm, np.random.default_rng(1), 40 if run == "compiled" else 8)
    for q in qs:
        T = np.empty((len(arm.joint_names), 12))
        C = np.empty((K.CW, len(caps)))
        place(q, f, i, T, C)
        frames = arm.fk_frames(q)
        chain = chain_poses(doc, by_name(arm, q))
        for j, name in enumerate(arm.joint_names):
            child = arm.spec.joint(name).child
            np.testing.assert_array_equal(T[j].reshape(3, 4),
                                          frames[arm.frame_index(child)][:3])
            np.testing.assert_allclose(T[j].reshape(3, 4), chain[child][:3], atol=1e-13)
        for k, (link, c) in enumerate(caps):
            t = chain[link]
            np.testing.assert_allclose(C[0:3, k], t[:3, :3] @ np.asarray(c.a) + t[:3, 3],
                                       atol=1e-13)
            np.testing.assert_allclose(C[3:6, k], t[:3, :3] @ np.asarray(c.b) + t[:3, 3],
                                       atol=1e-13)


# ---- distances --------------------------------------------------------------------------------
def test_distances_and_answers_agree_with_coal(arm: KinematicModel, doc: dict,
                                               cm: CollisionModel) -> None:
    qs = far_configurations(arm, np.random.default_rng(2), 150)
    pad = padding(cm)
    batch = cm.slacks_batch(qs)
    free = cm.free_batch(qs)
    seen = {True: 0, False: 0}
    for r, q in enumerate(qs):
        truth = truth_distances(cm, doc, q)
        slack = cm.slacks(q)
        np.testing.assert_allclose(slack + pad, truth, atol=2e-6)
        np.testing.assert_array_equal(batch[r], slack)
        want_free = bool((truth - pad >= 1e-6).all())
        if want_free or (truth - pad < -1e-6).any():  # not within rounding of touching
            assert cm.free(q) is want_free and bool(free[r]) is want_free
            assert (cm.contact(q) is None) is want_free
            seen[want_free] += 1
        least = cm.clearance(q)
        k = int(np.argmin(truth - pad))
        assert least is not None and least.distance == pytest.approx(truth[k], abs=2e-6)
        if r < 5:  # the interpreted kernels (one configuration, no compiler): the same numbers
            assert clearance_once(cm, q) == least
    assert min(seen.values()) > 10  # both answers were checked


def test_a_quaternion_of_the_wrong_norm_or_length_is_refused(arm: KinematicModel,
                                                             cm: CollisionModel) -> None:
    from armctl.errors import InputError

    q = arm.neutral()
    q[arm.q_index("shoulder")] = [1.0, 0.1, 0.0, 0.0]
    with pytest.raises(InputError, match="shoulder"):
        cm.free(q)
    with pytest.raises(InputError, match="quaternion"):
        cm.clearance(np.zeros(arm.nv))


# ---- motions ----------------------------------------------------------------------------------
def _arc(arm: KinematicModel, a: np.ndarray, b: np.ndarray, count: int) -> np.ndarray:
    us = np.linspace(0.0, 1.0, count)
    return us, np.array([arm.interpolate(a, b, float(u)) for u in us])


def test_the_shortest_arc_is_checked_continuously(arm: KinematicModel) -> None:
    """A thin plate across the arc of the ball joint, missed by the arc's end samples."""
    from armctl.config.scene import Obstacle
    from armctl.config.schema import Box, Origin

    a = arm.neutral()
    a[arm.q_index("elbow")] = 0.3
    b = np.array(a)
    b[arm.q_index("shoulder")] = np.roll(Rotation.from_rotvec([0.0, 2.2, 0.0]).as_quat(), 1)
    plate = Obstacle("plate", Box(size=(0.3, 0.3, 0.004),
                                  origin=Origin(xyz=(0.25, 0.0, 0.35), rpy=(0.0, -0.9, 0.0))))
    cm = CollisionModel.of(arm, SceneSpec(table=None, obstacles=(plate,)), adjacent_only(arm))
    assert cm.free(a) and cm.free(b)
    us, qs = _arc(arm, a, b, 4001)
    free = cm.free_batch(qs)
    assert not free.all()
    first = us[int(np.argmin(free))]
    hit = cm.first_contact_on_segment(a, b)
    assert hit is not None and hit.b == "plate"
    assert hit.time <= first + 1e-9 and hit.time > first - 2e-3
    np.testing.assert_allclose(hit.q, arm.interpolate(a, b, hit.time), atol=1e-9)
    assert cm.slacks(hit.q).min() < 1e-4
    assert not cm.segment_free(a, b)
    # a motion sampled so coarsely that no sample touches the plate: not certified free;
    # refined along the arc, the plate is found where the dense samples find it
    span = np.abs(arm.difference(a, b))
    assert cm.first_contact_on_samples([0.0, 1.0], np.array([a, b]), span[None]) is not None

    def refine(t0: float, t1: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        ts = np.linspace(t0, t1, 5)
        qs = np.array([arm.interpolate(a, b, float(t)) for t in ts])
        return ts, qs, np.tile(span * (ts[1] - ts[0]), (4, 1))

    found = cm.first_contact_on_samples([0.0, 1.0], np.array([a, b]), span[None], refine,
                                        depth=12)
    assert found is not None and found.b == "plate"
    assert first - 2e-3 < found.time <= first + 1e-9
    # and a line beside the plate is free, as dense samples say
    c = np.array(a)
    c[arm.q_index("shoulder")] = np.roll(Rotation.from_rotvec([0.0, 0.0, 2.5]).as_quat(), 1)
    assert cm.free_batch(_arc(arm, a, c, 2001)[1]).all()
    assert cm.first_contact_on_segment(a, c) is None and cm.segment_free(a, c)


def test_random_arcs_agree_with_dense_samples(arm: KinematicModel, cm: CollisionModel) -> None:
    rng = np.random.default_rng(5)
    qs = arm.sample(rng, 400)
    free = qs[cm.free_batch(qs)]
    seen = {True: 0, False: 0}
    for k in range(0, 24, 2):
        a, b = free[k], free[k + 1]
        us, arc = _arc(arm, a, b, 1501)
        dense = cm.free_batch(arc)
        hit = cm.first_contact_on_segment(a, b)
        if not dense.all():
            assert hit is not None and hit.time <= us[int(np.argmin(dense))] + 1e-9
        if hit is None:
            assert dense.all()
        else:
            assert cm.slacks(hit.q).min() < 1e-4
        seen[hit is None] += 1
        # the same arc as a sampled motion (20 samples, travels bounded by the tangent step)
        span = np.abs(arm.difference(a, b))
        ts = np.linspace(0.0, 1.0, 20)

        def refine(t0: float, t1: float, a=a, b=b, span=span):
            sub = np.linspace(t0, t1, 9)
            return sub, np.array([arm.interpolate(a, b, float(t)) for t in sub]), np.tile(
                span * (sub[1] - sub[0]), (8, 1))

        found = cm.first_contact_on_samples(ts, _arc(arm, a, b, 20)[1],
                                            np.tile(span / 19, (19, 1)), refine, depth=20)
        assert (found is None) == (hit is None)
        if found is not None and not dense.all():
            assert found.time <= us[int(np.argmin(dense))] + 1e-9
    assert min(seen.values()) >= 2  # lines in contact and free lines were both checked


def test_universal_joints_alone_take_the_compiled_line(tmp_path: Path) -> None:
    """Without ball joints the line is straight in q and the compiled bisection checks it."""
    doc = yaml.safe_load(ARM.read_text(encoding="utf-8"))
    shoulder = doc["joints"][0]
    shoulder.update(type="universal", axes=[[0, 0, 1], [0, 1, 0]],
                    limits=[{"lower": -3, "upper": 3}, {"lower": -2, "upper": 2}])
    del shoulder["axis"]
    doc["poses"] = {"home": {"shoulder": [0, 0], "elbow": 0.6, "wrist": [0.2, -0.3]}}
    path = tmp_path / "universal_arm.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    arm = KinematicModel(load_spec(path))
    assert arm.nq == arm.nv == len(arm.joint_names) + 2
    cm = CollisionModel.of(arm, allowed=adjacent_only(arm))
    rng = np.random.default_rng(6)
    qs = arm.sample(rng, 200)
    free = qs[cm.free_batch(qs)]
    for q in qs[:20]:
        np.testing.assert_allclose(cm.slacks(q) + padding(cm), truth_distances(cm, doc, q),
                                   atol=2e-6)
    seen = {True: 0, False: 0}
    for k in range(0, 24, 2):
        a, b = free[k], free[k + 1]
        us = np.linspace(0.0, 1.0, 1501)
        dense = cm.free_batch(a + us[:, None] * (b - a))
        hit = cm.first_contact_on_segment(a, b)
        if hit is None:
            assert dense.all()
        if not dense.all():
            assert hit is not None and hit.time <= us[int(np.argmin(dense))] + 1e-9
        seen[hit is None] += 1
    assert min(seen.values()) >= 2  # lines in contact and free lines were both checked


# ---- the figure with ball shoulders and hips --------------------------------------------------
def _three_axis_figure(folder: Path) -> Path:
    """The bundled figure with each ball joint as three revolute axes (the benchmark's twin)."""
    import importlib.util
    import sys

    tools = Path(__file__).resolve().parents[2] / "tools"
    sys.path.insert(0, str(tools))  # the tool imports its neighbour _benchdoc
    spec = importlib.util.spec_from_file_location("bench_ball_ik", tools / "bench_ball_ik.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out: Path = module.three_axis_twin(folder)
    return out


def test_the_ball_figure_has_the_distances_of_the_three_axis_figure_and_of_coal(
        tmp_path: Path) -> None:
    three = KinematicModel(load_spec(_three_axis_figure(tmp_path)))
    path = FIGURE
    ball = KinematicModel(load_spec(FIGURE))
    assert len(ball.multi_dof_joints) == 4 and ball.nv == three.dof
    scene = SceneSpec(table=None)
    cb = CollisionModel.of(ball, scene, adjacent_only(ball))
    c3 = CollisionModel.of(three, scene, adjacent_only(three))
    pairs3 = {frozenset(c3.pair_names(i)[:2]): i for i in range(c3.pair_count)}
    common = [(i, pairs3[frozenset(cb.pair_names(i)[:2])]) for i in range(cb.pair_count)
              if frozenset(cb.pair_names(i)[:2]) in pairs3]
    assert len(common) > 100
    names = list(three.joint_names)
    doc = yaml.safe_load(path.read_text(encoding="utf-8"))
    rng = np.random.default_rng(7)
    for r in range(30):
        q3 = rng.uniform(three.lower, three.upper)
        if r < 4:  # the middle axis of every shoulder and hip at +-90 deg: gimbal lock
            for n in names:
                if n.endswith("_2"):
                    q3[names.index(n)] = math.copysign(math.pi / 2, r - 1.5)
        qb = np.zeros(ball.nq)
        for j in ball.spec.actuated_joints:
            idx = ball.q_index(j.name)
            if j.type is JointType.BALL:
                rot = Rotation.identity()
                for k in (1, 2, 3):
                    spec = three.spec.joint(f"{j.name}_{k}")
                    rot = rot * Rotation.from_rotvec(np.asarray(spec.axis)
                                                     * q3[names.index(spec.name)])
                qb[idx] = np.roll(rot.as_quat(), 1)
            else:
                qb[idx] = q3[names.index(j.name)]
        sb, s3 = cb.slacks(qb), c3.slacks(q3)
        for i, k in common:
            assert sb[i] == pytest.approx(s3[k], abs=1e-12)
        if r < 8:
            np.testing.assert_allclose(sb + padding(cb), truth_distances(cb, doc, qb), atol=2e-6)
        assert cb.free(qb) == bool((sb >= 0).all())


# ---- the matrix and the command ---------------------------------------------------------------
def test_the_matrix_is_found_by_sampling_rotations(arm: KinematicModel, doc: dict) -> None:
    spec = generate_allowed(arm, samples=3000, seed=4)
    assert spec == generate_allowed(arm, samples=3000, seed=4)
    by = {frozenset((p.a, p.b)): p for p in spec.allowed}
    assert by[frozenset(("base", "upper"))].reason.value == "adjacent"
    assert by[frozenset(("fore", "hand"))].reason.value == "adjacent"
    assert "bent" in by[frozenset(("hand", "table"))].note  # in contact at a named pose
    # every pair left checked is one that some configuration brings into contact: the probe
    # of the sampling (no padding, every pair) found one; check it again against coal
    probe = CollisionModel(arm, SceneSpec(obstacles=(), padding=0.0), CollisionSpec())
    qs = far_configurations(arm, np.random.default_rng(4), 3000)
    sl = probe.slacks_batch(qs)
    for idx in range(probe.pair_count):
        key = frozenset(probe.pair_names(idx)[:2])
        if key in by:
            continue
        r = int(np.argmin(sl[:, idx]))
        if sl[r, idx] < -1e-6:  # a contact: the same pair in coal
            assert truth_distances(probe, doc, qs[r])[idx] < 0.0
    cm = CollisionModel.of(arm)  # the matrix found by sampling, the file's scene
    assert cm.pair_count < CollisionModel.of(arm, allowed=adjacent_only(arm)).pair_count


def test_armctl_collisions_on_an_arm_with_ball_joints(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.cli import main

    path = tmp_path / ARM.name
    shutil.copyfile(ARM, path)
    assert main(["collisions", str(path), "--generate", "--samples", "2000", "--write",
                 "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["source"] == "generated" and data["written"]
    reasons = {frozenset(p["links"]): p["reason"] for p in data["allowed"]}
    assert reasons[frozenset(("base", "upper"))] == "adjacent"
    assert main(["collisions", str(path)]) == 0
    out = capsys.readouterr().out
    assert "allowed-collision matrix from the file" in out and "base / upper" in out
    arm = KinematicModel(load_spec(path))
    assert arm.spec.collision is not None
    assert len(arm.spec.collision.allowed) == len(data["allowed"])


def test_the_search_steps_stay_inside_a_ball_joints_cone_and_twist(tmp_path: Path) -> None:
    """The local search of the matrix moves a limited ball joint by rotation vectors and keeps
    it inside its limits; the swing it measures is the angle of the turned axis (scipy)."""
    from armctl.collision.allowed import _moved, _swing_twist_batch

    doc = yaml.safe_load(ARM.read_text(encoding="utf-8"))
    doc["joints"][0]["limits"] = {"swing": "50 deg", "twist": {"lower": "-40 deg",
                                                             "upper": "30 deg"}}
    doc.pop("poses")
    path = tmp_path / "limited.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    arm = KinematicModel(load_spec(path))
    rng = np.random.default_rng(9)
    cur = arm.sample(rng, 300)
    assert all(arm.within_limits(q) for q in cur)
    moved = _moved(arm, cur, rng.normal(scale=0.6, size=(300, arm.nv)))
    assert all(arm.within_limits(q, tol=1e-9) for q in moved)
    sl = arm.q_index("shoulder")
    assert np.abs(np.linalg.norm(moved[:, sl], axis=1) - 1.0).max() < 1e-12
    assert (np.abs(moved[:, sl] - cur[:, sl]).max(axis=1) > 1e-6).mean() > 0.5  # they moved
    quats = Rotation.random(500, random_state=3)
    axis = np.array([0.0, 0.0, 1.0])
    swing, twist = _swing_twist_batch(np.roll(quats.as_quat(), 1, axis=1), axis)
    np.testing.assert_allclose(swing, np.arccos(np.clip(quats.apply(axis) @ axis, -1, 1)),
                               atol=1e-7)
    assert np.all(np.abs(twist) <= math.pi)
    unit = Rotation.from_rotvec(np.outer(rng.uniform(-3, 3, 50), axis))  # pure twists
    _, t = _swing_twist_batch(np.roll(unit.as_quat(), 1, axis=1), axis)
    np.testing.assert_allclose(t, unit.as_rotvec() @ axis, atol=1e-12)


def test_an_arm_lying_on_the_table_may_rise_through_its_ball_joint(arm: KinematicModel,
                                                                   cm: CollisionModel) -> None:
    """Laid down by its ball shoulder, the arm is in contact with the table; the model that
    lets it escape allows that contact, then rising out of it, never going deeper."""
    def lean(angle: float) -> np.ndarray:
        q = arm.neutral()
        q[arm.q_index("shoulder")] = np.roll(Rotation.from_rotvec([0.0, angle, 0.0]).as_quat(), 1)
        return q

    down = lean(-1.75)
    touching = cm.contact(down)
    assert touching is not None and touching.b == "table"
    esc = cm.escaping(down)
    assert esc.free(down) and esc.segment_free(down, lean(-1.2))
    assert not esc.free(lean(-1.9))  # deeper into the table
    assert esc.first_contact_on_segment(down, lean(-1.9)) is not None


# ---- the exact narrow phase -------------------------------------------------------------------
def _shape_geometry(shape: dict, pose: np.ndarray):
    """A link or obstacle shape of the arm file in coal, its pose, and its lowest z [m]."""
    t = pose @ origin(shape.get("origin"))
    kind = shape["shape"]
    z = t[:3, 2]
    if kind == "box":
        half = np.asarray(shape["size"], float) / 2
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        low = float(((corners * half) @ t[:3, :3].T + t[:3, 3])[:, 2].min())
        return coal.Box(*[float(v) for v in shape["size"]]), t, low
    if kind == "cylinder":
        r, h = float(shape["radius"]), float(shape["length"])
        low = t[2, 3] - abs(z[2]) * h / 2 - r * math.sqrt(max(0.0, 1.0 - z[2] ** 2))
        return coal.Cylinder(r, h), t, low
    r = float(shape["radius"])
    h = float(shape.get("length", 0.0))
    return coal.Capsule(r, h), t, t[2, 3] - abs(z[2]) * h / 2 - r


def shape_distances(cm: CollisionModel, doc: dict, q: np.ndarray) -> dict[frozenset, float]:
    """Per checked pair of names, the least distance between their real shapes [m]."""
    poses = chain_poses(doc, by_name(cm.model, q))
    links = {lk["name"]: [_shape_geometry(s, poses[lk["name"]]) for s in lk["collision"]]
             for lk in doc["links"]}
    obstacles = {ob["name"]: _shape_geometry(ob, np.eye(4))
                 for ob in (doc.get("scene") or {}).get("obstacles", [])}
    out: dict[frozenset, float] = {}
    for idx in range(cm.pair_count):
        a, b, kind = cm.pair_names(idx)
        key = frozenset((a, b))
        if key in out:
            continue
        if b == "table":
            out[key] = min(low for _, _, low in links[a]) - cm.scene.table.height
            continue
        others = links[b] if kind is ContactKind.SELF else [obstacles[b]]
        out[key] = min(_coal_distance(ga, ta, gb, tb)
                       for ga, ta, _ in links[a] for gb, tb, _ in others)
    return out


def test_the_exact_narrow_phase_agrees_with_the_real_shapes(arm: KinematicModel,
                                                            doc: dict) -> None:
    """With ``exact``, a configuration is free exactly when the real shapes (a box, a cylinder,
    spheres and capsules) keep their paddings, posed by the independent chain."""
    scene = CollisionModel.of(arm).scene
    exact = CollisionModel.of(arm, SceneSpec(table=scene.table, obstacles=scene.obstacles,
                                             padding=scene.padding, exact=True),
                              adjacent_only(arm))
    assert exact.exact is not None
    capsules = CollisionModel.of(arm, SceneSpec(table=scene.table, obstacles=scene.obstacles,
                                                padding=scene.padding), adjacent_only(arm))
    many = far_configurations(arm, np.random.default_rng(12), 3000)
    by_capsules, by_shapes = capsules.free_batch(many), exact.free_batch(many)
    assert not (by_capsules & ~by_shapes).any()  # the capsules contain the shapes
    changed = np.flatnonzero(by_shapes & ~by_capsules)
    assert len(changed) >= 10  # the real shapes decide some answers
    qs = np.concatenate([many[changed[:30]], many[:60]])
    seen = {True: 0, False: 0}
    for q in qs:
        truth = shape_distances(exact, doc, q)
        margin = min(d - (exact.scene.padding if "table" in k or k & set(exact.obstacles)
                          else 0.0) for k, d in truth.items())
        least = exact.clearance(q)
        assert least is not None
        assert least.distance <= truth[frozenset((least.a, least.b))] + 1e-6  # a lower bound
        if abs(margin) > 1e-6:
            want = bool(margin > 0)
            assert exact.free(q) is want
            seen[want] += 1
    assert min(seen.values()) > 10
