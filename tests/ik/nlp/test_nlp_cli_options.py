import json
from pathlib import Path

import numpy as np
import pytest

from armctl.cli import main
from armctl.errors import InputError
from armctl.ik import IKOptions, PositionGoal
from armctl.ik.nlp import InHalfSpace, KeepOutSphere, Method, NLPOptions, OnPlane, build_count

DATA = Path(__file__).parent / "data"


def test_plain_ik_options_keep_budget_and_cap_iterations():
    opts = NLPOptions.from_options(IKOptions(max_iterations=500, time_limit=0.7, restarts=3,
                                             seed=9))
    assert (opts.time_limit, opts.restarts, opts.seed) == (0.7, 3, 9)
    assert opts.max_iterations == NLPOptions().max_iterations
    assert NLPOptions.from_options(IKOptions(max_iterations=5)).max_iterations == 5
    assert Method.AUTO.resolve(True) is Method.IPOPT
    assert Method.AUTO.resolve(False) is Method.SQP


def test_option_errors(ur5e):
    with pytest.raises(InputError, match="preferred posture has 2 values"):
        ur5e.ik(np.eye(4), solver="nlp", options=NLPOptions(preferred=(0.0, 1.0)))
    with pytest.raises(InputError):
        NLPOptions(damping=-1.0)
    with pytest.raises(InputError):
        KeepOutSphere([0, 0, 0], 0.1, link_radius=0.0)


def test_preferred_posture_chooses_among_redundant_answers(panda):
    # a position goal leaves 4 of 7 DOF free: the answer stays near the preferred posture
    q_pref = panda.middle()
    target = panda.fk(q_pref)[:3, 3]
    start = np.clip(q_pref + 0.4, panda.lower, panda.upper)
    res = panda.ik(PositionGoal(target), start, solver="nlp",
                   options=NLPOptions(preferred=tuple(q_pref), regularization=1e-3))
    assert res.success, res.message
    assert np.linalg.norm(res.q - q_pref) < 0.05


def test_streaming_with_hard_constraints_does_not_rebuild(ur5e):
    rng = np.random.default_rng(17)
    q = ur5e.sample(rng)
    p = ur5e.fk(q)[:3, 3]
    cons = [OnPlane(p, [0, 0, 1]), InHalfSpace(p - 0.1, [1, 0, 0])]
    res = ur5e.ik(PositionGoal(p), q, solver="nlp", constraints=cons)
    assert res.success, res.message
    builds = build_count()
    for k in range(10):  # the target slides along the plane
        p = p + np.array([0.003, -0.002, 0.0])
        res = ur5e.ik(PositionGoal(p), res.q, solver="nlp", constraints=cons)
        assert res.success, (k, res.message)
        assert abs(ur5e.fk(res.q)[2, 3] - p[2]) <= 1e-5
    assert build_count() == builds


def test_cli_plane_keep_out_and_goals_file(tmp_path, capsys):
    arm = str(DATA / "ur5e.yaml")
    rc = main(["ik", arm, "--xyz", "-0.5", "-0.2", "0.3", "--plane", "0", "0", "0.3", "0", "0",
               "1", "--keep-out", "0", "0", "0.8", "0.1", "--time-limit", "1", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0, out
    assert out["solver"] == "nlp"
    names = [c["name"] for c in out["constraints"]]
    assert any("on plane" in n for n in names) and any("keep out" in n for n in names)
    assert all(c["satisfied"] for c in out["constraints"])
    goals = tmp_path / "goals.yaml"
    goals.write_text("goals:\n  - {type: position, position: [-0.5, -0.2, 0.3]}\n"
                     "constraints:\n  - {type: halfspace, point: [0, 0, 0.2], normal: [0, 0, 1]}\n")
    rc = main(["ik", arm, "--goals", str(goals), "--time-limit", "1", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0, out
    assert out["constraints"][0]["satisfied"]
    # infeasible: two parallel planes; exit code 3 (no solution)
    rc = main(["ik", arm, "--xyz", "-0.5", "-0.2", "0.3", "--plane", "0", "0", "0.1", "0", "0",
               "1", "--plane", "0", "0", "0.5", "0", "0", "1", "--time-limit", "0.2"])
    assert rc == 3
    assert "infeasible" in capsys.readouterr().err
    rc = main(["ik", arm, "--xyz", "0", "0", "0.5", "--keep-out", "0", "0", "1"])
    assert rc == 2
    assert "--keep-out takes 4 numbers" in capsys.readouterr().err


def test_keep_out_sphere_violation_matches_dense_sampling(twoarm):
    from armctl.kinematics.capsules import arm_capsules, world_segments

    rng = np.random.default_rng(6)
    c = KeepOutSphere([0.0, 0.3, 0.45], 0.08)
    caps = arm_capsules(twoarm)
    ts = np.linspace(0.0, 1.0, 4001)[:, None]
    hits = 0
    for q in twoarm.sample(rng, 8):
        a, b = world_segments(twoarm, q, caps)
        depth = max(cap.radius + 0.08 - np.linalg.norm(a[k] + ts * (b[k] - a[k]) - c.center,
                                                       axis=1).min()
                    for k, cap in enumerate(caps))
        hits += depth > 0
        assert np.isclose(c.violation(twoarm, q), max(depth, 0.0), atol=1e-4)
    assert hits >= 1
