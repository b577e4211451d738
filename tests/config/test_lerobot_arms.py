"""The bundled arms LeRobot users own: Koch v1.1 follower and leader, SO-101 leader.

Servo ids and models are checked against LeRobot's robot classes (transcribed below with their
source); the Koch kinematics against the designer's MuJoCo model, composed here by hand; the
simulator against the makers' model numbers through the vendor SDK.
"""

from __future__ import annotations

import math
import os
import select
import subprocess
import sys

import numpy as np
import pytest

import armctl
from armctl.config import load_spec
from armctl.servo import ArmBus, ServoBus

pytestmark = pytest.mark.timeout(60)

#: huggingface/lerobot (7427f318): robots/koch_follower/koch_follower.py,
#: teleoperators/koch_leader/koch_leader.py, teleoperators/so_leader/so_leader.py.
LEROBOT_MOTORS = {
    "koch_follower": {"shoulder_pan": (1, "xl430-w250"), "shoulder_lift": (2, "xl430-w250"),
                      "elbow_flex": (3, "xl330-m288"), "wrist_flex": (4, "xl330-m288"),
                      "wrist_roll": (5, "xl330-m288"), "gripper": (6, "xl330-m288")},
    "koch_leader": {n: (i, "xl330-m077") for i, n in enumerate(
        ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"),
        start=1)},
    "so101_leader": {n: (i, "sts3215") for i, n in enumerate(
        ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper"),
        start=1)},
}
#: Model numbers: ROBOTIS e-Manual (XL430-W250 1060, XL330-M288 1200, XL330-M077 1190);
#: Feetech STS3215 memory table (777).
MODEL_NUMBER = {"xl430-w250": 1060, "xl330-m288": 1200, "xl330-m077": 1190, "sts3215": 777}
ARMS = tuple(LEROBOT_MOTORS)


@pytest.mark.parametrize("arm", ARMS)
def test_servos_are_lerobots(arm: str) -> None:
    spec = load_spec(arm)
    assert spec.bus is not None
    got = {s.joint: (s.id, s.model) for s in spec.bus.servos}
    assert got == LEROBOT_MOTORS[arm]
    assert [j.name for j in spec.actuated_joints] == list(LEROBOT_MOTORS[arm])
    assert spec.bus.baudrate == 1_000_000
    assert all(s.gear_ratio == 1.0 and s.direction == 1 for s in spec.bus.servos)


def _rot(axis: tuple[float, float, float], q: float) -> np.ndarray:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    r = np.eye(4)
    r[:3, :3] = np.eye(3) + math.sin(q) * k + (1 - math.cos(q)) * k @ k
    return r


def _trans(xyz: tuple[float, float, float]) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = xyz
    return t


#: AlexanderKoch-Koch/low_cost_robot simulation/low_cost_robot_6dof/low_cost_robot.xml
#: (6218bbd8): body positions and joint axes of joints 1-5.
MJ_CHAIN = [((0, 0.07, 0), (0, 0, 1)), ((0, 0, 0.055), (1, 0, 0)), ((0, 0.0135, 0.108), (1, 0, 0)),
            ((0, 0.091, 0.0035), (1, 0, 0)), ((0, 0.04, 0), (0, -1, 0))]


@pytest.mark.parametrize("arm", ["koch_follower", "koch_leader"])
def test_koch_kinematics_match_the_designers_model(arm: str) -> None:
    model = armctl.load_arm(arm)
    rng = np.random.default_rng(3)
    for _ in range(50):
        q = rng.uniform(-1.5, 1.5, 6)
        t = np.eye(4)
        for (pos, axis), v in zip(MJ_CHAIN, q[:5], strict=True):
            t = t @ _trans(pos) @ _rot(axis, v)
        tcp = t @ _trans((0, 0.07, 0))  # the finger pads, 0.07 m ahead of the wrist roll joint
        jaw = t @ _trans((-0.009, 0.0165, 0)) @ _rot((0, 0, -1), -q[5])  # hinge about -z
        got = model.fk(q, "tcp")
        assert np.allclose(got[:3, 3], tcp[:3, 3], atol=1e-12)
        assert np.allclose(got[:3, 2], tcp[:3, 1], atol=1e-12)  # tool z along the fingers
        assert np.allclose(model.fk(q, "moving_jaw_link"), jaw, atol=1e-12)


def test_so101_leader_has_the_followers_kinematics() -> None:
    leader, follower = armctl.load_arm("so101_leader"), armctl.load_arm("so101")
    rng = np.random.default_rng(5)
    for _ in range(20):
        q = rng.uniform(leader.lower, leader.upper)
        assert np.array_equal(leader.fk(q), follower.fk(q))
    assert np.array_equal(leader.lower, follower.lower)
    assert np.array_equal(leader.upper, follower.upper)


@pytest.mark.parametrize("arm", ARMS)
def test_simulated_bus_serves_the_arm(arm: str) -> None:
    spec = load_spec(arm)
    with ArmBus.from_spec(spec) as ab:
        q = ab.read_joints()
        home = [spec.poses["home"][n] for n in ab.joint_names]
        assert np.allclose(q, home, atol=2e-3)
        for name, (sid, model) in LEROBOT_MOTORS[arm].items():
            assert ab.servo_bus.ping(sid).model_number == MODEL_NUMBER[model], name


def _read_line(proc: subprocess.Popen[str], timeout: float = 30.0) -> str:
    assert proc.stdout is not None
    ready, _, _ = select.select([proc.stdout], [], [], timeout)
    assert ready, "the simulator printed nothing"
    return proc.stdout.readline()


@pytest.mark.parametrize("arm", ARMS)
def test_armctl_sim_serves_the_arm(arm: str) -> None:
    """'armctl sim ARM' answers a vendor-SDK ping of every servo with the maker's model."""
    proc = subprocess.Popen([sys.executable, "-m", "armctl", "sim", arm],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    try:
        banner = _read_line(proc)
        assert f"for {arm} on " in banner and "servo ids 1, 2, 3, 4, 5, 6" in banner
        port = banner.split(" on ")[1].split(" at ")[0]
        spec = load_spec(arm)
        models = {sid: m for sid, m in LEROBOT_MOTORS[arm].values()}
        with ServoBus(port, spec.bus.protocol, models=models,  # type: ignore[union-attr]
                      latency_ms=8.0) as bus:
            found = {f.servo_id: f.model_number for f in bus.scan()}
        assert found == {sid: MODEL_NUMBER[m] for sid, m in models.items()}
        assert proc.stdin is not None
        proc.stdin.write("quit\n")
        proc.stdin.flush()
        assert proc.wait(timeout=10) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
