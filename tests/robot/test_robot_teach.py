"""Teach and playback on the simulated bus: hand-guiding, atomic files, kill mid-teach."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.config.motion import ExitPolicy
from armctl.motion import Interpolation, PlaybackOptions, load_keyframes
from armctl.robot import Robot
from armctl.robot.teach import TeachSession


@pytest.fixture(scope="module")
def so101() -> Arm:
    return load_arm("so101")


@pytest.fixture
def robot(so101: Arm) -> Iterator[Robot]:
    """The bundled SO-101 on its simulated bus, holding its start pose."""
    with Robot.open(so101, speed=0.7, exit_policy=ExitPolicy.HOLD) as r:
        yield r


TICK = 2 * np.pi / 4096  # STS3215 resolution [rad]


def test_hand_guided_poses_are_recorded(robot: Robot, tmp_path: Path) -> None:
    sim = robot.bus.simulator
    path = tmp_path / "taught.yaml"
    session = TeachSession(robot, path)
    session.start()
    assert session.release == ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex",
                               "wrist_roll")
    torque = robot.bus.torque()
    assert not any(torque[j] for j in session.release) and torque["gripper"]  # gripper stiff
    pushed = [np.array([0.2, -0.3, 0.4, 0.2, 0.1]), np.array([-0.2, -0.1, 0.5, -0.2, 0.3]),
              np.array([0.1, -0.4, 0.6, 0.3, -0.1])]
    for k, q in enumerate(pushed):
        for name, v in zip(session.release, q, strict=True):
            sim.set_joint(name, float(v))
        session.record(name=f"p{k}", dwell=0.1 * k)
        assert len(load_keyframes(path, robot.arm).keyframes) == k + 1  # saved every time
    held_before = robot.joints()
    program = session.finish()
    assert all(robot.bus.torque().values())
    robot.clock.sleep_until(robot.clock.now() + 0.2)
    assert np.allclose(robot.joints(), held_before, atol=2 * TICK)  # no jump on torque-on
    back = load_keyframes(path, robot.arm)
    assert back.calibration == program.calibration
    for kf, q in zip(back.keyframes, pushed, strict=True):
        assert np.allclose(kf.q, q, atol=TICK)
    # playback passes through the taught keyframes
    opts = PlaybackOptions(Interpolation.MIN_JERK, blend=False, ease_in_speed=0.7, speed=0.7)
    plan = robot.plan_program(back, opts)
    res = robot.execute(plan, record=True)
    idx = robot.executor.idx
    for wp in plan.waypoints:
        k = int(np.argmin(np.abs(res.log_t - wp.time)))
        assert np.max(np.abs(res.log_cmd[k] - wp.q[idx])) < 0.02
        assert np.max(np.abs(res.log_meas[min(k + 3, len(res.log_t) - 1)] - wp.q[idx])) < 0.03
    assert np.allclose(res.final[:5], pushed[-1], atol=0.01)


def test_continuous_recording_and_undo(robot: Robot, tmp_path: Path) -> None:
    import threading

    session = TeachSession(robot, tmp_path / "rec.yaml")
    session.start()
    assert session.limp
    n = session.record_continuous(50.0, threading.Event(), duration=0.2)
    prog = load_keyframes(tmp_path / "rec.yaml", robot.arm)
    assert len(prog.keyframes) == n >= 10
    stamps = np.diff([k.time for k in prog.keyframes])
    assert prog.timed and np.all(stamps > 0) and abs(np.median(stamps) - 0.02) < 0.005
    session.undo()
    assert len(load_keyframes(tmp_path / "rec.yaml", robot.arm).keyframes) == n - 1
    session.finish()


def test_jog_modes(robot: Robot, tmp_path: Path) -> None:
    session = TeachSession(robot, tmp_path / "jog.yaml")
    session.start()
    session.jog_joint("elbow_flex", 0.5, speed=0.7)  # switches torque on first
    assert not session.limp and robot.joints()[2] == pytest.approx(0.5, abs=0.01)
    assert all(robot.bus.torque().values())
    session.jog_joint("shoulder_lift", -0.5, speed=0.7)
    p0 = robot.pose()[:3, 3]
    session.jog_cartesian([0.0, 0.0, 0.02], speed=0.7)
    assert np.allclose(robot.pose()[:3, 3], [*p0[:2], p0[2] + 0.02], atol=2e-3)
    session.finish()


@pytest.mark.realtime  # end to end: `armctl teach` in a subprocess, in wall-clock time
def test_killing_teach_mid_session_leaves_a_valid_file(tmp_path: Path) -> None:
    out = tmp_path / "killed.yaml"
    proc = subprocess.Popen([sys.executable, "-m", "armctl", "teach", "so101", "-o", str(out)],
                            stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, text=True)
    try:
        from armctl.arm import load_arm

        arm = load_arm("so101")
        for k in range(3):
            proc.stdin.write(f"k kf{k}\n")
            proc.stdin.flush()
            deadline = time.monotonic() + 30
            while time.monotonic() < deadline:
                if out.exists() and len(load_keyframes(out, arm).keyframes) == k + 1:
                    break
                time.sleep(0.05)
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
    prog = load_keyframes(out, arm)
    assert [k.name for k in prog.keyframes] == ["kf0", "kf1", "kf2"]
    assert not [p for p in os.listdir(tmp_path) if p.endswith(".tmp")]
