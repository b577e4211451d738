"""Joint <-> tick mapping: round trips, limits refused before sending, wrap, multi-turn."""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
import pytest

from armctl.config.bus import ServoSpec
from armctl.config.schema import ArmSpec, JointType
from armctl.errors import ConfigError, InputError, JointLimitError
from armctl.servo import ArmBus, JointMap, JointMapping

pytestmark = pytest.mark.timeout(20)
TICK = 2 * math.pi / 4096


def test_round_trip_random(dxl_spec: ArmSpec, so_spec: ArmSpec) -> None:
    rng = np.random.default_rng(7)
    for spec in (dxl_spec, so_spec):
        m = JointMapping.from_spec(spec)
        for _ in range(200):
            q = rng.uniform(m.lower, m.upper)
            ticks = m.goal_ticks(q)
            back = m.from_ticks(ticks)
            res = np.array([TICK / (j.gear_ratio) for j in m.joints])
            assert np.all(np.abs(back - q) <= 0.5 * res + 1e-12)


def test_formula_direction_offset_gear(so_spec: ArmSpec) -> None:
    m = JointMapping.from_spec(so_spec)
    lift, elbow, grip = m.joint("shoulder_lift"), m.joint("elbow_flex"), m.joint("gripper")
    assert lift.to_ticks(0.0) == 2048 and lift.to_ticks(TICK) == 2047  # direction -1
    assert elbow.to_ticks(0.1) == 2048  # offset: joint value at the centre tick
    assert grip.to_ticks(0.01) == pytest.approx(2048 + 0.01 * 100 * 4096 / (2 * math.pi))


def test_limits_refused_and_nothing_sent(so_spec: ArmSpec) -> None:
    with ArmBus.from_spec(so_spec) as ab:
        sim = ab.simulator
        assert sim is not None
        trace = sim.start_trace()
        q = np.zeros(6)
        q[3] = 1.7  # wrist_flex upper limit 1.6
        with pytest.raises(JointLimitError) as info:
            ab.write_joints(q)
        assert info.value.joint == "wrist_flex"
        q[3] = math.nan
        with pytest.raises(InputError):
            ab.write_joints(q)
        with pytest.raises(InputError):
            ab.write_joints(np.zeros(5))
        time.sleep(0.02)
        assert trace == []


def test_write_then_read_in_joint_units(dxl_spec: ArmSpec) -> None:
    with ArmBus.from_spec(dxl_spec) as ab:
        assert ab.joint_names == ("j1", "j2", "j3", "j4")
        np.testing.assert_allclose(ab.read_joints(), [0.5, 0.2, -0.3, 0.0], atol=TICK)
        ab.set_torque(True)
        goal = np.array([4.0, -1.0, 1.2, -0.5])  # j1 beyond one turn: extended position mode
        ab.write_joints(goal)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline:
            state = ab.read_state()
            if np.allclose(state.position, goal, atol=2 * TICK) and not np.any(state.velocity):
                break
            time.sleep(0.05)
        np.testing.assert_allclose(ab.read_joints(), goal, atol=2 * TICK)
        assert ab.mapping.joint("j1").multi_turn
        assert ab.servo_bus.read(11, "operating_mode") == 4
        assert state.ok


def test_velocity_and_load_while_moving(so_spec: ArmSpec) -> None:
    with ArmBus.from_spec(so_spec) as ab:
        ab.set_torque(True)
        ab.servo_bus.write(1, "profile_velocity", 500)  # Goal Speed [tick/s]: ~2 s to the goal
        ab.write_joints(np.array([1.5, 0, 0, 0, 0, 0]))
        time.sleep(0.15)
        s = ab.read_state()
        assert s.velocity[0] > 0.5  # rad/s toward the goal
        assert s.load[0] != 0.0 and abs(s.load[0]) <= 1.0
        assert 0.0 < s.position[0] < 1.5


def test_hand_guiding_needs_torque_off(so_spec: ArmSpec) -> None:
    with ArmBus.from_spec(so_spec) as ab:
        sim = ab.simulator
        assert sim is not None
        sim.set_joint("elbow_flex", 0.7)
        sim.set_joint(1, 1024)  # by id: ticks
        q = ab.read_joints()
        assert q[2] == pytest.approx(0.7, abs=TICK)
        assert q[0] == pytest.approx(-1024 * TICK, abs=1e-9)
        assert sim.joint_positions()["elbow_flex"] == pytest.approx(0.7, abs=TICK)
        ab.set_torque(True, ["elbow_flex"])
        with pytest.raises(InputError, match="torque on"):
            sim.set_joint("elbow_flex", 0.2)


def _joint(lower: float, upper: float, zero: float = 2048.0) -> JointMap:
    return JointMap("j", 1, "sts3215", JointType.REVOLUTE, zero, 0.0, 1, 1.0, lower, upper)


def test_unwrap_on_read_and_wrap_inside_travel_refused() -> None:
    j = _joint(-1.0, 1.0, zero=3900.0)  # travel 3248..4552 ticks crosses 4095 -> 0
    assert j.wrap_inside()
    assert j.to_joint(100) == pytest.approx((4196 - 3900) * TICK)  # read past the wrap
    assert j.goal_ticks(0.1) == 3900 + round(0.1 / TICK)
    with pytest.raises(ConfigError, match="encoder wrap"):
        j.goal_ticks(0.5)
    assert not _joint(-1.0, 1.0).wrap_inside()


def test_feetech_joint_beyond_one_turn_is_a_config_error(so_spec: ArmSpec) -> None:
    joints = tuple(replace(j, limits=replace(j.limits, lower=-4.0, upper=4.0))
                   if j.name == "wrist_roll" else j for j in so_spec.joints)
    with pytest.raises(ConfigError, match="servo turns"):
        JointMapping.from_spec(replace(so_spec, joints=joints))


def test_model_protocol_mismatch(so_spec: ArmSpec) -> None:
    assert so_spec.bus is not None
    servos = (ServoSpec("shoulder_pan", 1, "xl330-m288"), *so_spec.bus.servos[1:])
    bad = replace(so_spec, bus=replace(so_spec.bus, servos=servos))
    with pytest.raises(ConfigError, match="does not speak feetech"):
        ArmBus.from_spec(bad)


def _with_offset(spec: ArmSpec, joint: str, offset: float) -> ArmSpec:
    assert spec.bus is not None
    servos = tuple(replace(s, offset=offset) if s.joint == joint else s
                   for s in spec.bus.servos)
    return replace(spec, bus=replace(spec.bus, servos=servos))


@pytest.mark.parametrize(("which", "joint", "offset", "goal"), [
    ("dxl_spec", "j2", 2.0, -1.75),   # ticks 2178..4525 without a homing offset
    ("so_spec", "shoulder_pan", 2.5, -1.85),  # ticks -820..1657
])
def test_wrap_moved_out_of_travel_by_homing_offset(which: str, joint: str, offset: float,
                                                  goal: float,
                                                  request: pytest.FixtureRequest) -> None:
    spec = _with_offset(request.getfixturevalue(which), joint, offset)
    m = JointMapping.from_spec(spec)
    j = m.joint(joint)
    assert j.homing_offset != 0 and not j.wrap_inside()
    lo, hi = sorted((j.to_ticks(j.lower), j.to_ticks(j.upper)))
    assert 0 <= lo and hi <= 4095
    with ArmBus.from_spec(spec) as ab:
        assert ab.servo_bus.read(j.servo_id, "homing_offset") == j.homing_offset
        i = ab.joint_names.index(joint)
        q = ab.read_joints()
        ab.set_torque(True)
        q[i] = goal
        ab.servo_bus.write(j.servo_id, "profile_velocity", 0)
        ab.write_joints(q)  # no ConfigError: the goal's ticks are inside 0..4095
        deadline = time.monotonic() + 5
        while abs(ab.read_joints()[i] - goal) > 2 * TICK and time.monotonic() < deadline:
            time.sleep(0.05)
        assert ab.read_joints()[i] == pytest.approx(goal, abs=2 * TICK)
