"""Ball (3-DOF) and universal (2-DOF) joints: FK against scipy's rotations and a hand chain of
matrices, Jacobians against finite differences through ``integrate``, the configuration-space
operations, limits, and the config's forms and errors."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import armctl
from armctl.errors import ConfigError, InputError, JointLimitError
from armctl.kinematics import _kernels

ARM = """armctl: 1
name: b
base: base
joints:
  - name: base_yaw
    type: revolute
    parent: base
    child: l0
    limits: {lower: -3, upper: 3}
  - name: shoulder
    type: ball
    parent: l0
    child: upper
    origin: {xyz: [0, 0, 0.1], rpy: [0.1, 0.2, 0.3]}
    axis: [0, 0, 1]
    limits: {swing: 120 deg, twist: {lower: -90 deg, upper: 90 deg}, velocity: 2}
  - name: elbow
    type: revolute
    parent: upper
    child: fore
    origin: {xyz: [0, 0, 0.3]}
    axis: [0, 1, 0]
    limits: {lower: -2, upper: 2}
  - name: wrist
    type: universal
    parent: fore
    child: hand
    origin: {xyz: [0.05, 0, 0.25]}
    axes: [[0, 1, 0], [1, 0, 0]]
    limits: [{lower: -1.5, upper: 1.5}, {lower: -1, upper: 1}]
frames:
  - name: tcp
    parent: hand
    origin: {xyz: [0, 0.02, 0.1]}
poses:
  home: {base_yaw: 0, shoulder: {rpy: [0, 0.5, 0]}, elbow: 0.3, wrist: [0.1, 0.2]}
  flat: [0, 1, 0, 0, 0, 0, 0, 0]
"""


def _arm(tmp_path: Path, text: str = ARM) -> armctl.Arm:
    p = tmp_path / "arm.yaml"
    p.write_text(text)
    return armctl.load_arm(p)


def _h(rot: np.ndarray | None = None, xyz: tuple[float, ...] = (0, 0, 0)) -> np.ndarray:
    t = np.eye(4)
    if rot is not None:
        t[:3, :3] = rot
    t[:3, 3] = xyz
    return t


def _hand_fk(q: np.ndarray) -> np.ndarray:
    """The tool pose by a chain of matrices built with scipy's rotations."""
    rv = Rotation.from_rotvec
    base = _h(rv([0, 0, q[0]]).as_matrix())
    origin = _h(Rotation.from_euler("xyz", [0.1, 0.2, 0.3]).as_matrix(), (0, 0, 0.1))
    ball = _h(Rotation.from_quat(q[1:5], scalar_first=True).as_matrix())
    elbow = _h(None, (0, 0, 0.3)) @ _h(rv([0, q[5], 0]).as_matrix())
    wrist = (_h(None, (0.05, 0, 0.25)) @ _h(rv([0, q[6], 0]).as_matrix())
             @ _h(rv([q[7], 0, 0]).as_matrix()))
    return base @ origin @ ball @ elbow @ wrist @ _h(None, (0, 0.02, 0.1))


def test_layout_and_names(tmp_path: Path) -> None:
    arm = _arm(tmp_path)
    assert arm.joint_names == ("base_yaw", "shoulder", "elbow", "wrist")
    assert (arm.nq, arm.nv, arm.dof) == (8, 7, 7)
    assert [arm.q_index(n) for n in arm.joint_names] == [
        slice(0, 1), slice(1, 5), slice(5, 6), slice(6, 8)]
    assert [arm.v_index(n) for n in arm.joint_names] == [
        slice(0, 1), slice(1, 4), slice(4, 5), slice(5, 7)]
    assert arm.multi_dof_joints == ("shoulder", "wrist")
    np.testing.assert_array_equal(arm.neutral(), [0, 1, 0, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(arm.velocity_limits[1:4], [2, 2, 2])
    home = arm.named_pose("home")
    expect = Rotation.from_euler("xyz", [0, 0.5, 0]).as_quat(scalar_first=True)
    np.testing.assert_allclose(home[1:5], expect, atol=1e-15)
    np.testing.assert_allclose(home[[0, 5, 6, 7]], [0, 0.3, 0.1, 0.2])
    np.testing.assert_array_equal(arm.named_pose("flat"), [0, 1, 0, 0, 0, 0, 0, 0])


def test_fk_matches_a_hand_chain(tmp_path: Path) -> None:
    arm = _arm(tmp_path)
    rng = np.random.default_rng(3)
    qs = arm.sample(rng, 40)
    run = _kernels.interpreted("chain_fk")
    rows, idx = arm._chain_of(arm.frame_index("tcp"))
    batch = arm.fk_batch(qs, "tcp")
    for i, q in enumerate(qs):
        want = _hand_fk(q)
        np.testing.assert_allclose(arm.fk(q, "tcp"), want, atol=1e-13)
        np.testing.assert_allclose(batch[i], want, atol=1e-13)
        np.testing.assert_allclose(arm.fk_all(q)["tcp"], want, atol=1e-13)
        np.testing.assert_allclose(run(q, rows, idx), want, atol=1e-13)
        assert arm.within_limits(q)


def _fd_jacobian(arm: armctl.Arm, q: np.ndarray, frame: str, h: float = 1e-6) -> np.ndarray:
    """Central differences of the frame pose along each tangent direction via integrate."""
    out = np.zeros((6, arm.nv))
    for k in range(arm.nv):
        e = np.zeros(arm.nv)
        e[k] = h
        tp, tm = arm.fk(arm.integrate(q, e), frame), arm.fk(arm.integrate(q, -e), frame)
        out[:3, k] = (tp[:3, 3] - tm[:3, 3]) / (2 * h)
        dr = Rotation.from_matrix(tp[:3, :3] @ tm[:3, :3].T).as_rotvec()  # world-frame turn
        out[3:, k] = dr / (2 * h)
    return out


def test_jacobian_matches_finite_differences(tmp_path: Path) -> None:
    arm = _arm(tmp_path)
    rng = np.random.default_rng(5)
    qs = list(arm.sample(rng, 25))
    # the old Euler expansion's singular middle angle: the shoulder turned 90 deg about y
    q90 = arm.neutral()
    q90[1:5] = Rotation.from_euler("xyz", [0.3, math.pi / 2, -0.4]).as_quat(scalar_first=True)
    qs.append(q90)
    batch = arm.jacobian_batch(np.array(qs), "tcp")
    run = _kernels.interpreted("chain_jacobian")
    rows, idx = arm._chain_of(arm.frame_index("tcp"))
    for i, q in enumerate(qs):
        jac = arm.jacobian(q, "tcp")
        np.testing.assert_allclose(jac, _fd_jacobian(arm, q, "tcp"), atol=1e-7)
        np.testing.assert_allclose(batch[i], jac, atol=1e-14)
        np.testing.assert_allclose(run(q, rows, idx, arm.nv), jac, atol=1e-14)
        pose, jac2 = arm.fk_jacobian(q, "tcp")
        np.testing.assert_allclose(jac2, jac, atol=1e-14)
        np.testing.assert_allclose(pose, arm.fk(q, "tcp"), atol=1e-14)
    # the ball's three angular columns are the axes of its moved frame: orthonormal, full rank
    sv = np.linalg.svd(arm.jacobian(q90, "tcp")[3:, 1:4], compute_uv=False)
    np.testing.assert_allclose(sv, [1, 1, 1], atol=1e-12)


def test_ball_joint_columns_are_its_moved_frame(tmp_path: Path) -> None:
    arm = _arm(tmp_path)
    q = arm.sample(np.random.default_rng(1))
    upper = arm.fk_all(q)["upper"]
    jac = arm.jacobian(q, "tcp")
    np.testing.assert_allclose(jac[3:, 1:4], upper[:3, :3], atol=1e-14)
    r = arm.fk(q, "tcp")[:3, 3] - upper[:3, 3]
    for k in range(3):
        np.testing.assert_allclose(jac[:3, 1 + k], np.cross(upper[:3, k], r), atol=1e-14)


def test_integrate_difference_interpolate(tmp_path: Path) -> None:
    arm = _arm(tmp_path)
    rng = np.random.default_rng(7)
    for _ in range(20):
        q0, q1 = arm.sample(rng), arm.sample(rng)
        v = arm.difference(q0, q1)
        q = arm.integrate(q0, v)
        np.testing.assert_allclose(arm.fk_frames(q), arm.fk_frames(q1), atol=1e-12)
        assert np.linalg.norm(v[1:4]) <= math.pi + 1e-12  # shortest arc
        mid = arm.interpolate(q0, q1, 0.5)
        r0 = Rotation.from_quat(q0[1:5], scalar_first=True)
        r1 = Rotation.from_quat(q1[1:5], scalar_first=True)
        from scipy.spatial.transform import Slerp

        want = Slerp([0, 1], Rotation.concatenate([r0, r1]))([0.5])[0]
        got = Rotation.from_quat(mid[1:5], scalar_first=True)
        assert (got.inv() * want).magnitude() < 1e-10
        np.testing.assert_allclose(mid[[0, 5, 6, 7]], (q0 + q1)[[0, 5, 6, 7]] / 2, atol=1e-15)
    # integrate of a body-frame turn: q ⊗ exp(v/2)
    q0 = arm.neutral()
    q0[1:5] = Rotation.from_rotvec([0.2, -0.1, 0.4]).as_quat(scalar_first=True)
    v = np.zeros(arm.nv)
    v[1:4] = [0.0, 0.3, 0.1]
    got = Rotation.from_quat(arm.integrate(q0, v)[1:5], scalar_first=True)
    want = Rotation.from_rotvec([0.2, -0.1, 0.4]) * Rotation.from_rotvec([0.0, 0.3, 0.1])
    assert (got.inv() * want).magnitude() < 1e-12


def test_limits_cone_and_twist(tmp_path: Path) -> None:
    arm = _arm(tmp_path)
    rng = np.random.default_rng(11)
    q = arm.neutral()
    q[1:5] = Rotation.from_rotvec([0, 2.5, 0]).as_quat(scalar_first=True)  # swing 2.5 > 120 deg
    assert not arm.within_limits(q)
    with pytest.raises(JointLimitError, match=r"'shoulder'.*swing"):
        arm.check_limits(q)
    clipped = arm.clip(q)
    assert arm.within_limits(clipped)
    z = Rotation.from_quat(clipped[1:5], scalar_first=True).apply([0, 0, 1])
    assert math.isclose(math.acos(z[2]), math.radians(120), abs_tol=1e-9)
    assert abs(z[1]) < 1e-12 and z[0] > 0  # shortened toward the centre, same direction
    q[1:5] = Rotation.from_rotvec([0, 0, 2.0]).as_quat(scalar_first=True)  # twist 2 > 90 deg
    with pytest.raises(JointLimitError, match="twist"):
        arm.check_limits(q)
    tw = Rotation.from_quat(arm.clip(q)[1:5], scalar_first=True).as_rotvec()
    np.testing.assert_allclose(tw, [0, 0, math.pi / 2], atol=1e-12)
    # samples: inside, and they fill the cone (some near its edge)
    qs = arm.sample(rng, 400)
    assert all(arm.within_limits(s) for s in qs)
    swings = [math.acos(np.clip(Rotation.from_quat(s[1:5], scalar_first=True).apply(
        [0, 0, 1])[2], -1, 1)) for s in qs]
    assert max(swings) > math.radians(110)


def test_unlimited_ball_samples_are_uniform(tmp_path: Path) -> None:
    text = ARM.replace(
        "limits: {swing: 120 deg, twist: {lower: -90 deg, upper: 90 deg}, velocity: 2}",
        "limits: {velocity: 2}").replace("  home: {base_yaw: 0, shoulder: {rpy: [0, 0.5, 0]}, "
                                         "elbow: 0.3, wrist: [0.1, 0.2]}\n", "")
    arm = _arm(tmp_path, text)
    quats = arm.sample(np.random.default_rng(2), 4000)[:, 1:5]
    # Haar measure: E[q q^T] = I / 4 for uniform unit quaternions (sign-invariant)
    np.testing.assert_allclose(quats.T @ quats / len(quats), np.eye(4) / 4, atol=0.02)


def test_quaternion_errors_name_the_joint(tmp_path: Path) -> None:
    arm = _arm(tmp_path)
    q = arm.neutral()
    q[1] = 2.0
    with pytest.raises(InputError, match=r"ball joint 'shoulder'.*norm 2"):
        arm.as_q(q)
    with pytest.raises(InputError, match=r"8 values \(base_yaw, shoulder: 4 \(quaternion"):
        arm.fk(np.zeros(7))
    np.testing.assert_allclose(arm.normalize(q), arm.neutral())
    with pytest.raises(InputError, match=r"1-DOF joints only.*'shoulder' \(ball\)"):
        arm.require_one_dof("the servo mapping")


@pytest.mark.parametrize(("limits", "message"), [
    ("[{lower: -1, upper: 1}, {lower: -1, upper: 1}, {lower: -1, upper: 1}]",
     "swing cone and a twist range, not a list per axis"),
    ("{swing: 200 deg}", "more than pi"),
    ("{twist: {lower: 1, upper: -1}}", "lower twist"),
    ("{twist: {lower: -4, upper: 1}}", "outside \\[-pi, pi\\]"),
    ("{lower: -1, upper: 1}", "unknown key 'lower'"),
])
def test_ball_limit_errors(tmp_path: Path, limits: str, message: str) -> None:
    text = ARM.replace(
        "{swing: 120 deg, twist: {lower: -90 deg, upper: 90 deg}, velocity: 2}", limits)
    with pytest.raises(ConfigError, match=message):
        _arm(tmp_path, text)


def test_spherical_is_a_ball_and_axes_are_refused(tmp_path: Path) -> None:
    arm = _arm(tmp_path, ARM.replace("type: ball", "type: spherical"))
    assert arm.joint_types[1] is armctl.config.schema.JointType.BALL
    with pytest.raises(ConfigError, match="takes no 'axes'"):
        _arm(tmp_path, ARM.replace("    axis: [0, 0, 1]\n    limits: {swing",
                                   "    axes: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n    limits: "
                                   "{swing"))


def test_pose_errors(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"quaternion .* has norm"):
        _arm(tmp_path, ARM.replace("flat: [0, 1, 0", "flat: [0, 2, 0"))
    with pytest.raises(ConfigError, match="joint vector has 8"):
        _arm(tmp_path, ARM.replace("flat: [0, 1, 0, 0, 0, 0, 0, 0]", "flat: [0, 1, 0, 0, 0, 0, 0]"))
    with pytest.raises(ConfigError, match="swings"):
        _arm(tmp_path, ARM.replace("{rpy: [0, 0.5, 0]}", "{rotvec: [0, 2.5, 0]}"))


def test_what_supports_1_dof_joints_only_refuses_clearly(tmp_path: Path) -> None:
    arm = _arm(tmp_path)
    from armctl.ik import PositionGoal

    goal = PositionGoal([0.1, 0.0, 0.5])
    with pytest.raises(InputError, match=r"solver 'analytic' supports 1-DOF joints only"):
        arm.ik(goal, solver="analytic")
    from armctl.ik.analytic.errors import NoDecompositionError
    from armctl.motion.limits import MotionLimits

    with pytest.raises(NoDecompositionError, match="multi-DOF joint"):
        arm.ik_all(np.eye(4))
    # joint moves, keyframe playback, straight lines and detours take such arms
    # (tests/motion/test_multi_dof_*.py); a detour needs the collision model of the arm
    from armctl.motion import plan_detour

    with pytest.raises(InputError, match=r"detour of an arm with ball joints needs a collision"):
        plan_detour(None, arm.neutral(), arm.neutral(),  # type: ignore[arg-type]
                    MotionLimits.from_model(arm))
    from armctl.ik.batch import solve_batch

    with pytest.raises(InputError, match="batch inverse kinematics"):
        solve_batch(arm, np.eye(4)[None])


def test_a_servo_cannot_drive_a_ball_joint(tmp_path: Path) -> None:
    text = ARM + """bus:
  port: sim
  protocol: feetech
  servos:
    shoulder: {id: 1, model: sts3215}
"""
    with pytest.raises(ConfigError, match="cannot drive a multi-DOF joint"):
        _arm(tmp_path, text)


def test_cli_fk_and_render(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.cli import main

    p = tmp_path / "arm.yaml"
    p.write_text(ARM)
    q = Rotation.from_euler("xyz", [0.2, 0.1, -0.3]).as_quat(scalar_first=True)
    args = ["fk", str(p), "--deg", "10", *(str(x) for x in q), "20", "5", "-10", "--json"]
    assert main(args) == 0
    import json

    data = json.loads(capsys.readouterr().out)
    full = np.array([math.radians(10), *q, math.radians(20), math.radians(5), math.radians(-10)])
    np.testing.assert_allclose(data["matrix"], _hand_fk(full), atol=1e-12)
    assert data["within_limits"]
    assert main(["fk", str(p), "0", "1", "0", "0", "0", "0", "0"]) != 0
    assert "expected 8 values (base_yaw, shoulder: 4 (quaternion w x y z)" in \
        capsys.readouterr().err
    # four decimals typed by hand are normalised; a quaternion far from unit norm is refused
    typed = ["0", "0.7071", "0.7071", "0", "0", "0", "0", "0"]
    assert main(["fk", str(p), *typed, "--json"]) == 0
    exact = ["0", *(str(x) for x in np.array([0.7071, 0.7071, 0, 0]) / math.hypot(0.7071, 0.7071)),
             "0", "0", "0"]
    got = json.loads(capsys.readouterr().out)["matrix"]
    assert main(["fk", str(p), *exact, "--json"]) == 0
    np.testing.assert_allclose(got, json.loads(capsys.readouterr().out)["matrix"], atol=1e-15)
    assert main(["fk", str(p), "0", "0.9", "0.9", "0", "0", "0", "0", "0"]) == 2
    err = capsys.readouterr().err
    assert "ball joint 'shoulder'" in err and "norm 1.27" in err and "Traceback" not in err
    assert main(["render", str(p), "-o", str(tmp_path / "r.png")]) == 0
    assert "clearance" in capsys.readouterr().out
    assert (tmp_path / "r.png").stat().st_size > 0


def test_info_shows_each_joints_own_limits(capsys: pytest.CaptureFixture[str]) -> None:
    import json as _json

    from armctl.cli import main as cli_main

    path = Path(__file__).resolve().parents[1] / "data" / "ball_arm.yaml"
    assert cli_main(["info", str(path), "--json"]) == 0
    joints = {j["name"]: j for j in _json.loads(capsys.readouterr().out)["joints"]}
    # the elbow after the ball joint shows its own range and speed, not the ball's entries
    assert joints["elbow"]["lower"] == pytest.approx(-2.5)
    assert joints["elbow"]["upper"] == pytest.approx(2.5)
    assert joints["wrist"]["lower"] == pytest.approx([-2.0, -1.5])
    assert joints["shoulder"]["swing"] == pytest.approx(np.radians(120))
    assert joints["shoulder"]["twist"] == pytest.approx(np.radians([-150, 150]))
    assert joints["shoulder"]["velocity"] == pytest.approx([2.0, 2.0, 2.0])
    assert cli_main(["info", str(path), "--deg"]) == 0
    text = capsys.readouterr().out
    assert "swing 120.000" in text and "-143.239" in text


def test_the_simulated_bus_refuses_an_arm_with_multi_dof_joints(
        capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.cli import main as cli_main

    path = Path(__file__).resolve().parents[1] / "data" / "ball_arm.yaml"
    code = cli_main(["move-joints", str(path), "1", "0", "0", "0", "0", "0", "0", "--sim"])
    err = capsys.readouterr().err
    assert code == 2 and "multi-DOF joint(s) shoulder, wrist has no servos" in err
    assert "armctl render" in err and "Traceback" not in err


@pytest.mark.parametrize(("edit", "problem", "fix"), [
    ({"limits": {"swing": "60 deg", "twist": "45 deg"}}, "twist takes a range",
     "twist: {lower: -45 deg, upper: 45 deg}"),
    ({"axes": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, "takes no 'axes'", "swing: 60 deg, twist:"),
])
def test_ball_joint_config_mistakes_say_how_to_fix_them(tmp_path: Path, edit: dict,
                                                        problem: str, fix: str) -> None:
    import yaml

    doc = yaml.safe_load(ARM)
    ball = next(j for j in doc["joints"] if j["type"] in ("ball", "spherical"))
    ball.pop("limits", None)
    ball.update(edit)
    with pytest.raises(ConfigError) as info:
        _arm(tmp_path, yaml.safe_dump(doc))
    text = str(info.value)
    assert problem in text and fix in text, text


def test_a_pose_outside_a_ball_joints_cone_says_how_to_fix_it(tmp_path: Path) -> None:
    import yaml

    doc = yaml.safe_load(ARM)
    ball = next(j for j in doc["joints"] if j["type"] in ("ball", "spherical"))
    ball["limits"] = {"swing": "30 deg"}
    doc["poses"] = {"far": {"base_yaw": 0, ball["name"]: {"rpy": ["0 deg", "50 deg", "0 deg"]},
                            "elbow": 0, "wrist": [0, 0]}}
    with pytest.raises(ConfigError) as info:
        _arm(tmp_path, yaml.safe_dump(doc))
    text = str(info.value)
    assert "swings" in text and "at most 30 deg, or widen limits.swing" in text, text
