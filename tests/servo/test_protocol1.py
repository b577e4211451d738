"""Dynamixel Protocol 1.0: framing against the e-Manual examples, and the driver on it."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from armctl.config.bus import Protocol
from armctl.config.schema import ArmSpec
from armctl.servo import Alarm, ArmBus, HardwareAlarm, Register, SimServoSpec, SimulatedBus
from armctl.servo.errors import CommError, EepromLockedError, ServoAlarmError, ServoRejectedError

pytestmark = pytest.mark.timeout(20)
H = bytes.fromhex


def test_protocol1_golden_packets() -> None:
    # e-Manual Protocol 1.0 examples: ping of id 1, and a 1-byte read at address 43 that
    # returns 32 (the temperature of an AX-series servo).
    import dynamixel_sdk as dxl

    sim = SimulatedBus([SimServoSpec(1, "xl430-w250")], Protocol.DYNAMIXEL1)
    with sim:
        sim.servo(1).mem[43] = 0x20
        trace = sim.start_trace()
        port = dxl.PortHandler(sim.port)
        pk = dxl.PacketHandler(1.0)
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            assert pk.ping(port, 1) == (1060, dxl.COMM_SUCCESS, 0)
            assert pk.read1ByteTxRx(port, 1, 43) == (0x20, dxl.COMM_SUCCESS, 0)
        finally:
            port.closePort()
    assert trace[0] == ("rx", H("FFFF010201FB"))
    assert trace[1] == ("tx", H("FFFF010200FC"))
    assert trace[-2:] == [("rx", H("FFFF0104022B01CC")), ("tx", H("FFFF01030020DB"))]


def _p1(spec: ArmSpec) -> ArmSpec:
    assert spec.bus is not None
    return replace(spec, bus=replace(spec.bus, protocol=Protocol.DYNAMIXEL1))


def test_arm_bus_on_protocol1(dxl_spec: ArmSpec) -> None:
    with ArmBus.from_spec(_p1(dxl_spec)) as ab:
        sim = ab.simulator
        assert sim is not None
        np.testing.assert_allclose(ab.read_joints(), [0.5, 0.2, -0.3, 0.0], atol=2e-3)
        trace = sim.start_trace()
        ab.read_state()
        assert [b[4] for d, b in trace if d == "rx"] == [2] * 4  # one READ per servo
        sim.inject(HardwareAlarm(12, Alarm.OVERHEATING))
        assert ab.read_state().errors == ((), (Alarm.OVERHEATING,), (), ())
        with pytest.raises(ServoAlarmError, match="overheating"):
            ab.read_joints()
        sim.clear_faults()
        ab.set_torque(True, ["j3"])
        with pytest.raises(EepromLockedError):
            ab.servo_bus.write(13, Register.MAX_POSITION_LIMIT, 3000)
        with pytest.raises(ServoRejectedError, match="range error"):
            ab.servo_bus.write(13, Register.GOAL_POSITION, 5000)
        with pytest.raises(CommError, match="no reboot"):
            ab.reboot(["j2"])
        assert [p.servo_id for p in ab.servo_bus.scan(range(10, 16))] == [11, 12, 13, 14]
