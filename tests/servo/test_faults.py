"""Every injected fault: recovered by a retry where one can help, else a specific error."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from armctl.config.schema import ArmSpec
from armctl.errors import BusError, ConfigError
from armctl.servo import (
    Alarm,
    ArmBus,
    CorruptedReply,
    DroppedReply,
    HardwareAlarm,
    LatencySpike,
    LateReply,
    LockupAfterOverload,
    MissingServo,
    Register,
    ServoBus,
    SimulatedBus,
    TruncatedReply,
    WrongModel,
)
from armctl.servo.errors import (
    CorruptReplyError,
    NoReplyError,
    ServoAlarmError,
    ServoMissingError,
    WrongModelError,
)

pytestmark = pytest.mark.timeout(20)
Pair = tuple[SimulatedBus, ServoBus]


@pytest.mark.parametrize("fault", [DroppedReply(2), CorruptedReply(2), TruncatedReply(2),
                                   LateReply(2, delay=0.02), LatencySpike(delay=0.02)])
@pytest.mark.parametrize("pair", ["dxl_pair", "ft_pair"])
def test_transient_fault_recovered_by_retry(pair: str, fault: object,
                                            request: pytest.FixtureRequest) -> None:
    sim, bus = request.getfixturevalue(pair)
    sim.servo(2).set_present_position(1234)
    sim.inject(fault)  # type: ignore[arg-type]
    assert bus.read(2, Register.PRESENT_POSITION) == 1234
    assert not sim.faults  # the fault was used up by the first attempt
    fb = bus.read_feedback([1, 2, 3])
    assert fb[2].position == 1234


@pytest.mark.parametrize("pair", ["dxl_pair", "ft_pair"])
def test_persistent_faults_name_the_servo(pair: str, request: pytest.FixtureRequest) -> None:
    sim, bus = request.getfixturevalue(pair)
    sim.inject(DroppedReply(3, count=None))
    with pytest.raises(NoReplyError) as info:
        bus.read(3, Register.PRESENT_POSITION)
    assert info.value.servo_id == 3 and "servo 3" in str(info.value)
    with pytest.raises(NoReplyError) as info:
        bus.read_feedback([1, 2, 3])
    assert info.value.servo_id == 3
    sim.clear_faults()
    sim.inject(CorruptedReply(2, count=None))
    with pytest.raises(CorruptReplyError) as cinfo:
        bus.read_feedback([1, 2, 3])
    assert cinfo.value.servo_id == 2
    sim.clear_faults()
    sim.inject(TruncatedReply(1, count=None, keep=4))
    with pytest.raises(CorruptReplyError) as cinfo:
        bus.read(1, Register.PRESENT_TEMPERATURE)
    assert cinfo.value.servo_id == 1
    sim.clear_faults()
    assert bus.read(1, Register.ID) == 1  # and the bus works again


def test_late_reply_is_not_taken_for_the_next_answer(dxl_pair: Pair) -> None:
    sim, bus = dxl_pair
    bus.retries = 0
    sim.inject(LateReply(1, delay=0.05))
    with pytest.raises(NoReplyError):
        bus.read(1, Register.PRESENT_TEMPERATURE)  # 1 byte, reply arrives late
    time.sleep(0.25)  # the late status packet is now waiting in the input buffer
    assert bus.read(1, Register.ID) == 1  # input was flushed before the request


def test_missing_and_wrong_model_servos_fail_open(so_spec: ArmSpec) -> None:
    ab = ArmBus.from_spec(so_spec)
    ab.open()
    sim = ab.simulator
    assert sim is not None
    sim.inject(MissingServo(4))
    with pytest.raises(NoReplyError) as info:
        ab.read_joints()
    assert info.value.servo_id == 4
    with pytest.raises(ServoMissingError) as minfo:
        ab.servo_bus.verify()
    assert minfo.value.servo_id == 4 and "does not answer" in str(minfo.value)
    sim.clear_faults()
    sim.inject(WrongModel(5, 2825))
    with pytest.raises(WrongModelError) as winfo:
        ab.servo_bus.verify()
    assert winfo.value.servo_id == 5 and "2825" in str(winfo.value)
    ab.close()


def test_hardware_alarm_flags_then_reboot_clears(dxl_spec: ArmSpec) -> None:
    with ArmBus.from_spec(dxl_spec) as ab:
        sim = ab.simulator
        assert sim is not None
        ab.set_torque(True)
        sim.inject(HardwareAlarm(12, Alarm.OVERLOAD))
        state = ab.read_state()
        assert state.errors[1] == (Alarm.OVERLOAD,) and not state.ok
        assert state.errors[0] == ()
        with pytest.raises(ServoAlarmError) as info:
            ab.read_joints()
        assert info.value.servo_id == 12 and "overload" in str(info.value)
        assert ab.torque()["j2"] is False  # the servo dropped its torque
        with pytest.raises(ServoAlarmError):
            ab.servo_bus.write(12, Register.GOAL_POSITION, 2000)
        ab.reboot(["j2"])
        assert ab.read_state().ok
        np.testing.assert_allclose(ab.read_joints(), [0.5, 0.2, -0.3, 0.0], atol=2e-3)


@pytest.mark.parametrize("alarm", [Alarm.OVERHEATING, Alarm.INPUT_VOLTAGE])
def test_feetech_alarm_bits(so_spec: ArmSpec, alarm: Alarm) -> None:
    with ArmBus.from_spec(so_spec) as ab:
        assert ab.simulator is not None
        ab.simulator.inject(HardwareAlarm(3, alarm))
        state = ab.read_state()
        assert state.errors[2] == (alarm,)
        if alarm is Alarm.OVERHEATING:
            assert state.temperature[2] > 70
        else:
            assert state.voltage[2] > 8.0


def test_lockup_after_overload_until_reboot(so_spec: ArmSpec) -> None:
    with ArmBus.from_spec(so_spec) as ab:
        assert ab.simulator is not None
        ab.simulator.inject(LockupAfterOverload(6))
        t0 = time.monotonic()
        with pytest.raises(NoReplyError) as info:
            ab.read_joints()
        assert info.value.servo_id == 6
        assert time.monotonic() - t0 < 1.0  # bounded: retries x timeout
        ab.reboot(["gripper"])  # the reboot gets no status packet; armctl re-pings
        assert ab.read_state().ok


def test_scenario_file(tmp_path: Path, so_spec: ArmSpec) -> None:
    f = tmp_path / "scenario.yaml"
    f.write_text("armctl_scenario: 1\nfaults:\n"
                 "  - {kind: dropped_reply, servo: 2, count: 1}\n"
                 "  - {kind: hardware_alarm, servo: 3, alarm: overload, at: 0.05}\n"
                 "  - {kind: latency_spike, delay: 0.001, count: 2}\n")
    with ArmBus.from_spec(so_spec) as ab:
        sim = ab.simulator
        assert sim is not None
        assert sim.load_scenario(f) == 3
        assert sim.requests > 0
        ab.read_state()  # the dropped reply is retried (read_state reports, never raises, alarms)
        deadline = time.monotonic() + 2.0
        while not ab.read_state().errors[2] and time.monotonic() < deadline:
            time.sleep(0.02)
        assert ab.read_state().errors[2] == (Alarm.OVERLOAD,)


def test_scenario_errors_name_the_line(tmp_path: Path) -> None:
    from armctl.servo.sim.scenario import load_scenario

    f = tmp_path / "bad.yaml"
    f.write_text("faults:\n  - {kind: dropped_reply, servo: 2}\n"
                 "  - {kind: dropped_rep, servo: 1}\n")
    with pytest.raises(ConfigError) as info:
        load_scenario(f)
    assert ":3:" in str(info.value) and "dropped_reply" in str(info.value)


def test_errors_are_bus_errors() -> None:
    for cls in (NoReplyError, CorruptReplyError, ServoAlarmError, ServoMissingError,
                WrongModelError):
        assert issubclass(cls, BusError)
        assert cls("x", "p").exit_code == 4
