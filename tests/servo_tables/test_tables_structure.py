"""Every control table is well formed: items, address maps, indexed blocks, ranges, areas."""

from __future__ import annotations

from itertools import pairwise

import pytest

from armctl.errors import InputError, UnknownNameError
from armctl.servo_tables import (
    TABLES,
    VENDORS,
    Access,
    ControlTable,
    Encoding,
    Family,
    IndirectBlock,
    Register,
    RegisterSpec,
    table_for,
)

MODELS = sorted(TABLES)
INDEXED = {Register.INDIRECT_ADDRESS, Register.INDIRECT_DATA, Register.EXTERNAL_PORT_MODE,
           Register.EXTERNAL_PORT_DATA}


@pytest.fixture(params=MODELS)
def table(request: pytest.FixtureRequest) -> ControlTable:
    return TABLES[request.param]


def test_the_supported_models() -> None:
    assert set(MODELS) == {"xl330-m077", "xl330-m288", "xl430-w250", "xm430-w350",
                           "xm540-w270", "sts3215"}


def test_items_sorted_and_never_overlapping(table: ControlTable) -> None:
    items = table.items
    assert items, table.model
    for a, b in pairwise(items):
        assert a.address + a.size <= b.address, (table.model, a.name, b.name)


def test_sizes_and_addresses_inside_memory(table: ControlTable) -> None:
    for spec in table.items:
        assert spec.size in (1, 2, 4), (table.model, spec.name)
        assert 0 <= spec.address and spec.address + spec.size <= table.memory_size, spec.name
    # The memory a read may cover ends with the last item of the table.
    last = table.items[-1]
    assert last.address + last.size == table.memory_size


def test_registers_are_the_non_indexed_items(table: ControlTable) -> None:
    plain = [s for s in table.items if s.index == 0]
    assert {s.register: s for s in plain} == table.registers
    assert len(plain) == len(table.registers)  # no register twice
    for reg, spec in table.registers.items():
        assert spec.register is reg
        assert reg not in INDEXED
    for spec in table.items:
        assert (spec.index > 0) == (spec.register in INDEXED), spec.name


def test_every_item_has_the_makers_name_and_a_unique_one(table: ControlTable) -> None:
    names = [s.name for s in table.items]
    assert all(names), [s for s in table.items if not s.name]
    assert len(set(names)) == len(names)
    for spec in table.items:
        assert table.named(spec.name) is spec
        assert table.named(spec.name.upper().replace(" ", "_")) is spec


def test_indexed_items_numbered_from_one_without_gaps(table: ControlTable) -> None:
    for reg in INDEXED:
        indices = sorted(s.index for s in table.items if s.register is reg)
        assert indices == list(range(1, len(indices) + 1)), (table.model, reg)
        for i in indices:
            spec = table.item(reg, i)
            assert (spec.register, spec.index) == (reg, i)
            assert spec.name.endswith(f" {i}")


def test_indirect_blocks_match_the_indexed_items(table: ControlTable) -> None:
    addresses = [s for s in table.items if s.register is Register.INDIRECT_ADDRESS]
    data = [s for s in table.items if s.register is Register.INDIRECT_DATA]
    assert len(addresses) == len(data) == sum(b.count for b in table.indirect)
    covered: list[int] = []
    for block in table.indirect:
        assert isinstance(block, IndirectBlock)
        for k in range(block.count):
            i = block.first_index + k
            covered.append(i)
            assert i in block and (i + block.count) not in block
            a = table.item(Register.INDIRECT_ADDRESS, i)
            d = table.item(Register.INDIRECT_DATA, i)
            assert a.address == block.address_start + 2 * k == block.address_of(i)
            assert d.address == block.data_start + k == block.data_of(i)
            assert (a.size, d.size) == (2, 1)
            assert a.access is d.access is Access.RW
            # Factory default: slot i points at its own data byte.
            assert a.default == d.address
            # An indirect address may name any RAM byte of the table.
            assert (a.lo, a.hi) == (table.eeprom_end, table.memory_size - 1)
            assert (d.lo, d.hi) == (0, 255)
        # The data bytes of a block follow its address words.
        assert block.data_start == block.address_start + 2 * block.count
    assert sorted(covered) == list(range(1, len(covered) + 1))


def test_defaults_inside_ranges_and_ranges_fit_the_bytes(table: ControlTable) -> None:
    for spec in table.items:
        assert spec.lo <= spec.default <= spec.hi, (table.model, spec.name)
        bits = 8 * spec.size
        if spec.encoding is Encoding.UNSIGNED:
            assert 0 <= spec.lo and spec.hi < 2**bits, spec.name
        elif spec.encoding is Encoding.TWOS_COMPLEMENT:
            assert -(2 ** (bits - 1)) <= spec.lo and spec.hi < 2 ** (bits - 1), spec.name
        else:
            assert spec.sign_bit < bits, spec.name
            assert -(2**spec.sign_bit) < spec.lo and spec.hi < 2**spec.sign_bit, spec.name


def test_encodings_match_the_family(table: ControlTable) -> None:
    allowed = ({Encoding.UNSIGNED, Encoding.TWOS_COMPLEMENT}
               if table.family is Family.DYNAMIXEL
               else {Encoding.UNSIGNED, Encoding.SIGN_MAGNITUDE})
    assert {s.encoding for s in table.items} <= allowed


def test_ram_eeprom_split(table: ControlTable) -> None:
    # RAM starts at Torque Enable on both families; everything before it is EEPROM.
    assert table.spec(Register.TORQUE_ENABLE).address == table.eeprom_end
    assert table.eeprom_end == (64 if table.family is Family.DYNAMIXEL else 40)
    for reg in (Register.ID, Register.BAUD_RATE, Register.OPERATING_MODE,
                Register.HOMING_OFFSET, Register.MAX_POSITION_LIMIT):
        assert table.is_eeprom(reg), reg
    for reg in (Register.TORQUE_ENABLE, Register.GOAL_POSITION, Register.PRESENT_POSITION,
                Register.PRESENT_LOAD, Register.HARDWARE_ERROR, Register.MOVING):
        assert not table.is_eeprom(reg), reg
    # The readings the servo produces live in RAM and are read-only.
    for spec in table.items:
        if spec.access is Access.R and spec.address >= table.eeprom_end:
            assert spec.name.startswith(("Present", "Hardware", "Moving", "Registered",
                                         "Realtime", "Velocity Trajectory",
                                         "Position Trajectory", "Backup", "Status",
                                         "Sync_Write")), spec.name


def test_covering_and_at_agree_with_a_brute_force_scan(table: ControlTable) -> None:
    for address in range(-2, table.memory_size + 3):
        hits = [s for s in table.items if s.address <= address < s.address + s.size]
        assert len(hits) <= 1
        assert table.covering(address) is (hits[0] if hits else None), address
        starts = [s for s in table.items if s.address == address]
        assert table.at(address) is (starts[0] if starts else None), address


def test_lookups_refuse_unknown_items(table: ControlTable) -> None:
    with pytest.raises(UnknownNameError):
        table.item(Register.INDIRECT_DATA, 0)
    with pytest.raises(UnknownNameError):
        table.item(Register.INDIRECT_DATA, 57)
    with pytest.raises(UnknownNameError):
        table.item(Register.GOAL_POSITION, 1)
    with pytest.raises(UnknownNameError, match="no such thing"):
        table.named("no such thing")


def test_model_parameters(table: ControlTable) -> None:
    vendor = VENDORS[table.family]
    assert table.vendor is vendor
    assert table.ticks_per_rev == 4096
    assert table.nominal_voltage > 0 and table.max_speed > 0
    mode = table.spec(Register.OPERATING_MODE)
    assert table.operating_modes and all(mode.lo <= m <= mode.hi for m in table.operating_modes)
    assert vendor.position_mode in table.operating_modes
    baud = table.spec(Register.BAUD_RATE)
    assert set(range(baud.lo, baud.hi + 1)) <= set(vendor.baud_codes)
    for option, kept in vendor.reset_keeps.items():
        assert 0 <= option <= 0xFF
        assert all(table.has(r) and table.is_eeprom(r) for r in kept)


def test_tables_built_without_items_derive_them() -> None:
    spec = RegisterSpec(Register.ID, 3, 1, Access.RW, 0, 9, name="Id")
    other = RegisterSpec(Register.LED, 1, 2, Access.RW, 0, 1)
    t = ControlTable("m", 1, VENDORS[Family.FEETECH], {Register.ID: spec, Register.LED: other},
                     eeprom_end=2, memory_size=4)
    assert t.items == (other, spec)
    assert t.covering(2) is other and t.covering(3) is spec and t.covering(0) is None
    assert t.named("ID") is spec and t.indirect == ()


def test_parse_accepts_the_new_names() -> None:
    cases = {
        "Goal PWM": Register.GOAL_PWM, "goal_current": Register.GOAL_CURRENT,
        "Secondary-ID": Register.SECONDARY_ID, "Bus Watchdog": Register.BUS_WATCHDOG,
        "Indirect_Address": Register.INDIRECT_ADDRESS, "INDIRECT DATA": Register.INDIRECT_DATA,
        "External Port Data": Register.EXTERNAL_PORT_DATA, "Torque_Limit": Register.TORQUE_LIMIT,
        "max acceleration": Register.MAX_ACCELERATION,
        "Overcurrent_Protection_Time": Register.OVERCURRENT_PROTECTION_TIME,
        "feedforward 2nd gain": Register.FEEDFORWARD_2ND_GAIN,
        "Startup Configuration": Register.STARTUP_CONFIGURATION,
    }
    for name, reg in cases.items():
        assert Register.parse(name) is reg
    # Every member parses from its own value and from its spelled-out name.
    for reg in Register:
        assert Register.parse(reg.value) is reg
        assert Register.parse(reg.name.replace("_", " ").title()) is reg
    with pytest.raises(UnknownNameError):
        Register.parse("goal pwn")


def test_table_for_is_case_insensitive() -> None:
    assert table_for("XM540-W270") is TABLES["xm540-w270"]
    with pytest.raises(UnknownNameError):
        table_for("xm540-w271")


def test_overlapping_items_are_refused() -> None:
    a = RegisterSpec(Register.ID, 3, 2, Access.RW, 0, 9, name="Id")
    b = RegisterSpec(Register.LED, 4, 1, Access.RW, 0, 1, name="Led")
    with pytest.raises(InputError, match=r"'m'.*'Id' and 'Led' overlap at address 4"):
        ControlTable("m", 1, VENDORS[Family.FEETECH], {Register.ID: a, Register.LED: b},
                     eeprom_end=2, memory_size=5)


def test_value_sets_inside_ranges(table: ControlTable) -> None:
    for spec in table.items:
        if spec.values:
            assert list(spec.values) == sorted(set(spec.values)), spec.name
            assert spec.lo <= spec.values[0] and spec.values[-1] <= spec.hi, spec.name
            assert spec.default in spec.values, spec.name
            holes = [v for v in range(spec.lo, spec.hi + 1) if v not in spec.values]
            assert holes and not any(spec.accepts(v) for v in holes), spec.name
            assert all(spec.accepts(v) for v in spec.values), spec.name
        else:
            assert spec.accepts(spec.lo) and spec.accepts(spec.hi)
        assert not spec.accepts(spec.lo - 1) and not spec.accepts(spec.hi + 1)
    if table.family is Family.DYNAMIXEL:
        assert table.spec(Register.OPERATING_MODE).values == table.operating_modes
    baud = table.spec(Register.BAUD_RATE)
    assert sorted(table.baud_codes) == list(range(baud.lo, baud.hi + 1))
    assert all(table.vendor.baud_codes[c] == r for c, r in table.baud_codes.items())
