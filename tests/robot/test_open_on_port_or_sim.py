"""``Robot.open(..., port=..., sim=...)``: the bus a robot drives, chosen in Python."""

from __future__ import annotations

import math

import numpy as np
import pytest
from armctl_testpaths import CONFIGS, DATA

from armctl.errors import BusError, InputError
from armctl.robot import Robot
from armctl.robot.bus_choice import SIM_MODEL, arm_on_bus, simulated_bus_spec

pytestmark = [pytest.mark.timeout(60), pytest.mark.usefixtures("simulated_time")]

TICK = 2 * math.pi / 4096


def test_sim_opens_a_urdf_without_a_bus() -> None:
    urdf = DATA / "urdf" / "ur5e.urdf"
    goal = np.array([0.2, -0.6, 0.7, -0.3, 0.4, 0.1])
    with Robot.open(urdf, sim=True) as robot:
        assert robot.simulated
        report = robot.move_joints(goal)
        assert report.result is not None
        assert np.allclose(robot.joints(), goal, atol=3 * TICK)


def test_a_port_replaces_the_configs_port() -> None:
    with pytest.raises(BusError, match="armctl-test-no-such-port"):
        Robot.open(CONFIGS / "so101.yaml", port="/dev/armctl-test-no-such-port")


def test_the_simulated_bus_of_a_bare_arm() -> None:
    from armctl.arm import load_arm

    arm = load_arm(DATA / "urdf" / "panda.urdf")
    assert arm.spec.bus is None
    bus = simulated_bus_spec(arm.spec)
    assert bus.simulated
    assert [s.joint for s in bus.servos] == list(arm.joint_names)
    assert [s.id for s in bus.servos] == list(range(1, arm.dof + 1))
    assert {s.model for s in bus.servos} == {SIM_MODEL}
    prismatic = [s for s in bus.servos if s.gear_ratio != 1.0]
    assert prismatic and all("finger" in s.joint for s in prismatic)


def test_bad_choices_are_refused() -> None:
    from armctl.arm import load_arm

    so = load_arm("so101")
    bare = load_arm(DATA / "urdf" / "ur5e.urdf")
    assert arm_on_bus(so) is so
    assert arm_on_bus(so, sim=True) is so  # its port is 'sim' already
    with pytest.raises(InputError, match="exclude each other"):
        arm_on_bus(so, "/dev/ttyX", True)
    with pytest.raises(InputError, match="no 'bus:' section"):
        arm_on_bus(bare, "/dev/ttyX")
    with pytest.raises(InputError, match="empty port"):
        arm_on_bus(so, " ")
