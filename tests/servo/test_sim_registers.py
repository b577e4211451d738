"""Registers with behaviour on the simulated servos: Indirect Address/Data, Realtime Tick, Bus
Watchdog, Shutdown and Hardware Error Status, goal limits, driven through the vendors' SDKs.

The expected behaviour is the ROBOTIS e-Manual's (X series control table: "Indirect Address,
Indirect Data" with its LED and Goal Position examples, "Realtime Tick", "Bus Watchdog" with its
example, "Shutdown", "Hardware Error Status", "Goal Position" / "Goal Velocity" ranges; Protocol
2.0 "Status Packet" for the Alert bit) and, for the Feetech angle limits, the STS3215's as
observed on the hardware (the goal register keeps the value written; the shaft stops at the
limit).
The servos run on a simulated clock, so the time-outs are exact.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from armctl.clock import SimulatedClock
from armctl.config.bus import Protocol
from armctl.servo import Alarm, HardwareAlarm, SimServoSpec, SimulatedBus

pytestmark = pytest.mark.timeout(30)

# X-series addresses (e-Manual control tables of the XM430-W350 and XL430-W250)
TORQUE, LED, GOAL_POSITION, PRESENT_POSITION = 64, 65, 116, 132
BUS_WATCHDOG, REALTIME_TICK, HARDWARE_ERROR, PROFILE_VELOCITY = 98, 120, 70, 112
INDIRECT_ADDRESS_1, INDIRECT_DATA_1 = 168, 224
ACCESS_ERROR, RANGE_ERROR = 0x07, 0x04


@pytest.fixture
def bus() -> Iterator[tuple[SimulatedBus, SimulatedClock, Any, Any, Any]]:
    import dynamixel_sdk as dxl

    clock = SimulatedClock()
    sim = SimulatedBus([SimServoSpec(1, "xm430-w350", 1000), SimServoSpec(2, "xl430-w250", 2000)],
                       clock=clock)
    with sim:
        port = dxl.PortHandler(sim.port)
        pk = dxl.PacketHandler(2.0)
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            yield sim, clock, dxl, port, pk
        finally:
            port.closePort()


def _map(pk: Any, port: Any, dxl: Any, servo_id: int, addresses: list[int]) -> None:
    """Point Indirect Address 1, 2, ... at ``addresses``."""
    for k, target in enumerate(addresses):
        assert pk.write2ByteTxRx(port, servo_id, INDIRECT_ADDRESS_1 + 2 * k, target) == \
            (dxl.COMM_SUCCESS, 0)


# ---- Indirect Address / Data --------------------------------------------------------------------
def test_indirect_data_reads_and_writes_the_mapped_bytes(bus: Any) -> None:
    _sim, clock, dxl, port, pk = bus
    # e-Manual examples: LED(65) at Indirect Data 1, the four bytes of Goal Position at 2 ~ 5;
    # and Present Position's four bytes after them
    _map(pk, port, dxl, 1, [LED, *range(GOAL_POSITION, GOAL_POSITION + 4),
                             *range(PRESENT_POSITION, PRESENT_POSITION + 4)])
    assert pk.write1ByteTxRx(port, 1, INDIRECT_DATA_1, 1) == (dxl.COMM_SUCCESS, 0)
    assert pk.read1ByteTxRx(port, 1, LED)[0] == 1
    assert pk.write1ByteTxRx(port, 1, INDIRECT_DATA_1, 0) == (dxl.COMM_SUCCESS, 0)
    assert pk.read1ByteTxRx(port, 1, LED)[0] == 0
    assert pk.write1ByteTxRx(port, 1, TORQUE, 1) == (dxl.COMM_SUCCESS, 0)
    assert pk.write4ByteTxRx(port, 1, INDIRECT_DATA_1 + 1, 1024) == (dxl.COMM_SUCCESS, 0)
    assert pk.read4ByteTxRx(port, 1, GOAL_POSITION)[0] == 1024
    clock.advance(3.0)
    data, result, error = pk.readTxRx(port, 1, INDIRECT_DATA_1, 9)
    assert (result, error) == (dxl.COMM_SUCCESS, 0)
    assert data[0] == 0
    assert int.from_bytes(bytes(data[1:5]), "little") == 1024
    assert int.from_bytes(bytes(data[5:9]), "little") == pk.read4ByteTxRx(port, 1,
                                                                          PRESENT_POSITION)[0]
    assert abs(pk.read4ByteTxRx(port, 1, PRESENT_POSITION)[0] - 1024) <= 2


def test_indirect_data_inherits_the_access_of_its_item(bus: Any) -> None:
    _sim, _clock, dxl, port, pk = bus
    _map(pk, port, dxl, 1, [PRESENT_POSITION])  # read-only
    assert pk.write1ByteTxRx(port, 1, INDIRECT_DATA_1, 5) == (dxl.COMM_SUCCESS, ACCESS_ERROR)
    # and the range of its item: LED takes 0 or 1
    _map(pk, port, dxl, 1, [LED])
    assert pk.write1ByteTxRx(port, 1, INDIRECT_DATA_1, 7) == (dxl.COMM_SUCCESS, RANGE_ERROR)
    assert pk.read1ByteTxRx(port, 1, LED)[0] == 0


def test_indirect_address_cannot_name_the_eeprom_area(bus: Any) -> None:
    _sim, _clock, dxl, port, pk = bus
    assert pk.write2ByteTxRx(port, 1, INDIRECT_ADDRESS_1, 7) == (dxl.COMM_SUCCESS, RANGE_ERROR)


def test_sync_read_of_indirect_data(bus: Any) -> None:
    _sim, _clock, dxl, port, pk = bus
    for i in (1, 2):
        _map(pk, port, dxl, i, [*range(PRESENT_POSITION, PRESENT_POSITION + 4), LED])
    assert pk.write1ByteTxRx(port, 2, LED, 1) == (dxl.COMM_SUCCESS, 0)
    group = dxl.GroupSyncRead(port, pk, INDIRECT_DATA_1, 5)
    assert group.addParam(1) and group.addParam(2)
    assert group.txRxPacket() == dxl.COMM_SUCCESS
    assert [group.getData(i, INDIRECT_DATA_1, 4) for i in (1, 2)] == [1000, 2000]
    assert [group.getData(i, INDIRECT_DATA_1 + 4, 1) for i in (1, 2)] == [0, 1]
    assert group.fastSyncRead() == dxl.COMM_SUCCESS
    assert [group.getData(i, INDIRECT_DATA_1, 4) for i in (1, 2)] == [1000, 2000]


# ---- Realtime Tick ------------------------------------------------------------------------------
def test_realtime_tick_counts_milliseconds_and_wraps(bus: Any) -> None:
    _sim, clock, dxl, port, pk = bus
    start = pk.read2ByteTxRx(port, 1, REALTIME_TICK)[0]
    clock.advance(1.234)
    assert pk.read2ByteTxRx(port, 1, REALTIME_TICK)[0] == (start + 1234) % 32768
    clock.advance(40.0)  # past 32 767 ms: it wraps to 0
    assert pk.read2ByteTxRx(port, 1, REALTIME_TICK)[0] == (start + 41234) % 32768
    assert pk.reboot(port, 1) == (dxl.COMM_SUCCESS, 0)
    clock.advance(0.5)
    assert pk.read2ByteTxRx(port, 1, REALTIME_TICK)[0] == 500  # counts from the reboot


# ---- Bus Watchdog -------------------------------------------------------------------------------
def test_bus_watchdog_stops_the_servo_and_refuses_goals_until_cleared(bus: Any) -> None:
    sim, clock, dxl, port, pk = bus
    assert pk.write4ByteTxRx(port, 1, PROFILE_VELOCITY, 20) == (dxl.COMM_SUCCESS, 0)  # slow
    assert pk.write1ByteTxRx(port, 1, TORQUE, 1) == (dxl.COMM_SUCCESS, 0)
    assert pk.write1ByteTxRx(port, 1, BUS_WATCHDOG, 5) == (dxl.COMM_SUCCESS, 0)  # 100 ms
    assert pk.write4ByteTxRx(port, 1, GOAL_POSITION, 3000) == (dxl.COMM_SUCCESS, 0)
    for _ in range(5):  # talking every 80 ms keeps it alive
        clock.advance(0.08)
        assert pk.read1ByteTxRx(port, 1, BUS_WATCHDOG)[0] == 5
    moving = pk.read4ByteTxRx(port, 1, PRESENT_POSITION)[0]
    assert 1000 < moving < 3000
    clock.advance(0.5)  # silence: it times out 100 ms after the last packet and stops there
    assert pk.read1ByteTxRx(port, 1, BUS_WATCHDOG)[0] == 0xFF  # -1, Bus Watchdog Error
    stopped = pk.read4ByteTxRx(port, 1, PRESENT_POSITION)[0]
    assert moving < stopped < 3000
    clock.advance(1.0)
    assert pk.read4ByteTxRx(port, 1, PRESENT_POSITION)[0] == stopped
    assert pk.read1ByteTxRx(port, 1, TORQUE)[0] == 1  # torque stays on
    # the goal values are read-only: Data Range Error (e-Manual Bus Watchdog example)
    assert pk.write4ByteTxRx(port, 1, GOAL_POSITION, 3000) == (dxl.COMM_SUCCESS, RANGE_ERROR)
    assert pk.write1ByteTxRx(port, 1, BUS_WATCHDOG, 0) == (dxl.COMM_SUCCESS, 0)  # cleared
    assert pk.write4ByteTxRx(port, 1, GOAL_POSITION, 3000) == (dxl.COMM_SUCCESS, 0)
    for _ in range(10):  # 20 x 0.229 rev/min is about 313 tick/s
        clock.advance(1.0)
        assert sim.positions  # the dynamics catch up (a long step would delay the reply)
    assert abs(pk.read4ByteTxRx(port, 1, PRESENT_POSITION)[0] - 3000) <= 2


def _wait(sim: SimulatedBus, clock: SimulatedClock, seconds: float) -> None:
    """Let simulated time pass without a packet (the dynamics catch up in small steps)."""
    for _ in range(round(seconds / 0.25)):
        clock.advance(0.25)
        assert sim.positions


def test_bus_watchdog_manual_example_in_velocity_mode(bus: Any) -> None:
    # e-Manual "Bus Watchdog (98) Example", step by step
    sim, clock, dxl, port, pk = bus
    velocity = 128  # Present Velocity
    assert pk.write1ByteTxRx(port, 1, 11, 1) == (dxl.COMM_SUCCESS, 0)  # 1. velocity mode,
    assert pk.write1ByteTxRx(port, 1, TORQUE, 1) == (dxl.COMM_SUCCESS, 0)  # torque on
    assert pk.write4ByteTxRx(port, 1, 104, 50) == (dxl.COMM_SUCCESS, 0)  # 2. Goal Velocity 50
    assert pk.write1ByteTxRx(port, 1, BUS_WATCHDOG, 100) == (dxl.COMM_SUCCESS, 0)  # 3. 2 s
    _wait(sim, clock, 1.5)
    assert pk.read4ByteTxRx(port, 1, velocity)[0] == 50  # a packet within 2 s: still turning
    _wait(sim, clock, 3.0)  # 4. no packet for 2 s: it stops
    assert pk.read4ByteTxRx(port, 1, velocity)[0] == 0
    assert pk.read1ByteTxRx(port, 1, BUS_WATCHDOG)[0] == 0xFF  # 5. -1
    stopped = pk.read4ByteTxRx(port, 1, PRESENT_POSITION)[0]
    _wait(sim, clock, 1.0)
    assert pk.read4ByteTxRx(port, 1, PRESENT_POSITION)[0] == stopped
    assert pk.write4ByteTxRx(port, 1, 104, 150) == (dxl.COMM_SUCCESS, RANGE_ERROR)  # 6.
    assert pk.write1ByteTxRx(port, 1, BUS_WATCHDOG, 0) == (dxl.COMM_SUCCESS, 0)  # 7. cleared
    assert pk.write4ByteTxRx(port, 1, 104, 150) == (dxl.COMM_SUCCESS, 0)  # 8. turns again
    _wait(sim, clock, 1.0)
    assert pk.read4ByteTxRx(port, 1, velocity)[0] == 150


def test_bus_watchdog_is_idle_with_torque_off(bus: Any) -> None:
    _sim, clock, dxl, port, pk = bus
    assert pk.write1ByteTxRx(port, 2, BUS_WATCHDOG, 1) == (dxl.COMM_SUCCESS, 0)  # 20 ms
    clock.advance(1.0)
    assert pk.read1ByteTxRx(port, 2, BUS_WATCHDOG)[0] == 1


# ---- Shutdown and Hardware Error Status ------------------------------------------------------
def test_shutdown_bits_decide_which_alarm_cuts_the_torque(bus: Any) -> None:
    sim, _clock, dxl, port, pk = bus
    for i in (1, 2):
        assert pk.write1ByteTxRx(port, i, TORQUE, 1) == (dxl.COMM_SUCCESS, 0)
    assert pk.read1ByteTxRx(port, 1, 63)[0] == 52  # Shutdown default: overheat, shock, overload
    assert pk.write1ByteTxRx(port, 2, TORQUE, 0) == (dxl.COMM_SUCCESS, 0)
    assert pk.write1ByteTxRx(port, 2, 63, 52 | 0x01) == (dxl.COMM_SUCCESS, 0)  # + input voltage
    assert pk.write1ByteTxRx(port, 2, TORQUE, 1) == (dxl.COMM_SUCCESS, 0)
    for i in (1, 2):
        sim.inject(HardwareAlarm(i, Alarm.INPUT_VOLTAGE))
    # the alarm is reported on both (Alert bit 0x80 of the status error field) ...
    assert pk.read1ByteTxRx(port, 1, HARDWARE_ERROR) == (0x01, dxl.COMM_SUCCESS, 0x80)
    assert pk.read1ByteTxRx(port, 2, HARDWARE_ERROR) == (0x01, dxl.COMM_SUCCESS, 0x80)
    # ... but only the servo whose Shutdown names it drops its torque, and keeps it off
    assert pk.read1ByteTxRx(port, 1, TORQUE)[0] == 1
    assert pk.read1ByteTxRx(port, 2, TORQUE)[0] == 0
    assert pk.write1ByteTxRx(port, 2, TORQUE, 1)[0] == dxl.COMM_SUCCESS
    assert pk.read1ByteTxRx(port, 2, TORQUE)[0] == 0
    assert pk.reboot(port, 2) == (dxl.COMM_SUCCESS, 0x80)  # answered before the reboot
    assert pk.read1ByteTxRx(port, 2, HARDWARE_ERROR) == (0, dxl.COMM_SUCCESS, 0)
    assert pk.write1ByteTxRx(port, 2, TORQUE, 1) == (dxl.COMM_SUCCESS, 0)
    assert pk.read1ByteTxRx(port, 2, TORQUE)[0] == 1


# ---- Writes of several items, and goal limits ----------------------------------------------------
def test_write_spanning_several_items(bus: Any) -> None:
    _sim, _clock, dxl, port, pk = bus
    # Profile Acceleration (108, 4 bytes) and Profile Velocity (112, 4 bytes) in one Write
    span = [*(30).to_bytes(4, "little"), *(40).to_bytes(4, "little")]
    assert pk.writeTxRx(port, 1, 108, 8, span) == (dxl.COMM_SUCCESS, 0)
    assert (pk.read4ByteTxRx(port, 1, 108)[0], pk.read4ByteTxRx(port, 1, 112)[0]) == (30, 40)
    # a span ending inside an item: Data Length Error; one item out of range: nothing written
    assert pk.writeTxRx(port, 1, 108, 6, span[:6]) == (dxl.COMM_SUCCESS, 0x05)
    bad = [*(31).to_bytes(4, "little"), *(40000).to_bytes(4, "little")]
    assert pk.writeTxRx(port, 1, 108, 8, bad) == (dxl.COMM_SUCCESS, RANGE_ERROR)
    assert pk.read4ByteTxRx(port, 1, 108)[0] == 30
    # a span from an address no item has (28 ~ 30 are unused; Temperature Limit is 31): Access
    # Error
    assert pk.writeTxRx(port, 1, 30, 2, [0, 70]) == (dxl.COMM_SUCCESS, ACCESS_ERROR)


def test_goal_values_beyond_their_limits_are_limit_errors(bus: Any) -> None:
    _sim, _clock, dxl, port, pk = bus
    LIMIT_ERROR = 0x06
    # Position Control Mode: Goal Position within Min/Max Position Limit (0 ~ 4095)
    assert pk.write4ByteTxRx(port, 1, GOAL_POSITION, 4096) == (dxl.COMM_SUCCESS, LIMIT_ERROR)
    assert pk.write4ByteTxRx(port, 1, 48, 3000) == (dxl.COMM_SUCCESS, 0)  # Max Position Limit
    assert pk.write4ByteTxRx(port, 1, GOAL_POSITION, 3001) == (dxl.COMM_SUCCESS, LIMIT_ERROR)
    assert pk.write4ByteTxRx(port, 1, GOAL_POSITION, 3000) == (dxl.COMM_SUCCESS, 0)
    # Extended Position Control Mode: the limits do not apply
    assert pk.write1ByteTxRx(port, 1, 11, 4) == (dxl.COMM_SUCCESS, 0)
    assert pk.write4ByteTxRx(port, 1, GOAL_POSITION, 9000) == (dxl.COMM_SUCCESS, 0)
    # Goal Velocity within +- Velocity Limit (44; XM430-W350 default 200)
    assert pk.write4ByteTxRx(port, 1, 104, 201) == (dxl.COMM_SUCCESS, LIMIT_ERROR)
    assert pk.write4ByteTxRx(port, 1, 104, (-201) & 0xFFFFFFFF) == \
        (dxl.COMM_SUCCESS, LIMIT_ERROR)
    assert pk.write4ByteTxRx(port, 1, 104, 200) == (dxl.COMM_SUCCESS, 0)


# ---- Feetech angle limits ------------------------------------------------------------------------
def test_feetech_goal_beyond_the_angle_limit_is_stored_and_the_shaft_stops_at_the_limit() -> None:
    import scservo_sdk as scs

    clock = SimulatedClock()
    sim = SimulatedBus([SimServoSpec(1, "sts3215", 1000)], Protocol.FEETECH, clock=clock)
    with sim:
        port = scs.PortHandler(sim.port)
        pk = scs.PacketHandler(0)
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            assert pk.write1ByteTxRx(port, 1, 55, 0) == (scs.COMM_SUCCESS, 0)  # unlock EEPROM
            assert pk.write2ByteTxRx(port, 1, 11, 3000) == (scs.COMM_SUCCESS, 0)  # max angle
            assert pk.write1ByteTxRx(port, 1, 40, 1) == (scs.COMM_SUCCESS, 0)  # torque on
            assert pk.write2ByteTxRx(port, 1, 42, 3500) == (scs.COMM_SUCCESS, 0)
            for _ in range(12):
                clock.advance(0.25)
                assert sim.positions
            assert pk.read2ByteTxRx(port, 1, 42)[0] == 3500  # as written
            assert abs(pk.read2ByteTxRx(port, 1, 56)[0] - 3000) <= 2  # held at the limit
        finally:
            port.closePort()
