"""IK that respects collisions: solvers discard answers in contact, ``ik --all`` marks them.

The truth each answer is held to is the collision checker (:class:`CollisionModel`) and, for the
NLP's keep-out rows, a second implementation of the same distances
(:mod:`armctl.ik.nlp.scene`) compared with the checker's per-pair slacks.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import REPO

from armctl.arm import Arm, load_arm
from armctl.cli import main
from armctl.collision import CollisionModel
from armctl.config.scene import (
    TABLE,
    AllowedPair,
    AllowReason,
    CollisionSpec,
    Obstacle,
    SceneFrame,
    SceneSpec,
)
from armctl.config.schema import Box, Capsule, Cylinder, Mesh, Origin, Sphere
from armctl.errors import InputError
from armctl.ik import IKOptions, IKStatus, PositionGoal, solve_batch
from armctl.ik.nlp.scene import KeepOutOrientedBox, _segment_distance, scene_keep_out
from armctl.kinematics.capsules import arm_capsules

#: A tool pose in front of the UR5e, tool pointing down: 8 closed-form solutions.
POSE = np.array([[1.0, 0.0, 0.0, 0.45], [0.0, -1.0, 0.0, 0.1], [0.0, 0.0, -1.0, 0.3],
                 [0.0, 0.0, 0.0, 1.0]])
#: The same orientation 10 cm below the table top: every solution puts the wrist in the table.
BELOW = POSE.copy()
BELOW[2, 3] = -0.1


@pytest.fixture(scope="module")
def ur5e() -> Arm:
    return load_arm("ur5e")


@pytest.fixture(scope="module")
def table_only(ur5e: Arm) -> CollisionModel:
    return CollisionModel.of(ur5e)


@pytest.fixture(scope="module")
def crate(ur5e: Arm, table_only: CollisionModel) -> tuple[CollisionModel, np.ndarray]:
    """A box at the elbow of the nearest solution that is free with the table alone.

    Returns the checker of that scene and the solution (now in contact with the box).
    """
    sols = ur5e.ik_all(POSE, avoid=table_only)
    near = sols.valid[0]
    elbow = ur5e.fk(near, "forearm_link")[:3, 3]
    scene = SceneSpec(obstacles=(Obstacle("crate", Box((0.04, 0.04, 0.04),
                                                       Origin(tuple(elbow)))),))
    return CollisionModel.of(ur5e, scene), near


def _pose_error(arm: Arm, q: np.ndarray, target: np.ndarray) -> float:
    return float(np.linalg.norm(arm.fk(q)[:3, 3] - target[:3, 3]))


# ---- numerical solvers and auto ----------------------------------------------------------------
@pytest.mark.parametrize("solver", ["dls", "pinv", "jt", "auto", "analytic"])
def test_a_colliding_nearest_answer_gives_way_to_a_free_branch(ur5e, crate, solver):
    checker, near = crate
    sols = ur5e.ik_all(POSE)
    # the set-up: the start is itself a solution, in contact with the crate; another is free
    assert checker.contact(near) is not None and checker.contact(near).b == "crate"
    assert checker.free_batch(sols.valid).any()

    plain = ur5e.ik(POSE, near, solver)  # without a checker: the start's own branch, as before
    assert plain.success and plain.contact is None
    assert np.allclose(plain.q, near, atol=1e-3)
    assert not checker.free(plain.q)

    options = IKOptions(restarts=50, time_limit=2.0)
    res = ur5e.ik(POSE, near, solver, options=options, avoid=checker)
    assert res.success and res.status is IKStatus.CONVERGED and res.contact is None
    assert checker.free(res.q)
    assert _pose_error(ur5e, res.q, POSE) < 1e-4
    assert float(np.abs(res.q - near).max()) > 0.3  # another branch, not a nudge
    # a second implementation of the distance: no capsule of the arm within the box + padding
    box = KeepOutOrientedBox(np.eye(3), checker.scene.obstacles[0].shape.origin.xyz,
                             np.full(3, 0.02), padding=checker.scene.padding)
    assert box.violation(ur5e, res.q) == 0.0
    assert box.violation(ur5e, near) > 0.0
    # deterministic: the same seed, the same answer
    again = ur5e.ik(POSE, near, solver, options=options, avoid=checker)
    assert np.array_equal(again.q, res.q)


@pytest.mark.parametrize("solver", ["dls", "auto", "analytic"])
def test_a_goal_reachable_only_through_contact_fails_naming_the_contact(ur5e, table_only,
                                                                        solver):
    every = ur5e.ik_all(BELOW)
    assert len(every.valid) > 0 and not table_only.free_batch(every.valid).any()
    res = ur5e.ik(BELOW, None, solver, options=IKOptions(restarts=8), avoid=table_only)
    assert not res.success
    assert res.status is IKStatus.COLLIDES
    assert res.contact is not None and res.contact.b == TABLE
    assert res.contact.depth > 0.0
    assert math.isclose(res.contact.depth, table_only.contact(res.q).depth, abs_tol=1e-12)
    assert "collides" in res.message and f"'{res.contact.a}' and 'table'" in res.message
    assert _pose_error(ur5e, res.q, BELOW) < 1e-4  # the goal itself was met
    # without a checker nothing changes: the same goal succeeds
    assert ur5e.ik(BELOW, None, solver).success


def test_without_a_checker_results_carry_no_contact(ur5e):
    res = ur5e.ik(BELOW)
    assert res.success and res.contact is None


def test_a_checker_for_another_arm_is_refused(ur5e):
    other = CollisionModel.of(load_arm("so101"))
    with pytest.raises(InputError, match=r"another arm|joints differ"):
        ur5e.ik(POSE, avoid=other)


def test_batch_solves_colliding_rows_again(ur5e, crate):
    checker, near = crate
    res = solve_batch(ur5e, np.array([POSE, POSE, BELOW]), np.array([near, near, near]),
                      options=IKOptions(restarts=30, avoid=checker))
    assert res.success.tolist() == [True, True, False]
    assert res.status[2] is IKStatus.COLLIDES
    assert checker.free_batch(res.q[:2]).all()


# ---- ik_all marks --------------------------------------------------------------------------------
def test_ik_all_marks_agree_with_the_checker(ur5e, crate):
    checker, _ = crate
    rng = np.random.default_rng(7)
    seen_free = seen_hit = 0
    for pose in [POSE, BELOW, *(ur5e.fk(ur5e.sample(rng)) for _ in range(6))]:
        sols = ur5e.ik_all(pose, avoid=checker, variants=True)
        assert sols.contacts is not None and len(sols.contacts) == len(sols)
        for q, contact, free in zip(sols.q, sols.contacts, sols.collision_free, strict=True):
            assert free == checker.free(q) == (contact is None)
            if contact is not None:
                assert contact.depth > 0 and contact.b in (*checker.links, *checker.obstacles)
        assert len(sols.valid) == int((sols.within_limits & sols.collision_free).sum())
        distinct = sols.distinct([True] * ur5e.dof)
        assert distinct.contacts is not None
        assert distinct.collision_free.tolist() == checker.free_batch(distinct.q).tolist()
        seen_free += int(sols.collision_free.sum())
        seen_hit += int((~sols.collision_free).sum())
    assert seen_free > 0 and seen_hit > 0  # both marks occur
    with pytest.raises(InputError, match="not checked"):
        _ = ur5e.ik_all(POSE).collision_free


# ---- NLP keep-out from the scene ---------------------------------------------------------------
def _mesh(path: Path) -> Path:
    """A tetrahedron as an ASCII STL file."""
    v = np.array([[0, 0, 0], [0.06, 0, 0], [0, 0.04, 0], [0, 0, 0.05]], dtype=float)
    faces = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]
    lines = ["solid t"]
    for f in faces:
        lines += ["facet normal 0 0 0", "outer loop",
                  *(f"vertex {v[i][0]} {v[i][1]} {v[i][2]}" for i in f), "endloop", "endfacet"]
    path.write_text("\n".join([*lines, "endsolid t", ""]), encoding="utf-8")
    return path


def test_scene_keep_out_measures_what_the_checker_measures(ur5e, tmp_path):
    obstacles = (
        Obstacle("crate", Box((0.1, 0.2, 0.05), Origin((0.3, 0.1, 0.4), (0.3, 0.2, 0.5)))),
        Obstacle("ball", Sphere(0.06, Origin((0.2, -0.3, 0.5)))),
        Obstacle("pipe", Cylinder(0.03, 0.4, Origin((-0.3, 0.0, 0.3), (0.0, 1.2, 0.0)))),
        Obstacle("rod", Capsule(0.02, 0.3, Origin((0.4, 0.3, 0.2), (1.5, 0.0, 0.3)))),
        Obstacle("part", Mesh(_mesh(tmp_path / "t.stl"), origin=Origin((0.0, 0.4, 0.3)))),
        Obstacle("shelf", Box((0.3, 0.3, 0.02), Origin((0.5, 0.0, 0.6))), SceneFrame.WORLD),
    )
    scene = SceneSpec(obstacles=obstacles, padding=0.01,
                      base_in_world=Origin((0.1, 0.0, 0.2), (0.0, 0.0, 0.4)))
    base = CollisionModel.of(ur5e).allowed  # its matrix; one pair with an obstacle added
    user = AllowedPair("wrist_3_link", "crate", AllowReason.USER, "a fixture it may touch")
    checker = CollisionModel.of(ur5e, scene, CollisionSpec((*base.allowed, user)))
    zones = scene_keep_out(checker)
    assert sorted(z.name for z in zones) == sorted([TABLE, *(o.name for o in obstacles)])
    crate = next(z for z in zones if z.name == "crate")
    caps = arm_capsules(ur5e)
    assert crate.capsules is not None
    assert {caps[k].link for k in crate.capsules} == {c.link for c in caps} - {"wrist_3_link"}
    pairs = {z.name: [i for i in range(checker.pair_count) if checker.pair_names(i)[1] == z.name]
             for z in zones}
    rng = np.random.default_rng(11)
    hits = set()
    for _ in range(40):
        q = ur5e.sample(rng)
        slack = checker.slacks(q)
        for zone in zones:
            depth = max(0.0, -float(slack[pairs[zone.name]].min()))
            assert zone.violation(ur5e, q) == pytest.approx(depth, abs=1e-9), zone.name
            if depth > 0:
                hits.add(zone.name)
    assert len(hits) >= 4, hits  # most shapes are met: the comparison means something


def test_segment_distance_against_brute_force():
    rng = np.random.default_rng(5)
    ts = np.linspace(0.0, 1.0, 201)
    for k in range(120):
        a, b, c, d = rng.normal(size=(4, 3))
        if k % 5 == 0:
            b = a.copy()  # a point
        if k % 7 == 0:
            d = c + 0.7 * (b - a)  # parallel
        p = a + ts[:, None] * (b - a)
        q = c + ts[:, None] * (d - c)
        brute = float(np.min(np.linalg.norm(p[:, None] - q[None], axis=2)))
        exact = _segment_distance(a, b, c, d)
        # the grid's points lie on the segments: never closer; and within its spacing
        step = (np.linalg.norm(b - a) + np.linalg.norm(d - c)) / 200
        assert exact <= brute + 1e-12
        assert brute - exact <= step + 1e-12


def test_nlp_with_the_scene_returns_an_answer_the_checker_finds_free(ur5e):
    goal = PositionGoal([0.4, 0.2, 0.3])
    q0 = np.array([0.3, -1.2, 1.4, -1.5, -1.5, 0.0])
    plain = ur5e.ik(goal, q0, "nlp")
    assert plain.success
    at = {k: ur5e.fk(plain.q, k)[:3, 3] for k in ("upper_arm_link", "forearm_link",
                                                  "wrist_1_link")}
    mid = (at["upper_arm_link"] + at["forearm_link"]) / 2
    scene = SceneSpec(padding=0.01, obstacles=(
        Obstacle("crate", Box((0.06, 0.06, 0.06), Origin(tuple(at["forearm_link"] + [0, 0, 0.15]),
                                                        (0.0, 0.0, 0.5)))),
        Obstacle("ball", Sphere(0.03, Origin(tuple(at["wrist_1_link"] + [0, 0, 0.06])))),
        Obstacle("pipe", Cylinder(0.02, 0.3, Origin(tuple(mid + np.array([0, 0.25, 0])),
                                                    (0.0, 1.5708, 0.0)))),
        Obstacle("rod", Capsule(0.02, 0.3, Origin(tuple(at["wrist_1_link"] + [0, -0.1, 0]),
                                                  (1.5708, 0.0, 0.0)))),
    ))
    checker = CollisionModel.of(ur5e, scene)
    hit = {c.b for c in (checker.contact(plain.q),) if c is not None}
    assert hit, "the set-up: the answer found without the scene is in contact with it"
    res = ur5e.ik(goal, q0, "nlp", options=IKOptions(time_limit=3.0), avoid=checker)
    assert res.success and res.status is IKStatus.CONVERGED
    assert checker.free(res.q)
    assert np.linalg.norm(ur5e.fk(res.q)[:3, 3] - goal.position) < 1e-4
    held = {c.name for c in res.constraint_errors}
    assert {"table", "crate", "ball", "pipe", "rod"} <= {n.split("'")[1] for n in held}
    # the same zones given by hand as constraints: also free
    byhand = ur5e.ik(goal, q0, "nlp", options=IKOptions(time_limit=3.0),
                     constraints=scene_keep_out(checker))
    assert byhand.success and checker.free(byhand.q)


# ---- the command line ----------------------------------------------------------------------------
def _run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out = capsys.readouterr()
    return code, out.out, out.err


def _scene_file(path: Path, crate: tuple[CollisionModel, np.ndarray]) -> Path:
    x, y, z = (float(v) for v in crate[0].scene.obstacles[0].shape.origin.xyz)
    path.write_text("armctl: 1\n"
                    "obstacles:\n"
                    f"  - {{name: crate, shape: box, size: [0.04, 0.04, 0.04], "
                    f"origin: {{xyz: [{x!r}, {y!r}, {z!r}]}}}}\n", encoding="utf-8")
    return path


_GOAL = ("--xyz", "0.45", "0.1", "0.3", "--rpy", str(math.pi), "0", "0")


def test_cli_all_marks_each_solution(capsys, tmp_path, ur5e, crate):
    scene = _scene_file(tmp_path / "scene.yaml", crate)
    code, out, _ = _run(capsys, "ik", "ur5e", *_GOAL, "--solver", "analytic", "--all",
                        "--scene", str(scene), "--json")
    assert code == 0
    data = json.loads(out)
    assert data["collisions_checked"]
    checker = crate[0]
    marks = [s["collision_free"] for s in data["solutions"]]
    assert marks == checker.free_batch(np.array([s["q"] for s in data["solutions"]])).tolist()
    assert True in marks and False in marks
    for s in data["solutions"]:
        if not s["collision_free"]:
            assert s["contact"]["depth"] > 0 and len(s["contact"]["pair"]) == 2

    code, text, _ = _run(capsys, "ik", "ur5e", *_GOAL, "--solver", "analytic", "--all",
                         "--scene", str(scene))
    assert code == 0
    rows = [ln for ln in text.splitlines() if re.match(r"^\d+\s+(yes|no)\s", ln)]
    assert len(rows) == len(marks)
    for row, free in zip(rows, marks, strict=True):
        if free:
            assert row.rstrip().endswith("free")
        else:
            assert re.search(r"collides: \S+-\S+ \d+\.\d mm deep$", row.rstrip()), row
    assert "crate" in text

    code, text, _ = _run(capsys, "ik", "ur5e", *_GOAL, "--solver", "analytic", "--all",
                         "--no-collisions")
    assert code == 0 and "collides" not in text and "free" not in text


def test_cli_names_the_contact_when_every_answer_collides(capsys):
    below = ("--xyz", "0.45", "0.1", "-0.1", "--rpy", str(math.pi), "0", "0")
    code, out, _ = _run(capsys, "ik", "ur5e", *below, "--restarts", "5", "--json")
    assert code == 3
    err = json.loads(out)["error"]
    assert "collides" in err["message"] and "'table'" in err["message"]
    assert err["details"]["status"] == "collides"
    assert err["details"]["contact"]["pair"][1] == "table"
    assert err["details"]["contact"]["depth"] > 0
    code, out, _ = _run(capsys, "ik", "ur5e", *below, "--no-collisions", "--json")
    assert code == 0 and json.loads(out)["collisions_checked"] is False
    code, _, err_text = _run(capsys, "ik", "ur5e", *below, "--no-collisions", "--scene", "x.yaml")
    assert code == 2 and "--no-collisions" in err_text


# ---- the docs example ------------------------------------------------------------------------
def test_the_docs_collisions_example_runs():
    doc = (REPO / "docs" / "ik-methods.md").read_text(encoding="utf-8")
    section = doc.split("## Collisions", 1)[1].split("\n## ", 1)[0]
    code = re.search(r"```python\n(.*?)```", section, re.S)
    assert code is not None
    exec(compile(code.group(1), "docs/ik-methods.md", "exec"), {})
