"""Keyframe playback: limits over many random keyframe sets, pass-through, dwell, gripper, loops."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.errors import InputError
from armctl.motion import (
    Interpolation,
    Keyframe,
    KeyframeProgram,
    LimitViolation,
    MotionLimits,
    PlaybackOptions,
    plan_program,
)
from armctl.motion.interpolate import spline_through

ARM3G = Path(__file__).parent / "data" / "arm3g.yaml"  # planar 3R + prismatic gripper


@pytest.fixture(scope="module")
def arm3g() -> Arm:
    return load_arm(ARM3G)


@pytest.fixture(scope="module")
def limits3g(arm3g: Arm) -> MotionLimits:
    return MotionLimits.from_model(arm3g)


MODES = [(i, b) for i in Interpolation for b in (True, False)]


def _random_program(arm: Arm, rng: np.random.Generator, n: int) -> KeyframeProgram:
    names = arm.joint_names[:3]  # arm joints; the gripper follows 'gripper' values
    lo, hi = arm.lower[:3], arm.upper[:3]
    kfs = []
    for k in range(n):
        q = rng.uniform(lo, hi)
        dwell = 0.2 if rng.random() < 0.2 else 0.0
        grip = float(rng.uniform(0.0, 0.04)) if rng.random() < 0.2 else None
        kfs.append(Keyframe(q=tuple(q), name=f"k{k}", dwell=dwell, gripper=grip))
    return KeyframeProgram(arm.name, names, tuple(kfs))


def _dense_check(plan_traj, limits: MotionLimits) -> None:
    """Independent check: 1 kHz samples, limits, and velocity consistent with position."""
    ts = np.arange(0.0, plan_traj.duration, 1e-3)
    q, qd, qdd = plan_traj.sample_many(ts)
    assert np.all(q >= limits.lower - 1e-9) and np.all(q <= limits.upper + 1e-9)
    assert np.all(np.abs(qd) <= limits.velocity * (1 + 1e-6))
    assert np.all(np.abs(qdd) <= limits.acceleration * (1 + 1e-6))
    fd = np.diff(q, axis=0) / 1e-3
    mid = (qd[1:] + qd[:-1]) / 2
    # finite differences agree with the reported velocity (bounded acceleration between)
    assert np.max(np.abs(fd - mid)) <= 1e-3 * np.max(limits.acceleration) + 1e-9


@pytest.mark.parametrize(("interp", "blend"), MODES,
                         ids=[f"{i.value}-{'blend' if b else 'stop'}" for i, b in MODES])
def test_random_keyframe_sets_respect_limits_and_pass_keyframes(
        arm3g: Arm, limits3g: MotionLimits, interp: Interpolation, blend: bool) -> None:
    rng = np.random.default_rng(MODES.index((interp, blend)))
    opts = PlaybackOptions(interpolation=interp, blend=blend, speed=0.8)
    for _ in range(8):
        prog = _random_program(arm3g, rng, int(rng.integers(2, 7)))
        start = arm3g.sample(rng)
        start[3] = 0.01
        plan = plan_program(prog, arm3g, limits3g, start, opts)
        _dense_check(plan.trajectory, limits3g)
        assert np.allclose(plan.trajectory.sample(0.0)[0], start, atol=1e-12)
        # every keyframe is passed within 1e-6 rad at the reported time
        assert len(plan.waypoints) == len(prog.keyframes)
        for wp, kf in zip(plan.waypoints, prog.keyframes, strict=True):
            q = plan.trajectory.sample(wp.time)[0]
            assert np.max(np.abs(q[:3] - np.array(kf.q))) < 1e-6
        # the gripper holds each commanded value until the next keyframe (or the end)
        names = [w.name for w in plan.waypoints]
        for ev in (e for e in plan.events if e.kind == "gripper"):
            k = names.index(ev.name)
            t_next = plan.waypoints[k + 1].time if k + 1 < len(names) else plan.duration
            assert plan.trajectory.sample(t_next)[0][3] == pytest.approx(ev.value, abs=1e-9)


def test_blending_is_faster_than_stopping(arm3g: Arm, limits3g: MotionLimits) -> None:
    # keyframes along a monotone path: passing through them must save time
    qs = [(0.1 * k, 0.15 * k, -0.1 * k) for k in range(6)]
    prog = KeyframeProgram(arm3g.name, arm3g.joint_names[:3],
                           tuple(Keyframe(q=q) for q in qs))
    start = np.array([0.0, 0.0, 0.0, 0.0])
    for interp in Interpolation:
        fast = plan_program(prog, arm3g, limits3g, start, PlaybackOptions(interp, blend=True))
        slow = plan_program(prog, arm3g, limits3g, start, PlaybackOptions(interp, blend=False))
        assert fast.duration < 0.8 * slow.duration, interp
        # blended: no stop at the inner keyframes
        mid = fast.waypoints[3]
        assert np.max(np.abs(fast.trajectory.sample(mid.time)[1])) > 0.05


def test_cubic_is_c2_and_min_jerk_is_quintic() -> None:
    rng = np.random.default_rng(3)
    t = np.array([0.0, 0.7, 1.1, 2.0, 2.4])
    q = rng.normal(size=(5, 2))
    for kind in (Interpolation.CUBIC, Interpolation.MIN_JERK):
        sp = spline_through(t, q, kind)
        eps = 1e-7
        for knot in t[1:-1]:
            a = sp.sample_many([knot - eps, knot + eps])
            assert np.allclose(a[1][0], a[1][1], atol=1e-5)  # velocity continuous
            assert np.allclose(a[2][0], a[2][1], atol=1e-4)  # acceleration continuous
    # one rest-to-rest min-jerk segment is 10 tau^3 - 15 tau^4 + 6 tau^5
    seg = spline_through(np.array([0.0, 2.0]), np.array([[0.0], [1.0]]), Interpolation.MIN_JERK)
    tau = np.linspace(0, 1, 11)
    assert np.allclose(seg.sample_many(2 * tau)[0][:, 0], 10 * tau**3 - 15 * tau**4 + 6 * tau**5)


def test_dwell_reverse_loops_and_ease_in(arm3g: Arm, limits3g: MotionLimits) -> None:
    kfs = (Keyframe(q=(0.0, 0.0, 0.0), name="a"), Keyframe(q=(0.5, 0.2, 0.1), name="b", dwell=0.5),
           Keyframe(q=(1.0, -0.4, 0.3), name="c"))
    prog = KeyframeProgram(arm3g.name, arm3g.joint_names[:3], kfs)
    start = np.array([-0.3, 0.1, 0.0, 0.0])
    plan = plan_program(prog, arm3g, limits3g, start, PlaybackOptions(loops=2, reverse=True))
    assert [w.name for w in plan.waypoints] == ["c", "b", "a"] * 2
    dwells = [e for e in plan.events if e.kind == "dwell"]
    assert len(dwells) == 2 and all(e.value == 0.5 for e in dwells)
    for e in dwells:  # standing still during the dwell
        q0 = plan.trajectory.sample(e.time + 0.01)[0]
        q1 = plan.trajectory.sample(e.time + 0.49)[0]
        assert np.allclose(q0, q1, atol=1e-12)
    # ease-in: the first 'c' is reached at a lower speed factor (0.3) than the rest
    first = plan.waypoints[0].time
    _, qd, _ = plan.trajectory.sample_many(np.linspace(0, first, 200))
    assert np.max(np.abs(qd) / limits3g.velocity) <= 0.3 + 1e-6
    with pytest.raises(InputError, match="not at the first keyframe"):
        plan_program(prog, arm3g, limits3g, start, PlaybackOptions(ease_in=False))


def test_gripper_event_moves_only_the_gripper(arm3g: Arm, limits3g: MotionLimits) -> None:
    kfs = (Keyframe(q=(0.0, 0.0, 0.0), name="open"),
           Keyframe(q=(0.4, 0.4, 0.0), name="grasp", gripper=0.03),
           Keyframe(q=(0.0, 0.3, 0.0), name="lift"))
    prog = KeyframeProgram(arm3g.name, arm3g.joint_names[:3], kfs)
    plan = plan_program(prog, arm3g, limits3g, np.zeros(4), PlaybackOptions())
    (ev,) = [e for e in plan.events if e.kind == "gripper"]
    assert ev.name == "grasp" and ev.value == 0.03
    q_at, _, _ = plan.trajectory.sample(ev.time)
    later = plan.waypoints[2].time
    ts = np.linspace(ev.time, ev.time + 0.5, 50)
    q, _, _ = plan.trajectory.sample_many(ts)
    assert np.allclose(q[:, :3], q_at[:3], atol=1e-12)  # arm holds while the gripper closes
    assert plan.trajectory.sample(later)[0][3] == pytest.approx(0.03, abs=1e-9)
    no_grip = KeyframeProgram("x", ("j1",), (Keyframe(q=(0.0,), gripper=0.1),))
    planar = load_arm(Path(__file__).parent.parent / "data" / "planar3r.yaml")
    with pytest.raises(InputError, match="no gripper"):
        plan_program(no_grip, planar, MotionLimits.from_model(planar), np.zeros(3))


def test_recorded_timing_is_followed_and_too_fast_is_refused(
        arm3g: Arm, limits3g: MotionLimits) -> None:
    ts = np.linspace(0.0, 2.0, 21)
    # a recording that starts and ends at rest
    kfs = tuple(Keyframe(q=(0.15 * (1 - np.cos(np.pi * t)), 0.2 * (t - np.sin(np.pi * t) / np.pi),
                            0.0), time=float(t)) for t in ts)
    prog = KeyframeProgram(arm3g.name, arm3g.joint_names[:3], kfs)
    start = np.array([0.0, 0.0, 0.0, 0.0])
    opts = PlaybackOptions(Interpolation.CUBIC, ease_in=False)
    one = plan_program(prog, arm3g, limits3g, start, opts)
    assert one.duration == pytest.approx(2.0, abs=1e-9)
    two = plan_program(prog, arm3g, limits3g, start,
                       PlaybackOptions(Interpolation.CUBIC, ease_in=False, speed=2.0))
    assert two.duration == pytest.approx(1.0, abs=1e-9)
    fast = KeyframeProgram(arm3g.name, arm3g.joint_names[:3],
                           tuple(Keyframe(q=(1.0 - np.cos(np.pi * t), 0.0, 0.0), time=float(t) / 4)
                                 for t in ts))
    with pytest.raises(LimitViolation, match=r"try --speed 0\.\d+") as info:
        plan_program(fast, arm3g, limits3g, start,
                     PlaybackOptions(Interpolation.CUBIC, ease_in=True))
    assert info.value.joint == "j1"


def test_recording_that_stands_still_keeps_its_timing(arm3g: Arm, limits3g: MotionLimits) -> None:
    # still for 1 s, then a smooth 1 s move: the arm must not start moving early
    ts = np.round(np.arange(0.0, 2.0001, 0.05), 4)
    ramp = np.clip(ts - 1.0, 0.0, 1.0)
    pos = 0.3 * (ramp - np.sin(2 * np.pi * ramp) / (2 * np.pi))
    prog = KeyframeProgram(arm3g.name, arm3g.joint_names[:3],
                           tuple(Keyframe(q=(p, 0.0, 0.0), time=float(t))
                                 for p, t in zip(pos, ts, strict=True)))
    for interp in Interpolation:
        plan = plan_program(prog, arm3g, limits3g, np.zeros(4),
                            PlaybackOptions(interp, ease_in=False))
        assert plan.duration == pytest.approx(2.0, abs=1e-4)
        q, _, _ = plan.trajectory.sample_many(np.linspace(0.0, 0.95, 20))
        assert np.max(np.abs(q[:, 0])) < 1e-9, interp
        assert plan.trajectory.sample(2.0)[0][0] == pytest.approx(0.3, abs=1e-9)


@pytest.mark.parametrize(("keyframe", "message"), [
    (Keyframe(q=(0.1, 2.8, 0.0), name="reach"), "joint 'j2' would be 2.8 rad, outside its "
                                                 "limits [-2.5, 2.5] rad"),
    (Keyframe(q=(0.1, 0.2, 0.0), gripper=0.06), "gripper value for joint 'finger' would be "
                                                "0.06 m, outside its limits [0, 0.04] m"),
])
def test_keyframe_outside_limits_is_bad_input(arm3g: Arm, limits3g: MotionLimits,
                                              keyframe: Keyframe, message: str) -> None:
    from armctl.errors import ConfigError

    program = KeyframeProgram("arm3g", ("j1", "j2", "j3"),
                              (Keyframe(q=(0.0, 0.0, 0.0)), keyframe))
    with pytest.raises(ConfigError) as err:
        plan_program(program, arm3g, limits3g, np.zeros(arm3g.dof))
    assert err.value.exit_code == 2 and message in str(err.value)
    assert err.value.where.keys == ("keyframes", 1)


def test_each_segment_takes_the_interpolation_of_the_keyframe_it_arrives_at(
        arm3g: Arm, limits3g: MotionLimits) -> None:
    """Linear into b and c, min-jerk into d: straight in joint space up to c, at rest at c."""
    qs = [(0.0, 0.0, 0.0), (0.4, 0.2, -0.1), (0.8, -0.2, 0.2), (0.2, 0.5, 0.4)]
    kinds = [None, Interpolation.LINEAR, Interpolation.LINEAR, Interpolation.MIN_JERK]
    prog = KeyframeProgram(arm3g.name, arm3g.joint_names[:3], tuple(
        Keyframe(q=q, name=n, interpolation=k) for q, n, k in zip(qs, "abcd", kinds,
                                                                   strict=True)))
    start = np.array([0.0, 0.0, 0.0, 0.0])
    plan = plan_program(prog, arm3g, limits3g, start,
                        PlaybackOptions(Interpolation.CUBIC, blend=True))
    _dense_check(plan.trajectory, limits3g)
    wp = {w.name: w for w in plan.waypoints}
    for name, q in zip("abcd", qs, strict=True):
        assert np.allclose(plan.trajectory.sample(wp[name].time)[0][:3], q, atol=1e-6)
    # a -> b -> c is what a linear playback of a, b, c alone gives, sample for sample
    c = np.array(qs[2])
    first = KeyframeProgram(arm3g.name, arm3g.joint_names[:3],
                            tuple(Keyframe(q=q) for q in qs[:3]))
    linear = plan_program(first, arm3g, limits3g, start,
                          PlaybackOptions(Interpolation.LINEAR, blend=True))
    assert linear.duration == pytest.approx(wp["c"].time, abs=1e-9)
    ts = np.linspace(0.0, linear.duration, 200)
    assert np.allclose(plan.trajectory.sample_many(ts)[0], linear.trajectory.sample_many(ts)[0],
                       atol=1e-9)
    # the kind changes at c: the arm rests there, then c -> d is one min-jerk segment
    assert wp["c"].stop and np.allclose(plan.trajectory.sample(wp["c"].time)[1], 0.0,
                                        atol=1e-9)
    d = np.array(qs[3])
    tau = np.linspace(0.0, 1.0, 11)
    dur = wp["d"].time - wp["c"].time
    q_cd = plan.trajectory.sample_many(wp["c"].time + tau * dur)[0][:, :3]
    s_tau = 10 * tau**3 - 15 * tau**4 + 6 * tau**5
    assert np.allclose(q_cd, c + s_tau[:, None] * (d - c), atol=1e-6)
    # the same keyframes without the field are all cubic: another path from a to c
    plain = KeyframeProgram(arm3g.name, arm3g.joint_names[:3],
                            tuple(Keyframe(q=q, name=n) for q, n in zip(qs, "abcd", strict=True)))
    cubic = plan_program(plain, arm3g, limits3g, start,
                         PlaybackOptions(Interpolation.CUBIC, blend=True))
    t_c = {w.name: w for w in cubic.waypoints}["c"].time
    assert not np.allclose(cubic.trajectory.sample_many(np.linspace(0.0, t_c, 200))[0],
                           plan.trajectory.sample_many(np.linspace(0.0, wp["c"].time, 200))[0],
                           atol=1e-3)
