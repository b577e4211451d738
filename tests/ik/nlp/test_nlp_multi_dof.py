"""The NLP solver on arms with universal and ball joints.

The symbolic FK against the compiled FK; a ball joint's limit rows against the model's own limit
check and against swing and twist computed independently with scipy.spatial.transform; answers
from random starts, at the old gimbal-lock angle, for two end effectors at once, with
constraints, and goals outside the cone or the twist range that must fail.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import armctl
from armctl.arm import Arm, load_arm
from armctl.errors import InputError
from armctl.ik import OrientationGoal, PoseGoal, PositionGoal
from armctl.ik.nlp import KeepOutSphere, NLPOptions, OnPlane
from armctl.kinematics.symbolic import ball_limit_rows, fk_function

BALL_ARM = Path(__file__).parents[2] / "data" / "ball_arm.yaml"


def _write(folder: Path, text: str, name: str = "arm.yaml") -> Arm:
    path = folder / name
    path.write_text(text)
    return load_arm(path)


def _one_ball(folder: Path, limits: str, name: str = "arm.yaml") -> Arm:
    """A ball joint with twist axis z and a 0.3 m link along it to the frame ``tip``."""
    return _write(folder, f"""armctl: 1
name: one_ball
base: base
joints:
  - name: hip
    type: ball
    parent: base
    child: leg
    axis: [0, 0, 1]
    limits: {limits}
frames:
  - {{name: tip, parent: leg, origin: {{xyz: [0, 0, 0.3]}}}}
""", name)


def scipy_swing_twist(quat: np.ndarray, axis: np.ndarray) -> tuple[float, float]:
    """Swing and twist [rad] by scipy alone: the swing the shortest rotation taking the axis to
    its image, the twist the remaining turn about the axis."""
    rot = Rotation.from_quat(quat, scalar_first=True)
    moved = rot.apply(axis)
    cross = np.cross(axis, moved)
    swing = math.atan2(float(np.linalg.norm(cross)), float(axis @ moved))
    if np.linalg.norm(cross) > 1e-12:
        swing_rot = Rotation.from_rotvec(cross / np.linalg.norm(cross) * swing)
    else:
        swing_rot = Rotation.identity()
    rest = (swing_rot.inv() * rot).as_rotvec()
    twist = float(rest @ axis)  # rest is a turn about the axis
    assert np.linalg.norm(rest - twist * axis) < 1e-6
    return swing, twist


@pytest.fixture(scope="module")
def ball_arm() -> Arm:
    return load_arm(BALL_ARM)


def test_symbolic_fk_equals_compiled_fk_on_random_q(ball_arm: Arm) -> None:
    rng = np.random.default_rng(11)
    qs = ball_arm.sample(rng, 15)
    for frame in ball_arm.frame_names:
        f = fk_function(ball_arm, frame)
        for q in qs:
            np.testing.assert_allclose(np.array(f(q)), ball_arm.fk(q, frame), atol=1e-12)
    # a quaternion off unit norm gives the same rotation, as in the compiled kernels
    q = qs[0].copy()
    q[0:4] *= 1.7
    np.testing.assert_allclose(np.array(fk_function(ball_arm)(q)), ball_arm.fk(qs[0]),
                               atol=1e-12)


@pytest.mark.parametrize("limits", [
    "{swing: 30 deg, twist: {lower: -20 deg, upper: 60 deg}}",
    "{swing: 90 deg}",
    "{swing: 150 deg, twist: {lower: -170 deg, upper: 100 deg}}",
    "{twist: {lower: -45 deg, upper: 45 deg}}",
])
def test_ball_limit_rows_match_the_model_and_scipy(tmp_path: Path, limits: str) -> None:
    import casadi as ca

    arm = _one_ball(tmp_path, limits)
    sym = ca.SX.sym("q", 4)
    rows = ball_limit_rows(arm, sym)
    assert rows[0].what == "unit norm" and rows[0].equality
    ineq = ca.Function("g", [sym], [ca.vertcat(*[r.expr for r in rows[1:]])])
    spec = arm.spec.actuated_joints[0]
    axis = np.array(spec.axis)
    rng = np.random.default_rng(4)
    seen = {True: 0, False: 0}
    for k in range(3000):
        if k % 2:  # uniform over every rotation
            quat = rng.normal(size=4)
        else:  # near the limits: inside, turned a little
            quat = (Rotation.from_quat(arm.sample(rng), scalar_first=True)
                    * Rotation.from_rotvec(rng.normal(scale=0.2, size=3))).as_quat(
                        scalar_first=True)
        quat /= np.linalg.norm(quat)
        if quat[0] < 0:  # the half the NLP keeps (w >= 0) when a twist is limited
            quat = -quat
        swing, twist = scipy_swing_twist(quat, axis)
        margin = min(spec.swing - swing, twist - spec.limits.lower, spec.limits.upper - twist)
        if abs(margin) < 1e-6:
            continue
        inside = margin > 0
        rows_hold = bool(np.all(np.array(ineq(quat)) <= 0.0))
        assert rows_hold == inside, (quat, swing, twist)
        assert arm.within_limits(quat) == inside
        seen[inside] += 1
    assert min(seen.values()) > 100  # both sides were tested


def test_random_pose_goals_are_met_inside_the_limits(ball_arm: Arm) -> None:
    rng = np.random.default_rng(21)
    for seed in range(3):
        target = ball_arm.fk(ball_arm.sample(rng))
        res = ball_arm.ik(PoseGoal(target), q0=ball_arm.sample(rng), solver="nlp",
                          options=NLPOptions(seed=seed, time_limit=5.0))
        assert res.success, res.message
        np.testing.assert_allclose(ball_arm.fk(res.q), target, atol=1e-4)
        assert ball_arm.within_limits(res.q)
        assert abs(np.linalg.norm(res.q[0:4]) - 1.0) < 1e-12
        swing, twist = scipy_swing_twist(res.q[0:4], np.array([0.0, 0.0, 1.0]))
        assert swing <= math.radians(120) + 1e-9
        assert math.radians(-150) - 1e-9 <= twist <= math.radians(150) + 1e-9
        lo, hi = ball_arm.lower[4:], ball_arm.upper[4:]
        assert np.all(res.q[4:] >= lo) and np.all(res.q[4:] <= hi)


def test_the_old_gimbal_lock_angle(tmp_path: Path) -> None:
    """The shoulder turned 90 deg about y (where an XYZ Euler chain loses an axis), from rest."""
    from tests.ik.test_tangent_ik import ARM

    arm = _write(tmp_path, ARM)
    q = arm.neutral()
    q[0:4] = Rotation.from_euler("xyz", [0.0, math.pi / 2, 0.4]).as_quat(scalar_first=True)
    target = arm.fk(q)
    res = arm.ik(PoseGoal(target), solver="nlp", options=NLPOptions(time_limit=5.0))
    assert res.success, res.message
    np.testing.assert_allclose(arm.fk(res.q), target, atol=1e-4)
    assert arm.within_limits(res.q)


def test_two_end_effectors_of_the_figure_with_ball_shoulders_and_hips() -> None:
    arm = armctl.load_arm("figure")
    assert len(arm.multi_dof_joints) == 4
    rng = np.random.default_rng(2)
    for seed in range(2):
        qt = arm.sample(rng)
        goals = [PositionGoal(arm.fk(qt, "left_palm")[:3, 3], frame="left_palm"),
                 PoseGoal(arm.fk(qt, "right_palm"), frame="right_palm")]
        res = arm.ik(goals, solver="nlp", options=NLPOptions(seed=seed, time_limit=5.0))
        assert res.success, res.message
        for f in ("left_palm", "right_palm"):
            np.testing.assert_allclose(arm.fk(res.q, f)[:3, 3], arm.fk(qt, f)[:3, 3], atol=1e-4)
        np.testing.assert_allclose(arm.fk(res.q, "right_palm")[:3, :3],
                                   arm.fk(qt, "right_palm")[:3, :3], atol=1e-4)
        assert arm.within_limits(res.q)


def test_a_goal_outside_the_cone_fails_honestly(tmp_path: Path) -> None:
    arm = _one_ball(tmp_path, "{swing: 30 deg}")
    # 60 deg from the axis: the cone allows 30
    far = 0.3 * np.array([math.sin(math.radians(60)), 0.0, math.cos(math.radians(60))])
    res = arm.ik(PositionGoal(far, frame="tip"), solver="nlp",
                 options=NLPOptions(restarts=3, time_limit=2.0))
    assert not res.success
    assert arm.within_limits(res.q)
    swing, _ = scipy_swing_twist(res.q, np.array([0.0, 0.0, 1.0]))
    assert swing <= math.radians(30) + 1e-9
    # 25 deg is inside: reached, with the cone's own row not in the way
    near = 0.3 * np.array([math.sin(math.radians(25)), 0.0, math.cos(math.radians(25))])
    res = arm.ik(PositionGoal(near, frame="tip"), solver="nlp")
    assert res.success, res.message


def test_a_wide_cone_beyond_90_degrees(tmp_path: Path) -> None:
    arm = _one_ball(tmp_path, "{swing: 120 deg}")
    for angle, reachable in ((110, True), (135, False)):
        a = math.radians(angle)
        target = 0.3 * np.array([0.0, math.sin(a), math.cos(a)])
        res = arm.ik(PositionGoal(target, frame="tip"), solver="nlp",
                     options=NLPOptions(restarts=3, time_limit=2.0))
        assert res.success is reachable, (angle, res.message)
        swing, _ = scipy_swing_twist(res.q, np.array([0.0, 0.0, 1.0]))
        assert swing <= math.radians(120) + 1e-9


def test_twist_limits(tmp_path: Path) -> None:
    arm = _one_ball(tmp_path, "{swing: 60 deg, twist: {lower: -30 deg, upper: 50 deg}}")
    for twist, reachable in ((-25, True), (45, True), (-40, False), (70, False)):
        rot = Rotation.from_euler("z", twist, degrees=True).as_matrix()
        res = arm.ik(OrientationGoal(rot, frame="tip"), solver="nlp",
                     options=NLPOptions(restarts=3, time_limit=2.0))
        assert res.success is reachable, (twist, res.message)
        _, found = scipy_swing_twist(res.q, np.array([0.0, 0.0, 1.0]))
        assert math.radians(-30) - 1e-9 <= found <= math.radians(50) + 1e-9
        if reachable:
            assert found == pytest.approx(math.radians(twist), abs=1e-4)


def test_constraints_and_keep_out_on_a_ball_arm(ball_arm: Arm) -> None:
    target = np.array([0.2, 0.1, 0.4])
    plane = OnPlane([0.0, 0.0, 0.3], [0.0, 0.0, 1.0], frame="fore")  # the elbow's height
    zone = KeepOutSphere([0.1, 0.05, 0.3], 0.05)
    res = ball_arm.ik(PositionGoal(target), solver="nlp", constraints=[plane, zone],
                      options=NLPOptions(time_limit=5.0))
    assert res.success, res.message
    assert np.linalg.norm(ball_arm.fk(res.q)[:3, 3] - target) < 1e-4
    assert abs(ball_arm.fk(res.q, "fore")[2, 3] - 0.3) < 1e-5
    assert zone.violation(ball_arm, res.q) == 0.0
    assert ball_arm.within_limits(res.q)


def test_preferred_posture_takes_the_joint_vector_q(ball_arm: Arm) -> None:
    pref = ball_arm.named_pose("home")
    res = ball_arm.ik(PositionGoal(ball_arm.fk(pref)[:3, 3]), solver="nlp",
                      options=NLPOptions(preferred=tuple(pref), regularization=1e-3))
    assert res.success
    bad = np.array(pref)
    bad[0] = 3.0
    with pytest.raises(InputError, match="ball joint 'shoulder'"):
        ball_arm.ik(PositionGoal([0.1, 0.0, 0.5]), solver="nlp",
                    options=NLPOptions(preferred=tuple(bad)))
    with pytest.raises(InputError, match="has 6 values; the arm's joint vector q has 7"):
        ball_arm.ik(PositionGoal([0.1, 0.0, 0.5]), solver="nlp",
                    options=NLPOptions(preferred=(0.0,) * 6))


def test_what_is_still_refused(ball_arm: Arm) -> None:
    from armctl.collision import CollisionModel

    plain = armctl.load_arm(Path(__file__).parents[2] / "data" / "planar3r.yaml")
    with pytest.raises(InputError, match=r"built for arm 'planar3r', whose joints differ"):
        ball_arm.ik(PositionGoal([0.1, 0.0, 0.5]), solver="nlp",
                    avoid=CollisionModel.of(plain))
    with pytest.raises(InputError, match="the solver 'analytic' supports 1-DOF joints only"):
        ball_arm.ik(PoseGoal(ball_arm.fk(ball_arm.neutral())), solver="analytic")
    from armctl.ik.nlp import Method

    with pytest.raises(InputError, match=r"Method.SQP.*'shoulder'.*use Method.AUTO"):
        ball_arm.ik(PositionGoal([0.1, 0.0, 0.5]), solver="nlp",
                    options=NLPOptions(method=Method.SQP))
    from armctl.ik.errors import UnsupportedGoalError

    with pytest.raises(UnsupportedGoalError, match="nlp"):
        ball_arm.ik(PositionGoal([0.1, 0.0, 0.5]), solver="dls",
                    constraints=[OnPlane([0, 0, 0.4], [0, 0, 1])])


def test_cli_ik_nlp_on_a_ball_arm(capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.cli import main

    assert main(["ik", str(BALL_ARM), "--xyz", "0.2", "0.1", "0.4", "--solver", "nlp",
                 "--keep-out", "0.1", "0.05", "0.3", "0.05", "--no-collisions", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["success"] and data["solver"] == "nlp"
    arm = load_arm(BALL_ARM)
    q = np.array(data["q"])
    np.testing.assert_allclose(arm.fk(q)[:3, 3], [0.2, 0.1, 0.4], atol=1e-4)
    assert arm.within_limits(q)
    assert KeepOutSphere([0.1, 0.05, 0.3], 0.05).violation(arm, q) == 0.0
    assert len(data["joints"]["shoulder"]) == 4 and len(data["joints"]["wrist"]) == 2


def test_cli_goals_file_on_a_ball_arm(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.cli import main

    goals = tmp_path / "goals.yaml"
    goals.write_text("""goals:
  - {type: position, position: [0.15, -0.1, 0.35]}
constraints:
  - {type: halfspace, frame: fore, point: [0, 0, 0.3], normal: [0, 0, 1]}
  - {type: cone, direction: [0, 0, -1], half_angle: 60 deg, axis: [0, 0, 1]}
""")
    assert main(["ik", str(BALL_ARM), "--goals", str(goals), "--no-collisions", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["success"] and data["solver"] == "nlp"  # auto with constraints
    arm = load_arm(BALL_ARM)
    q = np.array(data["q"])
    np.testing.assert_allclose(arm.fk(q)[:3, 3], [0.15, -0.1, 0.35], atol=1e-4)
    assert arm.fk(q, "fore")[2, 3] >= 0.3 - 1e-5
    tool_z = arm.fk(q)[:3, 2]
    assert math.degrees(math.acos(-tool_z[2])) <= 60 + 1e-3
    assert arm.within_limits(q)
