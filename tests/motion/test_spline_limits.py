"""Spline runs through keyframes at joint limits stay inside the limits.

Independent truth: scipy's ``PPoly`` (its own roots of the derivative) for the extremes of the
polynomial pieces; brute-force sampling (1e5 points) of every produced plan; scipy ``Rotation``
for a ball joint's swing (the angle of its turned twist axis from the rest direction) and twist
(the turn left after undoing the shortest swing); and, for plans the planner accepted before its
overshoot test was exact, the values it produced then.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.interpolate import PPoly
from scipy.spatial.transform import Rotation

import armctl
from armctl.kinematics.joint_space import BallJoint
from armctl.motion import (
    Interpolation,
    Keyframe,
    KeyframeProgram,
    MotionLimits,
    PlaybackOptions,
    plan_program,
)
from armctl.motion.interpolate import piece_extrema
from armctl.motion.multi_dof import _ball_leaves
from armctl.motion.quaternion_spline import QuaternionSpline
from armctl.motion.trajectory import PiecewisePolynomial

DENSE = 100_000
TOL = 1e-9
KINDS = [Interpolation.CUBIC, Interpolation.MIN_JERK]


@pytest.fixture(scope="module")
def figure() -> armctl.Arm:
    return armctl.load_arm("figure")  # knees with lower limit 0, ball shoulders and hips


def _dense(traj: object) -> np.ndarray:
    ts = np.linspace(0.0, traj.duration, DENSE)  # type: ignore[attr-defined]
    return traj.sample_many(ts)[0]  # type: ignore[attr-defined,no-any-return]


def _assert_scalar_inside(q: np.ndarray, limits: MotionLimits) -> None:
    idx = np.arange(q.shape[1]) if limits.layout is None else limits.layout.scalar_q
    assert np.all(q[:, idx] >= limits.lower[idx] - TOL)
    assert np.all(q[:, idx] <= limits.upper[idx] + TOL)


def _wxyz(r: Rotation) -> tuple[float, ...]:
    return tuple(float(x) for x in np.roll(r.as_quat(), 1))


def _swing_twist(quats: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Swing and twist [rad] by scipy: the shortest turn of the axis, then what is left."""
    rot = Rotation.from_quat(np.roll(quats, -1, axis=1))
    moved = rot.apply(axis)
    swing = np.arccos(np.clip(moved @ axis, -1.0, 1.0))
    cross = np.cross(axis, moved)
    norm = np.linalg.norm(cross, axis=1, keepdims=True)
    unit = np.where(norm > 1e-12, cross / np.maximum(norm, 1e-300), 0.0)
    twist = (Rotation.from_rotvec(unit * swing[:, None]).inv() * rot).as_rotvec() @ axis
    return swing, twist


@pytest.mark.parametrize("order", [4, 6])
def test_piece_extrema_are_those_of_scipy_ppoly(order: int) -> None:
    rng = np.random.default_rng(order)
    breaks = np.concatenate([[0.0], np.cumsum(rng.uniform(0.2, 1.5, 7))])
    coeffs = rng.normal(size=(7, order, 3)) * 2.0 ** -np.arange(order)[None, :, None]
    coeffs[2, 2:, 1] = 0.0  # a straight piece: no critical point
    coeffs[4, :, 2] = 0.0  # a constant piece
    lo, hi = piece_extrema(PiecewisePolynomial(breaks, coeffs))
    for k in range(7):
        h = breaks[k + 1] - breaks[k]
        for j in range(3):
            pp = PPoly(coeffs[k, ::-1, j][:, None], [0.0, h])
            roots = pp.derivative().roots(extrapolate=False)
            cand = np.concatenate([[0.0, h], roots[np.isfinite(roots)]])  # nan: a constant
            vals = pp(cand)
            assert lo[k, j] == pytest.approx(vals.min(), abs=1e-12)
            assert hi[k, j] == pytest.approx(vals.max(), abs=1e-12)
            dense = pp(np.linspace(0.0, h, DENSE))
            assert lo[k, j] <= dense.min() + 1e-15 and hi[k, j] >= dense.max() - 1e-15


# Knee keyframes at 0 (its lower limit) that the spline passed with a dip of 1e-5 rad between
# the 48 samples per segment of the earlier test: the plan was refused (LimitViolation).
KNEE_PROGRAMS = [
    (Interpolation.CUBIC, [0.34, 0.0, 1.18, 1.15, 0.87], [0.04, -0.14, 1.15, 0.43, -0.21]),
    (Interpolation.MIN_JERK, [0.75, 0.93, 0.0, 1.1, 0.05], [0.45, 0.33, -0.3, 0.63, 0.96]),
    (Interpolation.CUBIC, [0.13, 0.24, 0.34, 0.0, 0.38], [1.15, 0.84, 0.87, 0.81, 0.56]),
    (Interpolation.MIN_JERK, [0.67, 0.0, 0.95, 0.73, 1.03], [0.77, 0.56, 0.06, 0.85, 0.0]),
]


@pytest.mark.parametrize(("kind", "knee", "lumbar"), KNEE_PROGRAMS)
def test_knee_keyframes_at_the_lower_limit_plan_inside_it(figure: armctl.Arm,
                                                         kind: Interpolation, knee: list[float],
                                                         lumbar: list[float]) -> None:
    limits = MotionLimits.from_model(figure)
    prog = KeyframeProgram("figure", ("left_knee", "lumbar"), tuple(
        Keyframe(q=(k, lu), name=f"k{i}") for i, (k, lu) in enumerate(zip(knee, lumbar,
                                                                          strict=True))))
    plan = plan_program(prog, figure, limits, figure.neutral(), PlaybackOptions(kind))
    q = _dense(plan.trajectory)
    _assert_scalar_inside(q, limits)
    iknee = figure.q_index("left_knee").start
    for w, k in zip(plan.waypoints, knee, strict=True):
        assert plan.trajectory.sample(w.time)[0][iknee] == pytest.approx(k, abs=1e-12)
    # the run stops at the keyframe at the limit (the dip is gone), nowhere below it
    at_zero = [w for w, k in zip(plan.waypoints, knee, strict=True) if k == 0.0]
    assert all(np.abs(plan.trajectory.sample(w.time)[1]).max() < 1e-9 for w in at_zero)


@pytest.mark.parametrize("arm_name", ["so101", "ur5e", "figure"])
def test_random_programs_with_keyframes_at_limits_stay_inside(arm_name: str) -> None:
    arm = armctl.load_arm(arm_name)
    limits = MotionLimits.from_model(arm)
    joints = tuple(n for n, t in zip(arm.joint_names, arm.joint_types, strict=True)
                   if t.value in ("revolute", "prismatic"))
    idx = [arm.q_index(j).start for j in joints] if limits.layout else list(range(arm.nq))
    lo = np.maximum(limits.lower[idx], -3.0)
    hi = np.minimum(limits.upper[idx], 3.0)
    rng = np.random.default_rng(11)
    for trial in range(8):
        u = rng.uniform(size=(5, len(idx)))
        at = rng.uniform(size=u.shape) < 0.3
        u[at] = np.round(u[at])  # keyframes exactly at a limit
        rows = lo + (hi - lo) * u
        prog = KeyframeProgram(arm.name, joints, tuple(Keyframe(q=tuple(map(float, r)))
                                                       for r in rows))
        start = arm.neutral()
        plan = plan_program(prog, arm, limits, start,
                            PlaybackOptions(KINDS[trial % 2], ease_in=True))
        _assert_scalar_inside(_dense(plan.trajectory), limits)


# Plans the planner accepted before its overshoot test was exact, as it produced them then:
# (arm, keyframes, interpolation, duration [s], keyframe times [s]).
BEFORE = [
    ("so101", [(0.0, -0.8, 0.9, 0.3, 0.0, 0.2), (0.6, -0.2, 0.4, -0.5, 1.0, 0.5),
               (-0.4, 0.5, 1.2, 0.6, -1.2, 0.1), (0.2, -1.0, 0.3, 0.0, 0.4, 0.8)],
     Interpolation.CUBIC, 2.073476188206277,
     [0.0, 0.5531997830802181, 1.3737276619484504, 2.073476188206277]),
    ("so101", [(0.0, -0.8, 0.9, 0.3, 0.0, 0.2), (0.6, -0.2, 0.4, -0.5, 1.0, 0.5),
               (-0.4, 0.5, 1.2, 0.6, -1.2, 0.1), (0.2, -1.0, 0.3, 0.0, 0.4, 0.8)],
     Interpolation.MIN_JERK, 2.146555337344465,
     [0.0, 0.6107029469829403, 1.4330879668004521, 2.146555337344465]),
    ("ur5e", [(0.0, -1.2, 1.0, -1.0, 1.5, 0.0), (0.8, -0.6, 0.4, -2.0, 1.0, 0.5),
              (-0.5, -1.5, 1.8, -0.4, 2.0, -0.7)],
     Interpolation.CUBIC, 1.9810852239827188, [0.0, 0.8746856578222831, 1.9810852239827188]),
    ("ur5e", [(0.0, -1.2, 1.0, -1.0, 1.5, 0.0), (0.8, -0.6, 0.4, -2.0, 1.0, 0.5),
              (-0.5, -1.5, 1.8, -0.4, 2.0, -0.7)],
     Interpolation.MIN_JERK, 2.0023611941276536, [0.0, 0.8840793909725494, 2.0023611941276536]),
    # the spline through these swings the elbow 0.05-0.1 rad past its upper limit next to the
    # third keyframe: the run stops there, as it did before
    ("so101", [(0.0, -0.5, -1.0, 0.0, 0.0, 0.2), (0.3, 0.0, 0.4, 0.2, 0.5, 0.2),
               (0.6, 0.4, 1.65, 0.4, 1.0, 0.2), (0.2, 0.1, 1.6, 0.0, 0.3, 0.2)],
     Interpolation.CUBIC, 1.366039516360825,
     [0.0, 0.46950301690260693, 0.903199371170285, 1.366039516360825]),
    ("so101", [(0.0, -0.5, -1.0, 0.0, 0.0, 0.2), (0.3, 0.0, 0.4, 0.2, 0.5, 0.2),
               (0.6, 0.4, 1.65, 0.4, 1.0, 0.2), (0.2, 0.1, 1.6, 0.0, 0.3, 0.2)],
     Interpolation.MIN_JERK, 1.6943452150512925,
     [0.0, 0.5614654539680795, 1.0940090978222163, 1.6943452150512925]),
]


@pytest.mark.parametrize(("arm_name", "rows", "kind", "duration", "times"), BEFORE)
def test_plans_accepted_before_are_unchanged(arm_name: str, rows: list[tuple[float, ...]],
                                             kind: Interpolation, duration: float,
                                             times: list[float]) -> None:
    arm = armctl.load_arm(arm_name)
    limits = MotionLimits.from_model(arm)
    prog = KeyframeProgram(arm.name, tuple(arm.joint_names), tuple(Keyframe(q=r) for r in rows))
    plan = plan_program(prog, arm, limits, np.array(rows[0]), PlaybackOptions(kind,
                                                                              ease_in=False))
    assert plan.duration == pytest.approx(duration, rel=1e-12)
    assert [w.time for w in plan.waypoints] == pytest.approx(times, rel=1e-12, abs=1e-15)
    _assert_scalar_inside(_dense(plan.trajectory), limits)


def _random_spline(rng: np.random.Generator, swing_max: float) -> QuaternionSpline:
    rows = []
    for _ in range(5):
        phi = rng.uniform(0.0, 2.0 * math.pi)
        swing = rng.uniform(0.0, swing_max)
        turn = (Rotation.from_rotvec(swing * np.array([math.cos(phi), 0.0, math.sin(phi)]))
                * Rotation.from_rotvec([0.0, rng.uniform(-0.8, 0.8), 0.0]))
        rows.append(_wxyz(turn))
    times = np.concatenate([[0.0], np.cumsum(rng.uniform(0.3, 1.2, 4))])
    return QuaternionSpline(times, np.array(rows))


def test_the_ball_limit_test_never_misses_a_swing_or_twist_outside() -> None:
    rng = np.random.default_rng(5)
    axis = np.array([0.0, 1.0, 0.0])
    found = {True: 0, False: 0}
    for _ in range(6):
        spline = _random_spline(rng, 1.2)
        for k in range(4):
            ts = np.linspace(spline.times[k], spline.times[k + 1], DENSE)
            swing, twist = _swing_twist(spline(ts), axis)
            # limits just above, at and just below what the segment reaches
            for pad in (1e-3, 1e-6, 0.0, -1e-6, -1e-3):
                cone = BallJoint("b", slice(0, 4), slice(0, 3), axis, float(swing.max()) + pad,
                                 -math.inf, math.inf)
                leaves = _ball_leaves(spline, k, cone)
                found[leaves] += 1
                if not leaves:
                    assert swing.max() <= cone.swing + TOL
                if pad <= -1e-6:
                    assert leaves
                if pad >= 1e-6:
                    assert not leaves
                twisted = BallJoint("b", slice(0, 4), slice(0, 3), axis, math.pi,
                                    float(twist.min()) - pad, float(twist.max()) + pad)
                leaves = _ball_leaves(spline, k, twisted)
                if not leaves:
                    assert twist.min() >= twisted.lower - TOL
                    assert twist.max() <= twisted.upper + TOL
                if pad <= -1e-6:
                    assert leaves
                if pad >= 1e-6:
                    assert not leaves
    assert found[True] > 0 and found[False] > 0


@pytest.mark.parametrize("kind", KINDS)
def test_a_shoulder_keyframe_at_its_swing_limit_plans_inside_it(figure: armctl.Arm,
                                                               kind: Interpolation) -> None:
    limits = MotionLimits.from_model(figure)
    ball = next(b for b in limits.layout.balls if b.name == "left_shoulder")  # type: ignore[union-attr]
    rows = []
    for swing_deg, phi, twist in [(20, 0.0, 0.1), (60, 0.2, 0.3), (100, 0.4, 0.2), (70, 0.3, 0.0),
                                  (30, 0.1, -0.2)]:
        turn = (Rotation.from_rotvec(math.radians(swing_deg)
                                     * np.array([math.cos(phi), 0.0, math.sin(phi)]))
                * Rotation.from_rotvec(twist * ball.axis))
        rows.append((*_wxyz(turn), 0.5))
    assert math.radians(100) == pytest.approx(ball.swing)  # the keyframe is at the limit
    prog = KeyframeProgram("figure", ("left_shoulder", "left_elbow"),
                           tuple(Keyframe(q=r) for r in rows), widths=(4, 1))
    plan = plan_program(prog, figure, limits, figure.neutral(), PlaybackOptions(kind))
    q = _dense(plan.trajectory)
    swing, twist = _swing_twist(q[:, ball.q], ball.axis)
    assert swing.max() <= ball.swing + TOL
    assert np.all((twist >= ball.lower - TOL) & (twist <= ball.upper + TOL))
    _assert_scalar_inside(q, limits)


def test_the_speed_bound_is_never_exceeded() -> None:
    """The angular speed by finite differences of scipy rotations stays under the bound."""
    rng = np.random.default_rng(8)
    spline = _random_spline(rng, 1.5)
    dt = 1e-6
    for k in range(4):
        t0, t1 = spline.times[k], spline.times[k + 1]
        cuts = np.sort(rng.uniform(0.0, 1.0, 12))
        bounds = spline.speed_bound(np.full(11, k), cuts[:-1], cuts[1:])
        for a, b, bound in zip(cuts[:-1], cuts[1:], bounds, strict=True):
            ts = t0 + (t1 - t0) * np.linspace(a, b, 200)
            ts = np.clip(ts, t0 + dt, t1 - dt)
            r0 = Rotation.from_quat(np.roll(spline(ts - dt), -1, axis=1))
            r1 = Rotation.from_quat(np.roll(spline(ts + dt), -1, axis=1))
            speed = (r0.inv() * r1).magnitude() / (2.0 * dt)
            assert speed.max() <= bound * (1.0 + 1e-6) + 1e-9
    # the run ends at rest: the bound falls to zero towards its last keyframe
    last = spline.speed_bound([3, 3], [0.5, 0.999], [1.0, 1.0])
    assert last[1] < 0.01 * last[0]
