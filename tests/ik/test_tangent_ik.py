"""IK on arms with ball and universal joints (armctl.ik.tangent): every method reaches position
and pose goals from random starts, answers lie inside the limits (cone and twist included),
success only when forward kinematics meets the goal."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import armctl
from armctl.errors import InputError
from armctl.ik import PoseGoal, PositionGoal

ARM = """armctl: 1
name: b
base: base
joints:
  - name: shoulder
    type: ball
    parent: base
    child: upper
    origin: {xyz: [0, 0, 0.1]}
    limits: {swing: 150 deg, twist: {lower: -150 deg, upper: 150 deg}}
  - name: elbow
    type: revolute
    parent: upper
    child: fore
    origin: {xyz: [0, 0, 0.3]}
    axis: [0, 1, 0]
    limits: {lower: -2.5, upper: 2.5}
  - name: wrist
    type: ball
    parent: fore
    child: hand
    origin: {xyz: [0, 0, 0.25]}
    limits: {swing: 100 deg}
frames:
  - name: tcp
    parent: hand
    origin: {xyz: [0, 0, 0.08]}
"""

METHODS = ("auto", "dls", "pinv", "jt", "ccd", "ccd-jt")


@pytest.fixture(scope="module")
def arm(tmp_path_factory: pytest.TempPathFactory) -> armctl.Arm:
    p = tmp_path_factory.mktemp("arm") / "arm.yaml"
    p.write_text(ARM)
    return armctl.load_arm(p)


@pytest.mark.parametrize("method", METHODS)
def test_position_goals_from_random_starts(arm: armctl.Arm, method: str) -> None:
    rng = np.random.default_rng(METHODS.index(method))
    opts = armctl.ik.IKOptions(max_iterations=200, restarts=20, time_limit=5.0, seed=1)
    for _ in range(4):
        target = arm.fk(arm.sample(rng))[:3, 3]
        res = arm.ik(PositionGoal(target), q0=arm.sample(rng), solver=method, options=opts)
        assert res.success, (method, res.message)
        assert np.linalg.norm(arm.fk(res.q)[:3, 3] - target) < 1e-4
        assert arm.within_limits(res.q)
        assert abs(np.linalg.norm(res.q[0:4]) - 1) < 1e-9


@pytest.mark.parametrize("method", ("auto", "dls", "pinv", "ccd-jt", "ccd"))
def test_pose_goals(arm: armctl.Arm, method: str) -> None:
    rng = np.random.default_rng(5)
    opts = armctl.ik.IKOptions(max_iterations=300, restarts=30, time_limit=10.0, seed=2)
    for _ in range(3):
        target = arm.fk(arm.sample(rng))
        res = arm.ik(PoseGoal(target), q0=arm.sample(rng), solver=method, options=opts)
        assert res.success, (method, res.message)
        np.testing.assert_allclose(arm.fk(res.q), target, atol=1e-4)
        assert arm.within_limits(res.q)


def test_the_old_singular_middle_angle_is_reached(arm: armctl.Arm) -> None:
    # the shoulder turned 90 deg about y (the middle angle where the Euler expansion locked),
    # then a turn about the lost axis
    q = arm.neutral()
    q[0:4] = Rotation.from_euler("xyz", [0.0, math.pi / 2, 0.4]).as_quat(scalar_first=True)
    target = arm.fk(q)
    res = arm.ik(PoseGoal(target), q0=arm.neutral(), solver="dls")
    assert res.success
    np.testing.assert_allclose(arm.fk(res.q), target, atol=1e-4)


def test_unreachable_is_no_success(arm: armctl.Arm) -> None:
    opts = armctl.ik.IKOptions(max_iterations=50, restarts=2, time_limit=2.0)
    res = arm.ik(PositionGoal([2.0, 0.0, 0.0]), solver="dls", options=opts)
    assert not res.success
    assert res.status is not armctl.ik.IKStatus.SINGULAR  # stretched at the nearest point
    assert arm.within_limits(res.q)


@pytest.mark.parametrize("method", ["pinv", "dls", "jt"])
def test_a_stretched_arm_with_its_target_on_its_line(arm: armctl.Arm, method: str) -> None:
    """Straight up (every joint at rest), target on the arm's own line: the Jacobian has lost
    the radial direction, the step is zero; the failure is diagnosed as singular (the probes
    span the null space of the tangent columns) and CCD moves where they cannot."""
    from armctl.ik.singular import goal_jacobian

    q0 = arm.neutral()
    q0[arm.q_index("elbow")] = 0.0
    tip = arm.fk(q0)[:3, 3]
    goal = PositionGoal(tip - np.array([0.0, 0.0, 0.15]))  # 15 cm nearer, on the same line
    assert np.linalg.svd(goal_jacobian(arm, [goal], q0), compute_uv=False)[-1] < 1e-12
    opts = armctl.ik.IKOptions(max_iterations=30, restarts=0)
    res = arm.ik(goal, q0, method, options=opts)
    assert not res.success
    assert res.status is armctl.ik.IKStatus.SINGULAR, res.message  # the probes found it
    assert np.linalg.norm(arm.fk(res.q)[:3, 3] - tip) < 1e-9  # it did not move
    ccd = arm.ik(goal, q0, "ccd", options=opts)
    assert np.linalg.norm(arm.fk(ccd.q)[:3, 3] - tip) > 0.05


def test_what_the_tangent_methods_do_not_take(arm: armctl.Arm) -> None:
    from armctl.ik.errors import UnsupportedGoalError
    from armctl.ik.nlp import OnPlane

    with pytest.raises(InputError, match="solver 'analytic' supports 1-DOF joints only"):
        arm.ik(PositionGoal([0.1, 0, 0.5]), solver="analytic")
    with pytest.raises(UnsupportedGoalError, match=r"does not accept constraints.*nlp"):
        arm.ik(PositionGoal([0.1, 0, 0.5]), solver="dls",
               constraints=[OnPlane([0, 0, 0.5], [0, 0, 1])])


def test_cli_ik_on_a_ball_arm(tmp_path_factory: pytest.TempPathFactory,
                              capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from armctl.cli import main

    p = tmp_path_factory.mktemp("cli") / "arm.yaml"
    p.write_text(ARM)
    assert main(["ik", str(p), "--xyz", "0.1", "0", "0.5", "--no-collisions", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["success"]
    arm = armctl.load_arm(p)
    np.testing.assert_allclose(arm.fk(np.array(data["q"]))[:3, 3], [0.1, 0, 0.5], atol=1e-4)
    assert len(data["joints"]["shoulder"]) == 4


@pytest.mark.parametrize("method", ["dls", "ccd", "nlp"])
def test_collision_avoidance_on_an_arm_with_ball_and_universal_joints(method: str) -> None:
    """Goals whose plain answers collide with the arm's scene (a wall, a lamp, a post) or
    itself: with the checker the answers reach the goal free of contact (the checker is tested
    against coal in tests/collision/test_multi_dof.py)."""
    from pathlib import Path

    from armctl.collision import CollisionModel

    arm = armctl.load_arm(Path(__file__).parents[1] / "collision" / "multi_dof_arm.yaml")
    checker = CollisionModel.of(arm)
    rng = np.random.default_rng(3)
    opts = armctl.ik.IKOptions(restarts=30, time_limit=10.0)
    avoided = 0
    for i in range(40):
        qt = arm.sample(rng)
        if checker.contact(qt) is not None:
            continue
        goal = PositionGoal(arm.fk(qt)[:3, 3])
        plain = arm.ik(goal, solver=method, options=replace(opts, seed=i))
        if plain.success and checker.contact(plain.q) is None:
            continue  # the plain answer is free already
        res = arm.ik(goal, solver=method, options=replace(opts, seed=i), avoid=checker)
        assert res.success, (i, res.message)
        assert checker.contact(res.q) is None and res.contact is None
        np.testing.assert_allclose(arm.fk(res.q)[:3, 3], goal.position, atol=1e-4)
        assert arm.within_limits(res.q)
        avoided += 1
        if avoided == 2:
            break
    assert avoided == 2  # goals whose plain answers collide were met


def test_a_goal_reached_only_in_contact_is_no_success() -> None:
    """The tool inside the wall: every answer collides, the shallowest is returned, and the
    result says it is in contact."""
    from pathlib import Path

    from armctl.collision import CollisionModel

    arm = armctl.load_arm(Path(__file__).parents[1] / "collision" / "multi_dof_arm.yaml")
    checker = CollisionModel.of(arm)
    wall = np.array([0.4, 0.0, 0.25])  # the wall box's centre
    res = arm.ik(PositionGoal(wall), solver="dls",
                 options=armctl.ik.IKOptions(restarts=4, seed=0), avoid=checker)
    assert not res.success
    assert res.contact is not None and checker.contact(res.q) is not None


def test_restarts_keep_the_joints_that_move_no_goal() -> None:
    """A goal for the right palm that needs restarts: the legs, the head and the left arm of
    the figure keep their start values (the note of `armctl ik` says so)."""
    fig = armctl.load_arm("figure")
    start = fig.named_pose("stand")
    moving = {j for j in fig.chain("right_palm")}
    opts = armctl.ik.IKOptions(max_iterations=3, restarts=6, seed=2)
    res = fig.ik(PositionGoal([0.0, 0.0, 1.3], frame="right_palm"), start, "dls", options=opts)
    assert res.restarts >= 1
    for j, name in enumerate(fig.joint_names):
        if j not in moving:
            np.testing.assert_array_equal(res.q[fig.q_index(name)], start[fig.q_index(name)],
                                          err_msg=name)


def test_cli_full_pose_counts_degrees_of_freedom(capsys: pytest.CaptureFixture[str]) -> None:
    """The right palm of the figure has 7 degrees of freedom in 5 joints (a ball shoulder):
    a full pose is solved without --force-pose; a ball joint's --from outside its cone names
    the swing."""
    from armctl.cli import main

    fig = armctl.load_arm("figure")
    q = fig.sample(np.random.default_rng(4))
    pose = fig.fk(q, "right_palm")
    quat = Rotation.from_matrix(pose[:3, :3]).as_quat(scalar_first=True)
    code = main(["ik", "figure", "--xyz", *(f"{v:.9f}" for v in pose[:3, 3]), "--quat",
                 *(f"{v:.9f}" for v in quat), "--no-collisions", "--json"])
    out = capsys.readouterr()
    assert code == 0, out.err
    start = fig.named_pose("stand")
    start[fig.q_index("right_shoulder")] = [math.cos(0.95), 0.0, 0.0, math.sin(0.95)]  # 109 deg
    code = main(["ik", "figure", "--xyz", "0.3", "-0.3", "1.2", "--from",
                 *(f"{v:.9f}" for v in start)])
    err = capsys.readouterr().err
    assert code == 2 and "'right_shoulder'" in err and "swing" in err, err
    assert "limits.swing" in err and "Traceback" not in err
