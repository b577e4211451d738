"""armctl's control tables and the simulated servo, checked item by item against the manuals.

The truth is tests/data/servo_manuals/: one CSV per model with every item of the maker's control
table (address, size, name, area, access, default, range, unit) and one YAML with the model
number, operating modes, baud codes and factory reset options, typed in from the ROBOTIS e-Manual
and Feetech's memory table (see the README there). Nothing here reads armctl's tables to decide
what is right: the tables and the simulator are what is checked.

The simulator is driven at the byte level (``SimServo.read`` / ``SimServo.write`` at the manual's
addresses), so a simulator test says how the servo answers a host, whatever names armctl gives
its registers.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import cache
from typing import Any

import pytest
import yaml
from armctl_testpaths import DATA

from armctl.clock import SimulatedClock
from armctl.servo.sim.servo import SimServo
from armctl.servo_tables import ControlTable, RegisterSpec, table_for

MANUALS = DATA / "servo_manuals"
MODELS = ("xl330-m077", "xl330-m288", "xl430-w250", "xm430-w350", "xm540-w270", "sts3215")

# Dynamixel status error numbers (e-Manual, Protocol 2.0 "Status Packet").
RANGE_ERROR, LIMIT_ERROR, ACCESS_ERROR = 0x04, 0x06, 0x07
#: Items whose range is bounded by another item (the manual's "-Current Limit(38) ~ ..."): the
#: servo may report a write beyond it as a Data Limit Error instead of a Data Range Error.
LIMIT_BOUNDED = {"Goal PWM", "Goal Current", "Goal Velocity", "Goal Position"}
#: Read-only items the servo changes by itself as time passes.
TIME_VARYING = {"Realtime Tick"}
#: Ranges that the maker's notes (not the table's range column) widen, with where they say so.
WIDENED: dict[tuple[str, str], tuple[int, int]] = {
    # Feetech memory table, Maximum angle limit: "0 in multi-turn absolute position control"
    # (both angle limits 0 switch the limits off).
    ("sts3215", "Maximum angle limit"): (0, 4095),
    # Running time is the open-loop duty in PWM mode (mode 2), its direction in bit 10
    # (feetech-servo-sdk sms_sts.py WritePWM): -1000 ~ 1000.
    ("sts3215", "Running time"): (-1000, 1000),
}


@dataclass(frozen=True)
class Item:
    """One row of a transcribed control table."""

    model: str
    address: int
    size: int
    name: str
    area: str
    access: str
    default: int | None
    lo: int | None
    hi: int | None
    unit: str

    @property
    def eeprom(self) -> bool:
        return self.area == "EEPROM"

    @property
    def id(self) -> str:
        return f"{self.model}:{self.address}:{self.name}"


def _int(text: str) -> int | None:
    return int(text) if text.strip() else None


@cache
def manual_items(model: str) -> tuple[Item, ...]:
    """The transcribed table of ``model`` (tests/data/servo_manuals/<model>.csv)."""
    with open(MANUALS / f"{model}.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    items = tuple(Item(model, int(r["address"]), int(r["size"]), r["name"], r["area"], r["access"],
                       _int(r["default"]), _int(r["min"]), _int(r["max"]), r["unit"])
                  for r in rows)
    assert items, f"{model}.csv has no rows"
    return items


@cache
def manual_facts(model: str) -> dict[str, Any]:
    """The transcribed model facts (tests/data/servo_manuals/<model>.yaml)."""
    with open(MANUALS / f"{model}.yaml", encoding="utf-8") as f:
        facts: dict[str, Any] = yaml.safe_load(f)
    return facts


def is_feetech(model: str) -> bool:
    return manual_facts(model)["maker"] == "Feetech"


def sign_bit(item: Item) -> int | None:
    """Feetech sign-magnitude sign bit of an item, or None (Dynamixel, or unsigned)."""
    bits: dict[int, int] = manual_facts(item.model).get("sign_bits", {})
    return bits.get(item.address)


def encode(item: Item, value: int) -> bytes:
    """``value`` as the servo stores the item (little-endian; two's complement on Dynamixel,
    sign-magnitude where the Feetech table names a sign bit)."""
    bit = sign_bit(item)
    if bit is not None:
        raw = abs(value) | ((1 << bit) if value < 0 else 0)
        return raw.to_bytes(item.size, "little")
    return value.to_bytes(item.size, "little", signed=value < 0)


def decode(item: Item, data: bytes) -> int:
    raw = int.from_bytes(data, "little")
    bit = sign_bit(item)
    if bit is not None:
        magnitude = raw & ((1 << bit) - 1)
        return -magnitude if raw & (1 << bit) else magnitude
    if item.lo is not None and item.lo < 0 and raw >= 1 << (8 * item.size - 1):
        return raw - (1 << (8 * item.size))
    return raw


def fits(item: Item, value: int) -> bool:
    """Whether ``value`` can be put in the item's bytes at all."""
    bit = sign_bit(item)
    if bit is not None:
        return abs(value) < (1 << bit)
    if item.lo is not None and item.lo < 0:
        return -(1 << (8 * item.size - 1)) <= value < (1 << (8 * item.size - 1))
    return 0 <= value < (1 << (8 * item.size))


def enumerated(item: Item) -> list[int] | None:
    """The values the manual lists for an enumerated item, or None."""
    values: dict[int, list[int]] = manual_facts(item.model).get("enumerated", {})
    return values.get(item.address)


def by_name(model: str, name: str) -> Item:
    return next(i for i in manual_items(model) if i.name == name)


def cases(pred: Any = lambda item: True) -> list[Any]:
    return [pytest.param(item, id=item.id) for model in MODELS for item in manual_items(model)
            if pred(item)]


# ---- the tables ------------------------------------------------------------------------------
def table_items(table: ControlTable) -> tuple[RegisterSpec, ...]:
    """Every item of armctl's table, indexed ones included."""
    assert table.items, f"{table.model}: the table lists no items"
    return table.items


def spec_at(item: Item) -> RegisterSpec:
    table = table_for(item.model)
    spec = next((s for s in table_items(table) if s.address == item.address), None)
    assert spec is not None, f"{item.model}: no item at address {item.address} ({item.name})"
    return spec


@pytest.mark.parametrize("item", cases())
def test_table_item_address_size_access(item: Item) -> None:
    spec = spec_at(item)
    assert (spec.size, spec.access.value) == (item.size, item.access), \
        f"{item.id}: armctl has size {spec.size} access {spec.access.value}"


@pytest.mark.parametrize("item", cases())
def test_table_item_area(item: Item) -> None:
    table = table_for(item.model)
    assert (item.address < table.eeprom_end) == item.eeprom, \
        f"{item.id}: manual area {item.area}, armctl eeprom_end {table.eeprom_end}"


@pytest.mark.parametrize("item", cases(lambda i: i.default is not None))
def test_table_item_default(item: Item) -> None:
    assert spec_at(item).default == item.default


@pytest.mark.parametrize("item", cases(lambda i: i.access == "RW" and i.lo is not None))
def test_table_item_range(item: Item) -> None:
    spec = spec_at(item)
    if item.name in LIMIT_BOUNDED:
        # The manual bounds these by another item (and, for Goal Position, by the operating
        # mode); the CSV has the bounds at that item's default, which a table's static range
        # must at least admit. The servo's refusal beyond them is checked on the simulator.
        assert item.lo is not None and item.hi is not None
        assert spec.lo <= item.lo and item.hi <= spec.hi, \
            f"{item.id}: armctl range {spec.lo} ~ {spec.hi} refuses part of {item.lo} ~ {item.hi}"
    else:
        want = WIDENED.get((item.model, item.name), (item.lo, item.hi))
        assert (spec.lo, spec.hi) == want


@pytest.mark.parametrize("model", MODELS)
def test_table_has_no_item_the_manual_lacks(model: str) -> None:
    manual = {i.address for i in manual_items(model)}
    manual |= set(manual_facts(model).get("untranscribed", ()))  # see the README
    extra = sorted((s.address, s.name or s.register.value) for s in table_items(table_for(model))
                   if s.address not in manual)
    assert not extra, f"{model}: armctl items not in the maker's table: {extra}"


@pytest.mark.parametrize("model", MODELS)
def test_table_model_facts(model: str) -> None:
    facts = manual_facts(model)
    table = table_for(model)
    assert table.model_number == facts["model_number"]
    assert set(table.operating_modes) == set(facts["operating_modes"])
    assert table.baud_codes == facts["baud_rates"]


@pytest.mark.parametrize("model", [m for m in MODELS if manual_facts(m)["factory_reset"]])
def test_table_factory_reset_options(model: str) -> None:
    table = table_for(model)
    want = {option: sorted(by_name(model, n).address for n in names)
            for option, names in manual_facts(model)["factory_reset"].items()}
    got = {option: sorted(table.spec(r).address for r in kept)
           for option, kept in table.vendor.reset_keeps.items()}
    assert got == want


# ---- the simulated servo ---------------------------------------------------------------------
def make_servo(model: str) -> SimServo:
    facts = manual_facts(model)
    baud_item = by_name(model, "Baud Rate" if not is_feetech(model) else "Baud rate")
    assert baud_item.default is not None
    return SimServo(table_for(model), 1, facts["baud_rates"][baud_item.default],
                    clock=SimulatedClock())


def read(servo: SimServo, item: Item) -> int:
    data = servo.read(item.address, item.size)
    assert data is not None, f"{item.id}: the read was refused"
    return decode(item, data)


def write(servo: SimServo, item: Item, value: int) -> int:
    return servo.write(item.address, encode(item, value))


def unlock(servo: SimServo, item: Item) -> None:
    """Make an EEPROM write possible: torque off (the default) and, on Feetech, Lock = 0."""
    if is_feetech(item.model) and item.eeprom:
        assert write(servo, by_name(item.model, "Lock flag"), 0) == 0


def valid_values(item: Item) -> list[int]:
    """The extreme values a write of the item may carry."""
    listed = enumerated(item)
    if listed is not None:
        values = [v for v in listed if not (item.model == "sts3215" and v == 128)]  # 128: a command
        return [min(values), max(values)]
    assert item.lo is not None and item.hi is not None
    return [item.lo, item.hi]


def invalid_values(item: Item) -> list[int]:
    """Values outside the manual's range (or enumeration) that the item's bytes can carry."""
    assert item.lo is not None and item.hi is not None
    lo, hi = WIDENED.get((item.model, item.name), (item.lo, item.hi))
    out = [v for v in (lo - 1, hi + 1) if fits(item, v)]
    listed = enumerated(item)
    if listed is not None and not is_feetech(item.model):
        # Dynamixel checks the value itself (e.g. Operating Mode 2 is no mode): the first gap.
        out += [v for v in range(min(listed), max(listed)) if v not in listed][:1]
    return out


def other_value(item: Item, current: int) -> int:
    """A valid value of the item that differs from ``current``."""
    if item.lo is None or item.hi is None:
        return current ^ 1
    return next(v for v in (*valid_values(item), item.lo, item.hi, current + 1, current - 1)
                if v != current and item.lo <= v <= item.hi
                and (enumerated(item) is None or v in (enumerated(item) or ())))


RW_WITH_DEFAULT = cases(lambda i: i.access == "RW" and i.default is not None)
RW_WITH_RANGE = cases(lambda i: i.access == "RW" and i.lo is not None)
RW_OUT_OF_RANGE = cases(lambda i: i.access == "RW" and i.lo is not None and bool(invalid_values(i)))
READ_ONLY = cases(lambda i: i.access == "R")
RW_EEPROM = cases(lambda i: i.access == "RW" and i.eeprom)


@pytest.mark.parametrize("item", RW_WITH_DEFAULT)
def test_sim_factory_reset_restores_default(item: Item) -> None:
    servo = make_servo(item.model)
    assert item.default is not None
    unlock(servo, item)
    changed = other_value(item, item.default)
    write(servo, item, changed)
    assert read(servo, item) == changed, f"{item.id}: the write of {changed} (before the reset)"
    servo.factory_reset()
    assert read(servo, item) == item.default


@pytest.mark.parametrize("item", RW_WITH_RANGE)
def test_sim_accepts_range_ends(item: Item) -> None:
    for value in valid_values(item):
        servo = make_servo(item.model)
        unlock(servo, item)
        assert write(servo, item, value) == 0, f"{item.id}: write of {value} refused"
        assert read(servo, item) == value, f"{item.id}: wrote {value}"


@pytest.mark.parametrize("item", RW_OUT_OF_RANGE)
def test_sim_refuses_out_of_range(item: Item) -> None:
    allowed = {RANGE_ERROR, ACCESS_ERROR} | ({LIMIT_ERROR} if item.name in LIMIT_BOUNDED else set())
    for value in invalid_values(item):
        servo = make_servo(item.model)
        unlock(servo, item)
        before = read(servo, item)
        err = write(servo, item, value)
        if is_feetech(item.model):
            assert err == 0, f"{item.id}: Feetech reports no write errors"
        else:
            assert err in allowed, f"{item.id}: write of {value} answered error {err}"
        assert read(servo, item) == before, f"{item.id}: write of {value} changed the item"


@pytest.mark.parametrize("item", cases(lambda i: i.access == "R" and i.default is not None))
def test_sim_read_only_item_reads_its_initial_value(item: Item) -> None:
    """A servo fresh from the factory, at rest: model number, status and flags as documented."""
    assert read(make_servo(item.model), item) == item.default


@pytest.mark.parametrize("item", READ_ONLY)
def test_sim_refuses_write_to_read_only(item: Item) -> None:
    servo = make_servo(item.model)
    data = servo.read(item.address, item.size)
    assert data is not None, f"{item.id}: the read was refused"
    flipped = bytes([data[0] ^ 0x01]) + data[1:]
    err = servo.write(item.address, flipped)
    if is_feetech(item.model):
        assert err == 0
    else:
        assert err == ACCESS_ERROR, f"{item.id}: answered error {err}"
    if item.name not in TIME_VARYING:
        assert servo.read(item.address, item.size) == data


@pytest.mark.parametrize("item", [c for c in RW_EEPROM if not is_feetech(c.values[0].model)])
def test_sim_refuses_eeprom_write_with_torque_on(item: Item) -> None:
    servo = make_servo(item.model)
    assert write(servo, by_name(item.model, "Torque Enable"), 1) == 0
    before = read(servo, item)
    assert write(servo, item, other_value(item, before)) == ACCESS_ERROR
    assert read(servo, item) == before


@pytest.mark.parametrize("item", [c for c in RW_EEPROM if is_feetech(c.values[0].model)])
def test_sim_locked_eeprom_write_is_not_kept(item: Item) -> None:
    """Lock = 1: "the value written to the EPROM address is not saved when power is off"."""
    servo = make_servo(item.model)
    assert write(servo, by_name(item.model, "Lock flag"), 1) == 0
    before = read(servo, item)
    assert write(servo, item, other_value(item, before)) == 0
    if read(servo, item) != before:  # applied until power off: a power cycle must undo it
        servo.reboot()
        assert read(servo, item) == before, f"{item.id}: a locked write outlived a reboot"
