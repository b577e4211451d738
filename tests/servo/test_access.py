"""Control-table rules on the simulated servos, seen through the drivers' errors."""

from __future__ import annotations

import itertools
import time

import pytest

from armctl.config.bus import Protocol
from armctl.errors import InputError
from armctl.servo import Register, ServoBus, SimServoSpec, SimulatedBus
from armctl.servo.errors import (
    AccessError,
    EepromLockedError,
    NoReplyError,
    PortError,
    ServoRejectedError,
)
from armctl.servo_tables import TABLES, Family, table_for

pytestmark = pytest.mark.timeout(20)
Pair = tuple[SimulatedBus, ServoBus]


def test_tables_key_addresses_and_model_numbers() -> None:
    # Reference "facts": Dynamixel X and STS3215 addresses and model numbers.
    x = table_for("XM430-W350")
    assert [x.spec(r).address for r in (Register.TORQUE_ENABLE, Register.GOAL_POSITION,
                                        Register.PRESENT_POSITION, Register.HARDWARE_ERROR,
                                        Register.HOMING_OFFSET)] == [64, 116, 132, 70, 20]
    assert {m: t.model_number for m, t in TABLES.items()} == {
        "sts3215": 777, "xl330-m077": 1190, "xl330-m288": 1200, "xl430-w250": 1060,
        "xm430-w350": 1020, "xm540-w270": 1120}
    sts = table_for("sts3215")
    assert [sts.spec(r).address for r in (Register.ID, Register.HOMING_OFFSET,
                                          Register.TORQUE_ENABLE, Register.GOAL_POSITION,
                                          Register.LOCK, Register.PRESENT_POSITION,
                                          Register.PRESENT_LOAD)] == [5, 31, 40, 42, 55, 56, 60]
    assert sts.spec(Register.PRESENT_LOAD).sign_bit == 10
    for t in TABLES.values():
        regs = sorted(t.registers.values(), key=lambda s: s.address)
        for a, b in itertools.pairwise(regs):
            assert a.address + a.size <= b.address, (t.model, a.register, b.register)
        assert t.family is (Family.FEETECH if t.model == "sts3215" else Family.DYNAMIXEL)


@pytest.mark.parametrize("pair", ["dxl_pair", "ft_pair"])
def test_pinged_model_matches_table(pair: str, request: pytest.FixtureRequest) -> None:
    _, bus = request.getfixturevalue(pair)
    found = bus.verify()
    assert [f.model for f in found] == [bus.tables[f.servo_id].model for f in found]


def test_dynamixel_eeprom_locked_while_torque_on(dxl_pair: Pair) -> None:
    sim, bus = dxl_pair
    bus.set_torque([1], True)
    with pytest.raises(EepromLockedError) as info:
        bus.write(1, Register.MAX_POSITION_LIMIT, 3000)
    assert info.value.servo_id == 1 and info.value.register == "max_position_limit"
    assert "access error" in str(info.value) and "torque off" in str(info.value)
    bus.set_torque([1], False)
    bus.write(1, Register.MAX_POSITION_LIMIT, 3000)
    assert sim.servo(1).get(Register.MAX_POSITION_LIMIT) == 3000


def test_feetech_eeprom_locked(ft_pair: Pair) -> None:
    sim, bus = ft_pair
    with pytest.raises(EepromLockedError) as info:
        bus.write(2, Register.MAX_POSITION_LIMIT, 3000)  # lock = 1 (default)
    assert info.value.servo_id == 2 and "reads back 4095" in str(info.value)
    bus.write(2, Register.LOCK, 0)
    bus.write(2, Register.MAX_POSITION_LIMIT, 3000)
    assert sim.servo(2).get(Register.MAX_POSITION_LIMIT) == 3000


def test_range_checked_before_sending_and_by_the_servo(dxl_pair: Pair) -> None:
    sim, bus = dxl_pair
    trace = sim.start_trace()
    with pytest.raises(InputError):
        bus.write(1, Register.OPERATING_MODE, 40)
    with pytest.raises(AccessError):
        bus.write(1, Register.PRESENT_POSITION, 5)
    assert trace == []  # nothing was sent
    with pytest.raises(ServoRejectedError) as info:
        bus.write(1, Register.GOAL_POSITION, 5000)  # outside Max Position Limit: error 6
    assert "data limit error" in str(info.value)
    with pytest.raises(ServoRejectedError, match="data range error"):
        bus.write(2, Register.OPERATING_MODE, 0)  # XL430 has no current mode


def test_status_return_level_and_broadcast_silence(dxl_pair: Pair) -> None:
    sim, bus = dxl_pair
    # Set on the servo itself: a write of it whose reply came late would be retried, and the
    # retry (at level 1 already) gets no reply at all.
    sim.servo(3).set(Register.STATUS_RETURN_LEVEL, 1)
    assert bus.read(3, Register.STATUS_RETURN_LEVEL) == 1
    trace = sim.start_trace()
    bus.retries = 0
    with pytest.raises(NoReplyError):
        bus.write(3, Register.LED, 1)  # SRL 1: no status for a write...
    assert sim.servo(3).get(Register.LED) == 1  # ...but it was done
    assert bus.read(3, Register.LED) == 1  # reads still answer
    assert [d for d, _ in trace].count("tx") == 1


def test_wrong_baud_rate_is_silence() -> None:
    sim = SimulatedBus([SimServoSpec(1, "xl430-w250")], Protocol.DYNAMIXEL, 1_000_000)
    with sim, ServoBus(sim.port, Protocol.DYNAMIXEL, 57600, latency_ms=4.0, retries=0) as bus:
        with pytest.raises(NoReplyError):
            bus.ping(1)
    with sim, ServoBus(sim.port, Protocol.DYNAMIXEL, 1_000_000, latency_ms=8.0) as bus:
        assert bus.ping(1).model == "xl430-w250"


def test_port_errors_are_clear() -> None:
    with pytest.raises(PortError, match="no such port") as info:
        ServoBus("/dev/does-not-exist-armctl", Protocol.FEETECH).open()
    assert "armctl ports" in str(info.value)
    sim = SimulatedBus([SimServoSpec(1, "sts3215")], Protocol.FEETECH)
    with sim, ServoBus(sim.port, Protocol.FEETECH):
        with pytest.raises(PortError, match="busy"):
            ServoBus(sim.port, Protocol.FEETECH).open()


def test_wire_timing_paces_replies() -> None:
    sim = SimulatedBus([SimServoSpec(i, "xl330-m288") for i in (1, 2, 3)],
                       Protocol.DYNAMIXEL, 57600, wire_timing=True)
    with sim, ServoBus(sim.port, Protocol.DYNAMIXEL, 57600, models={1: "xl330-m288",
                       2: "xl330-m288", 3: "xl330-m288"}, latency_ms=8.0) as bus:
        bus.read_feedback([1, 2, 3])
        t0 = time.perf_counter()
        bus.read_feedback([1, 2, 3])
        took = time.perf_counter() - t0
    # 14+6 instruction bytes + 3 x (11+21) reply bytes = 116 bytes x 10 bits at 57600 baud
    assert took >= 116 * 10 / 57600 * 0.95


def test_id_change_takes_effect(ft_pair: Pair) -> None:
    sim, bus = ft_pair
    bus.write(3, Register.LOCK, 0)
    bus.write(3, Register.ID, 9)
    assert bus.ping(9).model == "sts3215"
    assert sim.servo(9).id == 9


def test_return_delay_is_honoured_with_wire_timing() -> None:
    ids = (1, 2, 3)
    sim = SimulatedBus([SimServoSpec(i, "xl330-m288") for i in ids], Protocol.DYNAMIXEL,
                       1_000_000, wire_timing=True)
    with sim, ServoBus(sim.port, Protocol.DYNAMIXEL, models=dict.fromkeys(ids, "xl330-m288"),
                       latency_ms=8.0) as bus:
        for i in ids:
            bus.write(i, Register.RETURN_DELAY, 250)  # 500 us each (the factory default)
        bus.read_positions(list(ids))
        t0 = time.perf_counter()
        bus.read_positions(list(ids))
        took = time.perf_counter() - t0
    assert took >= 3 * 500e-6  # three replies, each after its return delay


def test_feetech_locked_id_change_is_detected(ft_pair: Pair) -> None:
    _, bus = ft_pair
    bus.retries = 0
    with pytest.raises(EepromLockedError, match="reads back 2"):
        bus.write(2, Register.ID, 8)  # lock = 1: the servo keeps id 2
    assert bus.ping(2).model == "sts3215" and 2 in bus.tables


def test_port_error_messages_name_the_fix() -> None:
    import errno

    from armctl.servo.errors import port_error

    denied = port_error("/dev/ttyUSB0", OSError(errno.EACCES, "Permission denied"))
    assert "permission denied" in str(denied) and "dialout" in str(denied)
    busy = port_error("/dev/ttyUSB0", OSError(errno.EBUSY, "Device or resource busy"))
    assert "busy" in str(busy) and busy.port == "/dev/ttyUSB0"
