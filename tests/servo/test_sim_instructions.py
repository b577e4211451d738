"""Every instruction of both protocols on the simulated bus, driven through the vendors' SDKs.

The expected behaviour is the makers': ROBOTIS e-Manual "Protocol 2.0" (packet examples, Reg
Write / Action and Registered Instruction, Factory Reset options, Reboot, Control Table Backup,
Fast Bulk Read, Secondary ID) and "Protocol 1.0" (Reset), the X-series control table pages, and
Feetech's SCS/STS protocol as ``scservo_sdk`` speaks it (Reg Write / Action, recovery 0x06,
Torque Enable 128). Where an SDK has a flow for an instruction the test uses it; otherwise the
e-Manual's packet bytes go out raw.
"""

from __future__ import annotations

import select
import time
from collections.abc import Iterator
from typing import Any

import pytest
import serial

from armctl.config.bus import Protocol
from armctl.servo import SimServoSpec, SimulatedBus
from armctl.servo_tables import Register

pytestmark = pytest.mark.timeout(30)
H = bytes.fromhex


def _raw_exchange(port: str, packet: bytes, wait: float = 0.05) -> bytes:
    with serial.Serial(port, 1_000_000, timeout=0) as ser:
        ser.write(packet)
        out = b""
        end = time.monotonic() + wait
        while time.monotonic() < end:
            select.select([ser.fileno()], [], [], 0.005)
            out += ser.read(256)
        return out


def _dxl(sim: SimulatedBus, version: float = 2.0) -> Iterator[tuple[Any, Any, Any]]:
    import dynamixel_sdk as dxl

    port = dxl.PortHandler(sim.port)
    pk = dxl.PacketHandler(version)
    assert port.openPort() and port.setBaudRate(1_000_000)
    try:
        yield dxl, port, pk
    finally:
        port.closePort()


@pytest.fixture
def dxl_sim() -> Iterator[SimulatedBus]:
    sim = SimulatedBus([SimServoSpec(1, "xl330-m288", 1000), SimServoSpec(2, "xl430-w250", 2000),
                        SimServoSpec(3, "xm430-w350", 3000)])
    with sim:
        yield sim


@pytest.fixture
def sdk(dxl_sim: SimulatedBus) -> Iterator[tuple[Any, Any, Any]]:
    yield from _dxl(dxl_sim)


# ---- Ping -------------------------------------------------------------------------------------
def test_broadcast_ping_lists_every_servo_with_model_and_firmware(
        dxl_sim: SimulatedBus, sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    found, result = pk.broadcastPing(port)
    assert result == dxl.COMM_SUCCESS
    # model numbers from the e-Manual pages: XL330-M288 1200, XL430-W250 1060, XM430-W350 1020
    assert {i: v[0] for i, v in found.items()} == {1: 1200, 2: 1060, 3: 1020}
    assert all(v[1] == dxl_sim.servo(i).get(Register.FIRMWARE) for i, v in found.items())


def test_ping_answers_at_status_return_level_0(dxl_sim: SimulatedBus,
                                               sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    assert pk.write1ByteTxRx(port, 2, 68, 0) == (dxl.COMM_SUCCESS, 0)  # level 0: ping only
    assert pk.ping(port, 2) == (1060, dxl.COMM_SUCCESS, 0)
    assert pk.read1ByteTxRx(port, 2, 65)[1] == dxl.COMM_RX_TIMEOUT
    pk.write1ByteTxOnly(port, 2, 65, 1)
    time.sleep(0.02)
    assert dxl_sim.servo(2).get(Register.LED) == 1  # obeyed, not answered


# ---- Reg Write / Action -----------------------------------------------------------------------
def test_reg_write_waits_for_action_and_sets_registered_instruction(
        dxl_sim: SimulatedBus, sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    assert pk.read1ByteTxRx(port, 3, 69) == (0, dxl.COMM_SUCCESS, 0)
    assert pk.regWriteTxRx(port, 3, 65, 1, [1]) == (dxl.COMM_SUCCESS, 0)  # LED on, registered
    assert pk.read1ByteTxRx(port, 3, 65)[0] == 0
    assert pk.read1ByteTxRx(port, 3, 69)[0] == 1  # Registered Instruction
    assert pk.action(port, 3) == dxl.COMM_SUCCESS
    # the servo answers a unicast Action (e-Manual example); the SDK does not read that status
    time.sleep(0.02)
    port.clearPort()
    assert pk.read1ByteTxRx(port, 3, 65)[0] == 1
    assert pk.read1ByteTxRx(port, 3, 69)[0] == 0
    # Action without Reg Write (the e-Manual's Action packet to ID 1): Instruction Error 0x02
    reply = _raw_exchange(dxl_sim.port, H("FFFFFD000103000502CE"))
    assert reply[4] == 1 and reply[7:9] == H("5502")


def test_broadcast_action_runs_every_registered_write(dxl_sim: SimulatedBus,
                                                      sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    for i in (1, 2):
        assert pk.regWriteTxRx(port, i, 65, 1, [1]) == (dxl.COMM_SUCCESS, 0)
    trace = dxl_sim.start_trace()
    pk.action(port, dxl.BROADCAST_ID)
    time.sleep(0.02)
    assert [s.get(Register.LED) for s in dxl_sim.servos] == [1, 1, 0]
    assert [d for d, _ in trace] == ["rx"]  # no status to a broadcast


# ---- Factory Reset, Reboot, id and baud -------------------------------------------------------
@pytest.mark.parametrize(("option", "kept_id", "kept_baud"),
                         [(0x02, True, True), (0x01, True, False), (0xFF, False, False)])
def test_factory_reset_options(option: int, kept_id: bool, kept_baud: bool) -> None:
    sim = SimulatedBus([SimServoSpec(7, "xm430-w350")])
    with sim:
        for dxl, port, pk in _dxl(sim):
            assert pk.write1ByteTxRx(port, 7, 31, 60) == (dxl.COMM_SUCCESS, 0)  # Temp. Limit
            # the reply goes out before the reset and carries the old id
            assert pk.factoryReset(port, 7, option) == (dxl.COMM_SUCCESS, 0)
        servo = sim.servos[0]
        assert servo.get(Register.TEMPERATURE_LIMIT) == 80  # XM430-W350 default
        assert servo.id == (7 if kept_id else 1)
        assert servo.baudrate == (1_000_000 if kept_baud else 57_600)  # default code 1


def test_broadcast_factory_reset_all_is_not_carried_out(dxl_sim: SimulatedBus,
                                                        sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    pk.factoryReset(port, dxl.BROADCAST_ID, 0xFF)
    time.sleep(0.02)
    assert [s.id for s in dxl_sim.servos] == [1, 2, 3]
    pk.factoryReset(port, dxl.BROADCAST_ID, 0x02)  # the other options are
    time.sleep(0.02)
    assert [s.get(Register.RETURN_DELAY) for s in dxl_sim.servos] == [250] * 3


def test_factory_reset_unknown_option_is_a_range_error(sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    assert pk.factoryReset(port, 1, 0x05) == (dxl.COMM_SUCCESS, 0x04)


def test_reboot_restores_ram_and_keeps_eeprom(dxl_sim: SimulatedBus,
                                              sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    assert pk.write1ByteTxRx(port, 3, 31, 70) == (dxl.COMM_SUCCESS, 0)  # EEPROM
    assert pk.write1ByteTxRx(port, 3, 65, 1) == (dxl.COMM_SUCCESS, 0)  # RAM
    assert pk.reboot(port, 3) == (dxl.COMM_SUCCESS, 0)
    assert pk.read1ByteTxRx(port, 3, 31)[0] == 70
    assert pk.read1ByteTxRx(port, 3, 65)[0] == 0
    assert dxl_sim.servo(3).present_position() == 3000


def test_startup_configuration_torque_on_after_reboot(sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    assert pk.write1ByteTxRx(port, 1, 60, 1) == (dxl.COMM_SUCCESS, 0)  # Startup Torque On
    assert pk.reboot(port, 1) == (dxl.COMM_SUCCESS, 0)
    assert pk.read1ByteTxRx(port, 1, 64)[0] == 1
    assert pk.read4ByteTxRx(port, 1, 116)[0] == 1000  # holding where it is


def test_id_change_answers_with_the_old_id(dxl_sim: SimulatedBus,
                                           sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    trace = dxl_sim.start_trace()
    assert pk.write1ByteTxRx(port, 2, 7, 12) == (dxl.COMM_SUCCESS, 0)
    assert trace[-1][1][4] == 2
    assert pk.ping(port, 12)[1] == dxl.COMM_SUCCESS
    assert pk.ping(port, 2)[1] == dxl.COMM_RX_TIMEOUT


def test_baud_change_takes_effect_after_the_reply(dxl_sim: SimulatedBus,
                                                  sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    assert pk.write1ByteTxRx(port, 1, 8, 1) == (dxl.COMM_SUCCESS, 0)  # 57 600 bit/s
    assert pk.ping(port, 1)[1] == dxl.COMM_RX_TIMEOUT
    assert port.setBaudRate(57_600)
    assert pk.ping(port, 1) == (1200, dxl.COMM_SUCCESS, 0)


# ---- Control Table Backup (e-Manual example packets) ------------------------------------------
_STATUS_OK = H("FFFFFD000104005500A10C")
_BACKUP = H("FFFFFD0001080020014354524C16F5")
# The e-Manual's restore example prints the CRC as 92 F5; the CRC of its bytes is 9E F5 (the
# backup example's CRC, 16 F5, is right).
_RESTORE = H("FFFFFD0001080020024354524C9EF5")


def test_control_table_backup_and_restore() -> None:
    sim = SimulatedBus([SimServoSpec(1, "xl330-m288")])
    with sim:
        servo = sim.servos[0]
        servo.set(Register.TEMPERATURE_LIMIT, 60)
        servo.set(Register.PROFILE_VELOCITY, 77)
        assert servo.read(147, 1) == b"\x00"  # Backup Ready
        assert _raw_exchange(sim.port, _BACKUP) == _STATUS_OK
        assert servo.read(147, 1) == b"\x01"
        servo.set(Register.TEMPERATURE_LIMIT, 50)
        servo.set(Register.PROFILE_VELOCITY, 5)
        servo.set(Register.LED, 1)
        assert _raw_exchange(sim.port, _RESTORE) == _STATUS_OK
        assert servo.get(Register.TEMPERATURE_LIMIT) == 60  # EEPROM restored
        assert servo.get(Register.LED) == 0  # rebooted: RAM defaults
        assert servo.read(147, 1) == b"\x01"  # the backup is still there
        assert servo.get(Register.PROFILE_VELOCITY) == 0  # RAM restore not configured
        servo.set(Register.STARTUP_CONFIGURATION, 2)  # Restore RAM (an EEPROM item: backed up)
        servo.set(Register.PROFILE_VELOCITY, 77)
        assert _raw_exchange(sim.port, _BACKUP) == _STATUS_OK
        servo.set(Register.PROFILE_VELOCITY, 5)
        assert _raw_exchange(sim.port, _RESTORE) == _STATUS_OK
        assert servo.get(Register.PROFILE_VELOCITY) == 77


def test_control_table_backup_with_torque_on_fails() -> None:
    sim = SimulatedBus([SimServoSpec(1, "xl330-m288")])
    with sim:
        sim.servos[0].set(Register.TORQUE_ENABLE, 1)
        reply = _raw_exchange(sim.port, _BACKUP)
        assert reply[7:9] == H("5501")  # Result Fail
        assert sim.servos[0].read(147, 1) == b"\x00"


# ---- Fast Bulk Read ---------------------------------------------------------------------------
def test_fast_bulk_read_reply_follows_the_manual_example() -> None:
    # e-Manual Fast Bulk Read example: ID 3 Present Position (166), ID 7 Present PWM (2 bytes),
    # ID 4 Present Temperature (1 byte). The first part of the reply (header, LEN 0x14 for the
    # three segments, ID 3's segment and its CRC) depends only on ID 3's value.
    sim = SimulatedBus([SimServoSpec(3, "xl330-m288", 166), SimServoSpec(7, "xl330-m288"),
                        SimServoSpec(4, "xl330-m288")])
    with sim:
        # the instruction is the manual's; its CRC is computed (the manual prints 20 F2, the
        # CRC of its Fast Sync Read example)
        reply = _raw_exchange(sim.port, H("FFFFFD00FE12009A0384000400077C0002000492000100"
                                          "DA2D"))
    assert reply[:16] == H("FFFFFD00FE1400550003A600000067A4")
    assert len(reply) == 7 + 0x14
    assert reply[16:18] == H("0007") and reply[22:24] == H("0004")


def test_sdk_fast_bulk_read(dxl_sim: SimulatedBus, sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    dxl_sim.servo(2).set(Register.LED, 1)
    bulk = dxl.GroupBulkRead(port, pk)
    assert bulk.addParam(3, 132, 4) and bulk.addParam(2, 65, 1) and bulk.addParam(1, 7, 1)
    assert bulk.fastBulkRead() == dxl.COMM_SUCCESS
    assert bulk.getData(3, 132, 4) == 3000
    assert bulk.getData(2, 65, 1) == 1
    assert bulk.getData(1, 7, 1) == 1


# ---- Secondary ID ------------------------------------------------------------------------------
def test_secondary_id_obeys_ram_writes_without_replying(dxl_sim: SimulatedBus,
                                                        sdk: tuple[Any, Any, Any]) -> None:
    dxl, port, pk = sdk
    for i in (1, 2):
        assert pk.write1ByteTxRx(port, i, 12, 20) == (dxl.COMM_SUCCESS, 0)
    trace = dxl_sim.start_trace()
    assert pk.write1ByteTxRx(port, 20, 65, 1)[0] == dxl.COMM_RX_TIMEOUT  # no status packet
    assert [s.get(Register.LED) for s in dxl_sim.servos] == [1, 1, 0]
    assert all(d == "rx" for d, _ in trace)
    pk.write1ByteTxOnly(port, 20, 31, 55)  # EEPROM: not through the Secondary ID
    time.sleep(0.02)
    assert [s.get(Register.TEMPERATURE_LIMIT) for s in dxl_sim.servos[:2]] == [70, 72]
    # the primary ID wins: servo 3 with Secondary ID 1 stays silent, servo 1 answers
    assert pk.write1ByteTxRx(port, 3, 12, 1) == (dxl.COMM_SUCCESS, 0)
    assert pk.write1ByteTxRx(port, 1, 65, 0) == (dxl.COMM_SUCCESS, 0)
    assert dxl_sim.servo(3).get(Register.LED) == 0


# ---- Protocol 1.0 ------------------------------------------------------------------------------
def test_protocol1_reset_restores_everything() -> None:
    sim = SimulatedBus([SimServoSpec(5, "xl430-w250")], Protocol.DYNAMIXEL1)
    with sim:
        for dxl, port, pk in _dxl(sim, 1.0):
            assert pk.write1ByteTxRx(port, 5, 31, 60) == (dxl.COMM_SUCCESS, 0)
            assert pk.factoryReset(port, 5) == (dxl.COMM_SUCCESS, 0)
        servo = sim.servos[0]
        assert (servo.id, servo.get(Register.TEMPERATURE_LIMIT)) == (1, 72)
        assert servo.baudrate == 57_600


def test_protocol1_has_no_reboot() -> None:
    # Protocol 1.0 defines no instruction 0x08: Instruction Error, bit 6 of the status byte
    sim = SimulatedBus([SimServoSpec(1, "xl430-w250")], Protocol.DYNAMIXEL1)
    with sim:
        sim.servos[0].set(Register.LED, 1)
        assert _raw_exchange(sim.port, H("FFFF010208F4")) == H("FFFF010240BC")
        assert sim.servos[0].get(Register.LED) == 1


# ---- Feetech ----------------------------------------------------------------------------------
@pytest.fixture
def ft() -> Iterator[tuple[SimulatedBus, Any, Any, Any]]:
    import scservo_sdk as scs

    sim = SimulatedBus([SimServoSpec(1, "sts3215", 1000), SimServoSpec(2, "sts3215", 3000)],
                       Protocol.FEETECH)
    with sim:
        port = scs.PortHandler(sim.port)
        pk = scs.PacketHandler(0)
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            yield sim, scs, port, pk
        finally:
            port.closePort()


def test_feetech_reg_write_and_action(ft: tuple[SimulatedBus, Any, Any, Any]) -> None:
    _sim, scs, port, pk = ft
    assert pk.regWriteTxRx(port, 1, 42, 2, [0x00, 0x05]) == (scs.COMM_SUCCESS, 0)  # Goal 1280
    assert pk.read1ByteTxRx(port, 1, 64)[0] == 1  # Registered Instruction
    assert pk.read2ByteTxRx(port, 1, 42)[0] == 0
    assert pk.action(port, 1) == scs.COMM_SUCCESS
    assert pk.read2ByteTxRx(port, 1, 42)[0] == 0x0500
    assert pk.read1ByteTxRx(port, 1, 64)[0] == 0


def test_feetech_torque_enable_128_centres_the_position(
        ft: tuple[SimulatedBus, Any, Any, Any]) -> None:
    _sim, scs, port, pk = ft
    assert pk.write1ByteTxRx(port, 2, 40, 128) == (scs.COMM_SUCCESS, 0)
    assert pk.read2ByteTxRx(port, 2, 56)[0] == 2048
    assert pk.read1ByteTxRx(port, 2, 40)[0] == 0  # a command, not a torque state


def test_feetech_recovery_restores_factory_values(ft: tuple[SimulatedBus, Any, Any, Any]) -> None:
    sim, scs, port, pk = ft
    assert pk.write1ByteTxRx(port, 2, 55, 0) == (scs.COMM_SUCCESS, 0)  # unlock
    assert pk.write1ByteTxRx(port, 2, 13, 60) == (scs.COMM_SUCCESS, 0)  # max temperature
    reply = _raw_exchange(sim.port, H("FFFF020206F5"))
    assert reply == H("FFFF020200FB")  # acknowledged with the old id
    servo = sim.servos[1]
    assert (servo.id, servo.get(Register.TEMPERATURE_LIMIT), servo.get(Register.LOCK)) == (1, 70, 1)


def test_feetech_bad_checksum_is_ignored(ft: tuple[SimulatedBus, Any, Any, Any]) -> None:
    sim, _scs, _port, _pk = ft
    assert _raw_exchange(sim.port, H("FFFF010201FA")) == b""  # ping, checksum off by one
    assert _raw_exchange(sim.port, H("FFFF010201FB")) == H("FFFF010200FC")


def test_feetech_id_and_baud_changes_after_the_reply(
        ft: tuple[SimulatedBus, Any, Any, Any]) -> None:
    _sim, scs, port, pk = ft
    assert pk.write1ByteTxRx(port, 1, 5, 9) == (scs.COMM_SUCCESS, 0)  # locked: ignored
    assert pk.ping(port, 9)[1] == scs.COMM_RX_TIMEOUT
    assert pk.write1ByteTxRx(port, 1, 55, 0) == (scs.COMM_SUCCESS, 0)  # unlock
    assert pk.write1ByteTxRx(port, 1, 5, 9) == (scs.COMM_SUCCESS, 0)  # answered by id 1
    assert pk.ping(port, 9) == (777, scs.COMM_SUCCESS, 0)
    assert pk.write1ByteTxRx(port, 9, 6, 4) == (scs.COMM_SUCCESS, 0)  # 115 200 bit/s
    assert pk.ping(port, 9)[1] == scs.COMM_RX_TIMEOUT
    assert port.setBaudRate(115_200)
    assert pk.ping(port, 9) == (777, scs.COMM_SUCCESS, 0)


def test_feetech_status_return_level_0_answers_ping_and_read_only(
        ft: tuple[SimulatedBus, Any, Any, Any]) -> None:
    sim, scs, port, pk = ft
    assert pk.write1ByteTxRx(port, 2, 55, 0) == (scs.COMM_SUCCESS, 0)  # unlock
    assert pk.write1ByteTxRx(port, 2, 8, 0) == (scs.COMM_SUCCESS, 0)  # level 0 (answered: 1)
    assert pk.write1ByteTxRx(port, 2, 40, 1)[0] == scs.COMM_RX_TIMEOUT  # obeyed, not answered
    assert sim.servo(2).torque
    assert pk.read1ByteTxRx(port, 2, 40) == (1, scs.COMM_SUCCESS, 0)
    assert pk.ping(port, 2) == (777, scs.COMM_SUCCESS, 0)
