"""Per-model differences the makers' tables state, spot-checked with the manuals' numbers.

Numbers are from the ROBOTIS e-Manual control tables of each X-series model and Feetech's
STS3215 memory table (the full item-by-item check against an independent transcription is
elsewhere in the suite).
"""

from __future__ import annotations

import pytest

from armctl.servo_tables import TABLES, Access, Family, IndirectBlock, Register, table_for

DXL = ("xl330-m077", "xl330-m288", "xl430-w250", "xm430-w350", "xm540-w270")


@pytest.mark.parametrize(("model", "number", "memory"), [
    ("xl330-m077", 1190, 228), ("xl330-m288", 1200, 228), ("xl430-w250", 1060, 662),
    ("xm430-w350", 1020, 662), ("xm540-w270", 1120, 662), ("sts3215", 777, 87)])
def test_model_numbers_and_memory(model: str, number: int, memory: int) -> None:
    t = table_for(model)
    assert t.model_number == number
    assert t.spec(Register.MODEL_NUMBER).default == number
    assert t.memory_size == memory


def test_operating_modes() -> None:
    modes = {m: TABLES[m].operating_modes for m in DXL}
    assert modes == {"xl330-m077": (0, 1, 3, 4, 5, 16), "xl330-m288": (0, 1, 3, 4, 5, 16),
                     "xl430-w250": (1, 3, 4, 16), "xm430-w350": (0, 1, 3, 4, 5, 16),
                     "xm540-w270": (0, 1, 3, 4, 5, 16)}
    assert TABLES["sts3215"].operating_modes == (0, 1, 2, 3)


def test_current_sensing() -> None:
    xl430 = table_for("xl430-w250")
    assert not xl430.has(Register.CURRENT_LIMIT) and not xl430.has(Register.GOAL_CURRENT)
    assert xl430.covering(38) is None and xl430.covering(102) is None
    load = xl430.spec(Register.PRESENT_LOAD)
    assert (load.address, load.name, load.unit, load.lo, load.hi) == (
        126, "Present Load", "0.1 %", -1000, 1000)
    expected = {"xl330-m077": (1750, "1 mA"), "xl330-m288": (1750, "1 mA"),
                "xm430-w350": (1193, "2.69 mA"), "xm540-w270": (2047, "2.69 mA")}
    for model, (limit, unit) in expected.items():
        t = table_for(model)
        cur = t.spec(Register.CURRENT_LIMIT)
        assert (cur.address, cur.default, cur.hi, cur.unit) == (38, limit, limit, unit)
        goal = t.spec(Register.GOAL_CURRENT)
        assert (goal.address, goal.lo, goal.hi) == (102, -limit, limit)
        present = t.spec(Register.PRESENT_LOAD)
        assert (present.address, present.name, present.unit) == (126, "Present Current", unit)


def test_velocity_limits_and_gains() -> None:
    limits = {m: TABLES[m].spec(Register.VELOCITY_LIMIT).default for m in DXL}
    assert limits == {"xl330-m077": 1620, "xl330-m288": 445, "xl430-w250": 265,
                      "xm430-w350": 200, "xm540-w270": 128}
    gains = {m: tuple(TABLES[m].spec(r).default for r in (
        Register.VELOCITY_I_GAIN, Register.VELOCITY_P_GAIN, Register.D_GAIN, Register.I_GAIN,
        Register.P_GAIN)) for m in DXL}
    assert gains == {"xl330-m077": (400, 40, 0, 400, 400),
                     "xl330-m288": (1600, 180, 0, 0, 400),
                     "xl430-w250": (1000, 100, 4000, 0, 640),
                     "xm430-w350": (1920, 100, 0, 0, 800),
                     "xm540-w270": (1920, 100, 0, 0, 800)}


def test_xl330_only_items() -> None:
    for model in DXL:
        t = table_for(model)
        slope = t.has(Register.PWM_SLOPE)
        assert slope == model.startswith("xl330")
        if slope:
            s = t.spec(Register.PWM_SLOPE)
            assert (s.address, s.default, s.lo, s.hi) == (62, 140, 1, 255)
        assert t.spec(Register.BAUD_RATE).hi == (6 if model.startswith("xl330") else 7)
        # 4.5 Mbps (code 7) only on the X430/X540 models.
        assert (7 in t.baud_codes) == (not model.startswith("xl330"))
        assert t.baud_codes[3] == 1_000_000 and t.baud_codes[6] == 4_000_000
        protocol = t.spec(Register.PROTOCOL_TYPE)
        if model.startswith("xl330"):
            assert protocol.values == (2, 20, 21, 22) and not protocol.accepts(3)
        else:
            assert (protocol.lo, protocol.hi, protocol.values) == (1, 2, ())
        assert t.spec(Register.DRIVE_MODE).hi == (13 if model == "xl430-w250" else 5)
        assert t.spec(Register.SHUTDOWN).default == (53 if model.startswith("xl330") else 52)


def test_indirect_slots() -> None:
    for model in DXL:
        blocks = table_for(model).indirect
        if model.startswith("xl330"):
            assert blocks == (IndirectBlock(1, 20, 168, 208),)
        else:
            assert blocks == (IndirectBlock(1, 28, 168, 224), IndirectBlock(29, 28, 578, 634))
    x = table_for("xm430-w350")
    assert x.item(Register.INDIRECT_ADDRESS, 56).address == 632
    assert x.item(Register.INDIRECT_ADDRESS, 56).default == 661
    assert x.item(Register.INDIRECT_DATA, 28).address == 251
    assert x.covering(300) is None  # the gap between the two blocks
    assert table_for("xl330-m077").item(Register.INDIRECT_ADDRESS, 20).default == 227
    assert table_for("sts3215").indirect == ()


def test_xm540_external_ports() -> None:
    t = table_for("xm540-w270")
    for n in (1, 2, 3):
        mode = t.item(Register.EXTERNAL_PORT_MODE, n)
        assert (mode.address, mode.size, mode.default, mode.hi) == (55 + n, 1, 3, 3)
        assert mode.address < t.eeprom_end
        data = t.item(Register.EXTERNAL_PORT_DATA, n)
        assert (data.address, data.size, data.access) == (150 + 2 * n, 2, Access.RW)
        assert data.address >= t.eeprom_end
    for model in DXL[:4]:
        assert not any(s.register is Register.EXTERNAL_PORT_MODE
                       for s in table_for(model).items)


def test_feetech_items() -> None:
    t = table_for("sts3215")
    where = {r: (t.spec(r).address, t.spec(r).size) for r in (
        Register.TORQUE_LIMIT, Register.MAX_ACCELERATION, Register.PROTECTION_CURRENT,
        Register.PROTECTIVE_TORQUE, Register.PROTECTION_TIME, Register.OVERLOAD_TORQUE,
        Register.OVERCURRENT_PROTECTION_TIME, Register.CW_DEAD_ZONE, Register.CCW_DEAD_ZONE,
        Register.UNLOADING_CONDITION, Register.LED_ALARM_CONDITION,
        Register.MIN_STARTUP_FORCE, Register.ANGULAR_RESOLUTION, Register.PRESENT_CURRENT)}
    assert where == {
        Register.TORQUE_LIMIT: (48, 2), Register.MAX_ACCELERATION: (85, 1),
        Register.PROTECTION_CURRENT: (28, 2), Register.PROTECTIVE_TORQUE: (34, 1),
        Register.PROTECTION_TIME: (35, 1), Register.OVERLOAD_TORQUE: (36, 1),
        Register.OVERCURRENT_PROTECTION_TIME: (38, 1), Register.CW_DEAD_ZONE: (26, 1),
        Register.CCW_DEAD_ZONE: (27, 1), Register.UNLOADING_CONDITION: (19, 1),
        Register.LED_ALARM_CONDITION: (20, 1), Register.MIN_STARTUP_FORCE: (24, 2),
        Register.ANGULAR_RESOLUTION: (30, 1), Register.PRESENT_CURRENT: (69, 2)}
    assert t.spec(Register.TORQUE_LIMIT).default == t.spec(Register.MAX_TORQUE).default == 1000
    torque = t.spec(Register.TORQUE_ENABLE)
    assert [v for v in range(256) if torque.accepts(v)] == [0, 1, 2, 128]
    pwm = t.spec(Register.GOAL_TIME)
    assert (pwm.lo, pwm.hi, pwm.sign_bit) == (-1000, 1000, 10)
    assert t.baud_codes == {0: 1_000_000, 1: 500_000, 2: 250_000, 3: 128_000, 4: 115_200,
                            5: 76_800, 6: 57_600, 7: 38_400}
    assert t.named("Maximum_Acceleration") is t.spec(Register.MAX_ACCELERATION)
    assert t.named("Torque_Limit").address == 48
    # EPROM 0-39 (behind Lock), SRAM from 40, factory parameters from 80.
    assert t.is_eeprom(Register.VELOCITY_I_GAIN) and not t.is_eeprom(Register.TORQUE_LIMIT)
    assert not t.is_eeprom(Register.MAX_ACCELERATION)
    assert t.vendor.family is Family.FEETECH and t.vendor.eeprom_lock


def test_factory_reset_options() -> None:
    # e-Manual Protocol 2.0 "Factory Reset": 0xFF all, 0x01 all but ID, 0x02 all but ID and
    # Baud Rate.
    for model in DXL:
        keeps = table_for(model).vendor.reset_keeps
        assert keeps == {0xFF: (), 0x01: (Register.ID,),
                         0x02: (Register.ID, Register.BAUD_RATE)}
    assert table_for("sts3215").vendor.reset_keeps == {}


def test_items_found_by_the_names_clients_use() -> None:
    x = table_for("xl330-m077")
    assert x.named("Secondary_ID").address == 12
    assert x.named("Present_Input_Voltage").address == 144
    assert x.named("hardware error status").address == 70
    assert x.named("Position_P_Gain").register is Register.P_GAIN
    sts = table_for("sts3215")
    assert sts.named("Acceleration_Multiplier ").address == 86
    assert sts.named("Over_Current_Protection_Time").address == 38
