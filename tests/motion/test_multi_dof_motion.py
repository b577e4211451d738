"""Motion of arms with ball and universal joints: joint moves, keyframe playback, limits.

Independent truth: scipy.spatial.transform for rotations (angles travelled, distance from the
great circle, angular velocities by finite differences of the sampled quaternions), finite
differences of the samples for every rate, and the planner of an arm of 1-DOF joints for the
scalar coordinates.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.spatial.transform import Rotation

import armctl
from armctl.errors import ConfigError, InputError
from armctl.ik import IKOptions, PoseGoal, PositionGoal
from armctl.motion import (
    Interpolation,
    Keyframe,
    KeyframeProgram,
    LimitViolation,
    MotionLimits,
    PlaybackOptions,
    plan_joint_move,
    plan_program,
)
from armctl.motion.layout import swing_twist_many
from armctl.spatial import swing_twist

BALL_ARM = Path(__file__).resolve().parents[1] / "data" / "ball_arm.yaml"
DT = 1e-4


@pytest.fixture(scope="module")
def arm() -> armctl.Arm:
    return armctl.load_arm(BALL_ARM)


def _rot(q: np.ndarray) -> Rotation:
    """scipy rotations of (w, x, y, z) quaternions."""
    return Rotation.from_quat(np.roll(np.asarray(q), -1, axis=-1))


def _wxyz(r: Rotation) -> tuple[float, ...]:
    return tuple(np.roll(r.as_quat(), 1).tolist())


def _euler(deg: tuple[float, float, float]) -> tuple[float, ...]:
    return _wxyz(Rotation.from_euler("XYZ", deg, degrees=True))


def _body_rates(traj: object, ts: np.ndarray, sl: slice) -> np.ndarray:
    """Angular velocity [rad/s] in the moved frame by central differences of the quaternions."""
    q0 = traj.sample_many(ts - DT)[0][:, sl]  # type: ignore[attr-defined]
    q1 = traj.sample_many(ts + DT)[0][:, sl]  # type: ignore[attr-defined]
    return (_rot(q0).inv() * _rot(q1)).as_rotvec() / (2 * DT)


def _stray(path: Rotation, r0: Rotation, r1: Rotation) -> float:
    """Largest angle [rad] of the samples from the great-circle arc r0 -> r1.

    With ``p`` the quaternion of ``r0^-1 r`` and the arc ``(cos phi, sin phi u)``, phi from 0
    to half the angle of ``r0^-1 r1`` about ``u``: the nearest point of the circle is the
    projection of ``p`` on the plane of ``(1, 0, 0, 0)`` and ``(0, u)``, at the angle
    ``2 arccos |projection|`` as a rotation; past the arc's ends, the nearer end.
    """
    rel = (r0.inv() * r1).as_rotvec()
    theta = float(np.linalg.norm(rel))
    u = rel / theta
    p = (r0.inv() * path).as_quat()  # (x, y, z, w)
    p = np.where(p[:, 3:] < 0, -p, p)
    c, sn = p[:, 3], p[:, :3] @ u
    phi = np.arctan2(sn, c)
    outside = (phi < -1e-9) | (phi > theta / 2 + 1e-9)
    angle = 2 * np.arccos(np.clip(np.hypot(c, sn), -1, 1))
    ends = np.minimum((r0.inv() * path).magnitude(), (r1.inv() * path).magnitude())
    return float(np.where(outside, ends, angle).max())


def _program(arm: armctl.Arm, rows: list[tuple[tuple[float, ...], float, tuple[float, float]]],
             **kw: object) -> KeyframeProgram:
    kfs = tuple(Keyframe(q=(*quat, elbow, *wrist), name=f"k{i}", **kw)  # type: ignore[arg-type]
                for i, (quat, elbow, wrist) in enumerate(rows))
    return KeyframeProgram(arm.name, ("shoulder", "elbow", "wrist"), kfs, widths=(4, 1, 2))


# Two orientations 121 deg apart; their intrinsic x-y-z angles interpolated one by one travel
# 160 deg and stray 46 deg from the arc (checked below with scipy).
EULER_A = (-30.0, -90.0, -20.0)
EULER_B = (60.0, 30.0, 90.0)


def test_the_example_rotation_is_what_the_docs_say() -> None:
    ra = Rotation.from_euler("XYZ", EULER_A, degrees=True)
    rb = Rotation.from_euler("XYZ", EULER_B, degrees=True)
    assert math.degrees((ra.inv() * rb).magnitude()) == pytest.approx(121, abs=0.5)
    s = np.linspace(0, 1, 2001)[:, None]
    per_angle = Rotation.from_euler("XYZ", (1 - s) * EULER_A + s * np.array(EULER_B),
                                    degrees=True)
    travel = float(np.sum((per_angle[:-1].inv() * per_angle[1:]).magnitude()))
    assert math.degrees(travel) == pytest.approx(160, abs=0.5)
    assert math.degrees(_stray(per_angle, ra, rb)) == pytest.approx(45.6, abs=0.5)


def test_limits_of_an_arm_with_ball_and_universal_joints(arm: armctl.Arm) -> None:
    limits = MotionLimits.from_model(arm)
    assert limits.layout is not None
    assert limits.dof == arm.nv == 6 and limits.lower.shape == (arm.nq,)
    assert limits.layout.rate_names == ("elbow", "wrist (angle 1)", "wrist (angle 2)",
                                        "shoulder")
    vel, acc, jerk = limits.rate_limits()
    assert vel.tolist() == [1.0, 1.0, 1.0, 2.0]  # defaults, the shoulder's from the file
    assert acc.tolist() == [3.0, 3.0, 3.0, 3.0]
    assert np.all(np.isinf(jerk))
    assert MotionLimits.from_model(armctl.load_arm("so101")).layout is None


def test_swing_and_twist_of_many_agree_with_one_at_a_time() -> None:
    rng = np.random.default_rng(4)
    quats = np.roll(Rotation.random(300, random_state=5).as_quat(), 1, axis=1)
    quats[::3] *= -1.0
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    swing, twist = swing_twist_many(quats, axis)
    for q, s, t in zip(quats, swing, twist, strict=True):
        s1, t1 = swing_twist(q, axis)
        assert s == pytest.approx(s1, abs=1e-9)
        assert t == pytest.approx(t1, abs=1e-9) or abs(abs(t) - math.pi) < 1e-9


def test_a_joint_move_turns_the_ball_joint_on_the_great_circle(arm: armctl.Arm) -> None:
    limits = MotionLimits.from_model(arm)
    q0 = np.array([*_euler(EULER_A), 0.2, 0.3, -0.4])
    q1 = np.array([*_euler(EULER_B), -0.5, -0.1, 0.6])
    plan = plan_joint_move(q0, q1, limits, speed=0.8)
    ts = np.linspace(0.0, plan.duration, 801)
    q, qd, _ = plan.trajectory.sample_many(ts)
    assert q.shape == (ts.size, arm.nq) and qd.shape == (ts.size, arm.nv)
    assert np.allclose(np.linalg.norm(q[:, :4], axis=1), 1.0, atol=1e-12)
    path = _rot(q[:, :4])
    r0, r1 = _rot(q0[:4]), _rot(q1[:4])
    travel = float(np.sum((path[:-1].inv() * path[1:]).magnitude()))
    assert math.degrees(travel) == pytest.approx(
        math.degrees((r0.inv() * r1).magnitude()), abs=1e-6)
    assert math.degrees(travel) == pytest.approx(121, abs=0.5)
    assert _stray(path, r0, r1) < 1e-6
    # ends exactly at the goal, every joint together
    assert (_rot(q[-1, :4]).inv() * r1).magnitude() < 1e-9
    assert np.allclose(q[-1, 4:], q1[4:], atol=1e-9)
    # the angular velocity by finite differences is the planned one and within its limit
    inner = ts[1:-1]
    fd = _body_rates(plan.trajectory, inner, slice(0, 4))
    planned = plan.trajectory.sample_many(inner)[1][:, :3]
    assert np.allclose(fd, planned, atol=1e-5)
    ball_peak = np.linalg.norm(fd, axis=1).max() / (2.0 * 0.8)  # its limit x the speed
    assert ball_peak <= 1 + 1e-4
    # the scalar joints: velocities by finite differences of the positions
    qa = plan.trajectory.sample_many(inner - DT)[0][:, 4:]
    qb = plan.trajectory.sample_many(inner + DT)[0][:, 4:]
    scalar_peak = np.abs((qb - qa) / (2 * DT)).max() / (1.0 * 0.8)
    assert scalar_peak <= 1 + 1e-4
    # time-optimal: some joint reaches its velocity limit
    assert max(ball_peak, scalar_peak) > 0.98


KEYS = [(_euler((0, 0, 0)), 0.0, (0.0, 0.0)),
        (_euler((40, 20, 10)), 0.6, (0.3, -0.2)),
        (_euler((-30, 50, -40)), 1.2, (-0.4, 0.5)),
        (_euler((20, -30, 70)), 0.3, (0.1, 0.1)),
        (_euler((0, 10, 0)), 0.0, (0.0, 0.0))]


@pytest.mark.parametrize("kind", [Interpolation.CUBIC, Interpolation.MIN_JERK])
def test_cubic_playback_passes_the_keyframes_with_continuous_angular_velocity(
        arm: armctl.Arm, kind: Interpolation) -> None:
    limits = MotionLimits.from_model(arm)
    program = _program(arm, KEYS)
    plan = plan_program(program, arm, limits, program.keyframes[0].q, PlaybackOptions(kind))
    traj = plan.trajectory
    inner = [w for w in plan.waypoints[1:-1]]
    assert len(inner) == 3 and not any(w.stop for w in inner)
    for w, (quat, elbow, wrist) in zip(plan.waypoints, KEYS, strict=True):
        q = traj.sample(w.time)[0]
        assert (_rot(q[:4]).inv() * _rot(np.array(quat))).magnitude() < 1e-9
        assert np.allclose(q[4:], [elbow, *wrist], atol=1e-9)
    for w in inner:  # C1: the same angular velocity just before and just after the keyframe
        before = _body_rates(traj, np.array([w.time - 3e-4]), slice(0, 4))[0]
        after = _body_rates(traj, np.array([w.time + 3e-4]), slice(0, 4))[0]
        assert np.linalg.norm(before) > 0.1
        assert np.linalg.norm(after - before) < 0.02 * np.linalg.norm(before)
    ts = np.linspace(DT, plan.duration - DT, 3000)
    q = traj.sample_many(ts)[0]
    assert np.allclose(np.linalg.norm(q[:, :4], axis=1), 1.0, atol=1e-12)
    fd = _body_rates(traj, ts, slice(0, 4))
    assert np.linalg.norm(fd, axis=1).max() <= 2.0 * (1 + 1e-3)
    assert np.allclose(fd, traj.sample_many(ts)[1][:, :3], atol=1e-4)
    qa, qb = traj.sample_many(ts - DT)[0][:, 4:], traj.sample_many(ts + DT)[0][:, 4:]
    assert np.abs((qb - qa) / (2 * DT)).max() <= 1.0 * (1 + 1e-3)
    # the accelerations, by finite differences of the velocities, within their limits
    va, vb = traj.sample_many(ts - DT)[1], traj.sample_many(ts + DT)[1]
    acc = (vb - va) / (2 * DT)
    assert np.linalg.norm(acc[:, :3], axis=1).max() <= 3.0 * 1.01
    assert np.abs(acc[:, 3:]).max() <= 3.0 * 1.01


def test_linear_playback_turns_each_segment_on_its_great_circle(arm: armctl.Arm) -> None:
    limits = MotionLimits.from_model(arm)
    program = _program(arm, KEYS)
    plan = plan_program(program, arm, limits, program.keyframes[0].q,
                        PlaybackOptions(Interpolation.LINEAR))
    traj = plan.trajectory
    times = [w.time for w in plan.waypoints]
    for k in range(len(KEYS) - 1):
        ts = np.linspace(times[k], times[k + 1], 400)
        path = _rot(traj.sample_many(ts)[0][:, :4])
        r0, r1 = _rot(np.array(KEYS[k][0])), _rot(np.array(KEYS[k + 1][0]))
        assert _stray(path, r0, r1) < 1e-6
        travel = float(np.sum((path[:-1].inv() * path[1:]).magnitude()))
        assert travel == pytest.approx((r0.inv() * r1).magnitude(), abs=1e-6)
    for t in times[1:-1]:  # the ball joint rests where its axis of turn changes
        assert np.linalg.norm(traj.sample(t)[1][:3]) < 1e-9
    ts = np.linspace(DT, plan.duration - DT, 3000)
    assert np.linalg.norm(_body_rates(traj, ts, slice(0, 4)), axis=1).max() <= 2.0 * 1.001


def test_slerp_that_leaves_the_twist_range_is_refused_naming_keyframes_and_joint(
        arm: armctl.Arm) -> None:
    # twist +-150 deg: 140 deg and -140 deg are inside; the short arc between them turns
    # through 180 deg
    rows = [(_euler((0, 0, 140)), 0.0, (0.0, 0.0)), (_euler((0, 0, -140)), 0.0, (0.0, 0.0))]
    for q, _, _ in rows:
        assert abs(math.degrees(swing_twist(np.array(q), [0, 0, 1])[1])) == pytest.approx(140)
    program = _program(arm, rows)
    with pytest.raises(LimitViolation) as err:
        plan_program(program, arm, MotionLimits.from_model(arm), program.keyframes[0].q,
                     PlaybackOptions(Interpolation.LINEAR))
    text = str(err.value)
    assert "twist" in text and "'shoulder'" in text
    assert "between keyframes 'k0' and 'k1'" in text and "add a keyframe" in text


def test_a_keyframe_outside_the_swing_cone_names_it(arm: armctl.Arm) -> None:
    rows = [(_euler((0, 0, 0)), 0.0, (0.0, 0.0)), (_euler((0, 130, 0)), 0.0, (0.0, 0.0))]
    program = _program(arm, rows)
    with pytest.raises(ConfigError, match=r"swing of ball joint 'shoulder' would be 2\.26"):
        plan_program(program, arm, MotionLimits.from_model(arm), program.keyframes[0].q)


def test_a_program_without_widths_is_refused_clearly(arm: armctl.Arm) -> None:
    kf = Keyframe(q=(1.0, 0.0, 0.0))
    program = KeyframeProgram(arm.name, ("shoulder", "elbow", "wrist"), (kf,))
    with pytest.raises(InputError, match="a ball joint 4, a universal joint 2"):
        plan_program(program, arm, MotionLimits.from_model(arm), arm.neutral())


def test_dwell_gripperless_stops_loops_and_pose_keyframes(arm: armctl.Arm) -> None:
    """A multi-segment program with a dwell, a stop, two loops and pose keyframes by IK."""
    limits = MotionLimits.from_model(arm)
    options = IKOptions(time_limit=5.0)

    def ik(pose: np.ndarray, seed: np.ndarray, oriented: bool) -> np.ndarray:
        goal = PoseGoal(pose) if oriented else PositionGoal(pose[:3, 3])
        res = arm.ik(goal, q0=seed, options=options)
        assert res.success
        return np.asarray(res.q)

    kfs = [Keyframe(q=(*KEYS[1][0], 0.6, 0.3, -0.2), name="a"),
           Keyframe(q=(*KEYS[2][0], 1.2, -0.4, 0.5), name="b", dwell=0.3),
           Keyframe(pose=np.array([[1, 0, 0, 0.3], [0, 1, 0, 0.1], [0, 0, 1, 0.45],
                                   [0, 0, 0, 1.0]]), orientation=False, name="c"),
           Keyframe(q=(*KEYS[3][0], 0.3, 0.1, 0.1), name="d")]
    program = KeyframeProgram(arm.name, ("shoulder", "elbow", "wrist"), tuple(kfs),
                              widths=(4, 1, 2))
    plan = plan_program(program, arm, limits, arm.neutral(),
                        PlaybackOptions(Interpolation.CUBIC, loops=2), ik)
    names = [w.name for w in plan.waypoints]
    assert names == ["a", "b", "c", "d", "a", "b", "c", "d"]
    c = next(w for w in plan.waypoints if w.name == "c")
    assert np.allclose(arm.fk(c.q)[:3, 3], [0.3, 0.1, 0.45], atol=1e-3)
    assert any(e.kind == "dwell" for e in plan.events)
    ts = np.linspace(0.0, plan.duration, 4000)
    q = plan.trajectory.sample_many(ts)[0]
    assert np.allclose(np.linalg.norm(q[:, :4], axis=1), 1.0, atol=1e-12)
    assert all(arm.within_limits(x, tol=1e-6) for x in q[::10])
    # positions continuous: no jump between two samples beyond what the limits allow
    step = ts[1] - ts[0]
    turn = (_rot(q[:-1, :4]).inv() * _rot(q[1:, :4])).magnitude()
    assert turn.max() <= 2.0 * step * 1.01
    assert np.abs(np.diff(q[:, 4:], axis=0)).max() <= 1.0 * step * 1.01


@pytest.fixture(scope="module")
def figure() -> armctl.Arm:
    return armctl.load_arm("figure")  # ball joints at its shoulders and hips


def test_a_walk_of_the_figure_with_ball_hips_and_shoulders(figure: armctl.Arm,
                                                          tmp_path: Path) -> None:
    balls = [n for n, t in zip(figure.joint_names, figure.joint_types, strict=True)
             if t.value == "ball"]
    assert {"left_hip", "right_hip", "left_shoulder", "right_shoulder"} <= set(balls)
    knees = [n for n in figure.joint_names if n.endswith("knee")]
    doc = {"armctl_keyframes": 1, "arm": figure.name, "units": {"angle": "deg"},
           "joints": ["left_hip", "right_hip", "left_shoulder", *knees], "keyframes": []}
    for k, swing in enumerate([0, 25, 0, -25, 0]):
        doc["keyframes"].append({"name": f"step{k}", "q": [
            {"rotvec": [swing, 0, 0]}, {"rotvec": [-swing, 0, 0]},
            {"rpy": [0, 0, swing]}, *([10 + abs(swing)] * len(knees))]})
    path = tmp_path / "walk.yaml"
    path.write_text(yaml.safe_dump(doc), encoding="utf-8")
    from armctl.render.motions import plan_keyframes

    start = figure.neutral()
    plan = plan_keyframes(figure, path, start)
    traj = plan.trajectory
    ts = np.linspace(DT, plan.duration - DT, 2000)
    q = traj.sample_many(ts)[0]
    assert q.shape == (ts.size, figure.nq)
    for name in balls:
        sl = figure.q_index(name)
        assert np.allclose(np.linalg.norm(q[:, sl], axis=1), 1.0, atol=1e-12)
        fd = _body_rates(traj, ts, sl)
        limit = figure.spec.joint(name).limits.velocity
        limit = limit if math.isfinite(limit) else 1.0  # the rotary default [rad/s]
        assert np.linalg.norm(fd, axis=1).max() <= limit * (1 + 1e-3)
    hip = figure.q_index("left_hip")
    step1 = next(w for w in plan.waypoints if w.name == "step1")
    turn = _rot(traj.sample(step1.time)[0][hip])
    assert np.allclose(turn.as_rotvec(), [math.radians(25), 0, 0], atol=1e-9)
    # passing step2 (from +25 to -25 deg) without stopping, the hip's angular velocity is
    # continuous
    step2 = next(w for w in plan.waypoints if w.name == "step2")
    assert not step2.stop
    before = _body_rates(traj, np.array([step2.time - 3e-4]), hip)[0]
    after = _body_rates(traj, np.array([step2.time + 3e-4]), hip)[0]
    assert np.linalg.norm(before) > 0.1
    assert np.linalg.norm(after - before) < 0.02 * np.linalg.norm(before)


def test_straight_lines_and_detours_refuse_what_they_cannot_plan(arm: armctl.Arm) -> None:
    from armctl.ik import PositionGoal as Goal
    from armctl.motion import DetourOptions, Planner, plan_detour
    from armctl.motion.cartesian import plan_line

    limits = MotionLimits.from_model(arm)
    one_dof = MotionLimits(limits.names, limits.lower, limits.upper, limits.velocity,
                           limits.acceleration, limits.jerk, limits.units)
    with pytest.raises(InputError,
                       match=r"universal or ball joints .* \(MotionLimits.from_model\)"):
        plan_line(arm, arm.named_pose("home"), Goal([0.3, 0.1, 0.4]), one_dof)
    with pytest.raises(InputError, match=r"detour of an arm with ball joints needs a collision"):
        plan_detour(None, arm.neutral(), arm.neutral(), limits)  # type: ignore[arg-type]
    with pytest.raises(InputError, match=r"OMPL.*ball joint \(shoulder\).*Planner.BUILTIN"):
        plan_detour(None, arm.neutral(), arm.neutral(), limits,  # type: ignore[arg-type]
                    options=DetourOptions(planner=Planner.OMPL))


BALL_ONLY = """armctl: 1
name: ball_only
base: base
tool: hand
joints:
  - {name: hip, type: ball, parent: base, child: hand, origin: {xyz: [0, 0, 0.1]}}
"""
UNIVERSAL_ONLY = """armctl: 1
name: universal_only
base: base
tool: hand
joints:
  - name: wrist
    type: universal
    parent: base
    child: hand
    origin: {xyz: [0, 0, 0.1]}
    limits: [{lower: -2, upper: 2}, {lower: -1.5, upper: 1.5}]
"""


@pytest.mark.parametrize("text", [BALL_ONLY, UNIVERSAL_ONLY], ids=["ball", "universal"])
@pytest.mark.parametrize("kind", list(Interpolation), ids=lambda k: k.value)
def test_arms_of_ball_or_universal_joints_only(tmp_path: Path, text: str,
                                               kind: Interpolation) -> None:
    path = tmp_path / "arm.yaml"
    path.write_text(text, encoding="utf-8")
    one = armctl.load_arm(path)
    ball = one.joint_types[0].value == "ball"
    rows = ([_euler(e) for e in [(0, 0, 0), (30, 10, 0), (0, 40, -20), (-10, 0, 30)]] if ball
            else [(0.0, 0.0), (0.5, 0.3), (1.0, -0.2), (0.2, 0.1)])
    program = KeyframeProgram(one.name, one.joint_names,
                              tuple(Keyframe(q=tuple(r), name=f"k{i}")
                                    for i, r in enumerate(rows)), widths=(len(rows[0]),))
    plan = plan_program(program, one, MotionLimits.from_model(one), one.neutral(),
                        PlaybackOptions(kind, loops=2))
    assert [w.name for w in plan.waypoints] == ["k0", "k1", "k2", "k3"] * 2
    traj = plan.trajectory
    ts = np.linspace(DT, plan.duration - DT, 2000)
    if ball:
        rates = np.linalg.norm(_body_rates(traj, ts, slice(0, 4)), axis=1)
    else:
        rates = np.abs(traj.sample_many(ts + DT)[0] - traj.sample_many(ts - DT)[0]) / (2 * DT)
    assert rates.max() <= 1.0 * (1 + 1e-3)
    for w, r in zip(plan.waypoints, rows * 2, strict=True):
        q = traj.sample(w.time)[0]
        if ball:
            assert (_rot(q).inv() * _rot(np.array(r))).magnitude() < 1e-9
        else:
            assert np.allclose(q, r, atol=1e-9)
