"""``--tcp-speed`` and ``--tcp-angular-speed`` on straight-line moves.

The speed of the tool is measured here by brute force: the planned trajectory sampled every
millisecond, FK of each sample, finite differences of position and orientation. Through the
command line the plan's own figures and its duration are checked; the limits are also checked
against the joint limits (a TCP speed the joints cannot reach leaves the joint-limited plan).
"""

from __future__ import annotations

import json
import math
from typing import Any

import numpy as np
import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.ik import PoseGoal, PositionGoal
from armctl.motion import MotionLimits
from armctl.motion.cartesian import LineOptions, plan_line

pytestmark = [pytest.mark.timeout(60), pytest.mark.usefixtures("simulated_time")]


def measured_speeds(arm: Any, traj: Any, dt: float = 1e-3) -> tuple[float, float]:
    """Peak linear [m/s] and angular [rad/s] speed of the tool along a trajectory."""
    ts = np.arange(0.0, traj.duration + dt / 2, dt)
    q, _, _ = traj.sample_many(ts)
    poses = np.array([arm.fk(qi) for qi in q])
    v = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1) / dt
    w = []
    for a, b in zip(poses[:-1, :3, :3], poses[1:, :3, :3], strict=True):
        c = (float(np.trace(a.T @ b)) - 1.0) / 2.0
        w.append(math.acos(max(-1.0, min(1.0, c))) / dt)
    return float(v.max()), float(max(w))


def test_the_tool_keeps_to_the_linear_speed_limit() -> None:
    arm = load_arm("ur5e")
    q0 = arm.named_pose("home")
    start = arm.fk(q0)
    goal = PositionGoal(start[:3, 3] + np.array([0.10, 0.05, -0.05]))
    limits = MotionLimits.from_model(arm)
    free = plan_line(arm, q0, goal, limits)
    v_free, _ = measured_speeds(arm, free.trajectory)
    cap = v_free / 4  # well below what the joints allow
    plan = plan_line(arm, q0, goal, limits, options=LineOptions(tcp_speed=cap))
    v, _ = measured_speeds(arm, plan.trajectory)
    assert v <= cap * 1.01
    assert v >= cap * 0.95  # as fast as allowed, not slower
    assert plan.extra["tcp_speed_peak"] == pytest.approx(v, rel=0.02)
    assert plan.duration > free.duration * 3.5


def test_the_tool_keeps_to_the_angular_speed_limit() -> None:
    arm = load_arm("ur5e")
    q0 = arm.named_pose("home")
    start = arm.fk(q0)
    c, s = math.cos(0.5), math.sin(0.5)
    turned = start.copy()
    turned[:3, :3] = start[:3, :3] @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    goal = PoseGoal(turned)
    limits = MotionLimits.from_model(arm)
    plan = plan_line(arm, q0, goal, limits, options=LineOptions(tcp_angular_speed=0.1))
    _, w = measured_speeds(arm, plan.trajectory)
    assert 0.095 <= w <= 0.101
    assert plan.extra["tcp_angular_speed_peak"] == pytest.approx(w, rel=0.02)


def test_a_tcp_speed_beyond_the_joints_keeps_the_joint_limited_timing() -> None:
    arm = load_arm("ur5e")
    q0 = arm.named_pose("home")
    goal = PositionGoal(arm.fk(q0)[:3, 3] + np.array([0.0, 0.0, 0.1]))
    limits = MotionLimits.from_model(arm)
    free = plan_line(arm, q0, goal, limits)
    fast = plan_line(arm, q0, goal, limits, options=LineOptions(tcp_speed=100.0,
                                                                tcp_angular_speed=100.0))
    assert fast.duration == pytest.approx(free.duration)
    assert fast.peak_ratios()[0] <= 1.0


@pytest.mark.parametrize("bad", [0.0, -0.1, math.inf, math.nan])
def test_line_options_refuse_non_positive_speeds(bad: float) -> None:
    with pytest.raises(ValueError, match="positive finite"):
        LineOptions(tcp_speed=bad)
    with pytest.raises(ValueError, match="positive finite"):
        LineOptions(tcp_angular_speed=bad)


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, Any, str]:
    code = main([*argv, "--json"])
    out, err = capsys.readouterr()
    return code, json.loads(out) if out.strip() else None, err


def test_move_to_pose_linear_with_tcp_speed(capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "so101", "--relative", "--xyz", "0", "0",
                          "0.05", "--linear", "--tcp-speed", "0.02")
    assert code == 0, err
    assert data["tcp_speed"] == 0.02
    assert 0.019 <= data["tcp_speed_peak"] <= 0.0201
    # a straight 50 mm at a minimum-jerk peak of 0.02 m/s: 15/8 * 0.05 / 0.02 = 4.69 s
    assert data["plan"]["duration"] == pytest.approx(15 / 8 * 0.05 / 0.02, rel=0.03)
    assert data["moved"] is True


def test_tcp_angular_speed_in_degrees(capsys: pytest.CaptureFixture[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "ur5e", "--relative", "tool", "--rpy", "0",
                          "0", "20", "--deg", "--linear", "--tcp-angular-speed", "10",
                          "--dry-run")
    assert code == 0, err
    assert data["tcp_angular_speed"] == pytest.approx(math.radians(10))
    assert math.radians(9.5) <= data["tcp_angular_speed_peak"] <= math.radians(10.05)
    assert data["plan"]["duration"] == pytest.approx(15 / 8 * 20 / 10, rel=0.03)
    assert data["moved"] is False


@pytest.mark.parametrize(("extra", "words"), [
    (["--tcp-speed", "0.05"], ["--tcp-speed applies to straight-line moves", "--linear"]),
    (["--tcp-angular-speed", "0.5"], ["--tcp-angular-speed applies", "--linear"]),
    (["--linear", "--tcp-angular-speed", "30"], ["did you mean --deg?"]),
    (["--linear", "--tcp-speed", "50"], ["did you mean --tcp-speed 0.05 (50 mm/s)?"]),
])
def test_tcp_speed_misuse_is_refused(capsys: pytest.CaptureFixture[str], extra: list[str],
                                     words: list[str]) -> None:
    code, data, err = run(capsys, "move-to-pose", "ur5e", "--relative", "--xyz", "0", "0",
                          "0.01", *extra)
    assert code == 2, err
    for w in words:
        assert w in data["error"]["message"]


@pytest.mark.parametrize("value", ["0", "-0.05", "nan", "fast"])
def test_non_positive_tcp_speeds_are_usage_errors(capsys: pytest.CaptureFixture[str],
                                                  value: str) -> None:
    for flag in ("--tcp-speed", "--tcp-angular-speed"):
        code = main(["move-to-pose", "ur5e", "--relative", "--xyz", "0", "0", "0.01",
                     "--linear", flag, value])
        assert code == 2
        assert flag in capsys.readouterr().err
