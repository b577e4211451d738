"""Dynamixel X series: the family's conventions and control tables.

Every item of each model's control table (address, size, access, range, default, unit and the
maker's name) is transcribed from the ROBOTIS e-Manual control tables of the XL330-M077,
XL330-M288, XL430-W250, XM430-W350 and XM540-W270 (sections "Control Table of EEPROM Area"
and "Control Table of RAM Area"), with the e-Manual's item pages for what the tables leave
open: Operating Mode (values per model), Baud Rate (codes), Secondary ID (253-255 switch it
off, so a write of up to 255 is accepted), Bus Watchdog (0 switches it off, -1 reads back
after a watchdog stop), Startup Configuration and Backup Ready (firmware 45, XL330 46: the
tables are those of current firmware, so every model has both), and Protocol 2.0 "Factory
Reset" (which registers each option keeps). Negative values are two's complement.

The tables are built from rows common to the series plus per-model patches
(:data:`_X_MODELS`). Ranges that the manual gives relative to another register (Goal PWM
within +-PWM Limit, Goal Current within +-Current Limit, Goal Velocity within +-Velocity
Limit, Goal Position within the position limits) are recorded here as the widest value the
register can ever accept; the narrower live bound is the servo's behaviour, not the table's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from armctl.servo_tables.common import (
    Access,
    ControlTable,
    Encoding,
    Family,
    IndirectBlock,
    Register,
    RegisterSpec,
    Vendor,
)

__all__ = ["EEPROM_END", "RPM_UNIT", "TABLES", "VENDOR"]

RPM_UNIT = 0.229  # [rev/min] per velocity count (e-Manual "Velocity Limit")

#: First RAM address on every X-series model (Torque Enable).
EEPROM_END = 64

VENDOR = Vendor(
    family=Family.DYNAMIXEL, velocity_unit=RPM_UNIT / 60.0 * 4096,
    acceleration_unit=214.577 / 3600.0 * 4096, homing_sign=1, homing_limit=1024,
    eeprom_lock=False, reports_errors=True, position_mode=3, sets_mode=True,
    zero_limits_off=False, multi_turn_mode=4,
    position_limit_name="Position Limit", generic_model="xl430-w250",
    # e-Manual X series "Baud Rate"
    baud_codes={0: 9600, 1: 57_600, 2: 115_200, 3: 1_000_000, 4: 2_000_000, 5: 3_000_000,
                6: 4_000_000, 7: 4_500_000},
    # e-Manual Protocol 2.0 "Factory Reset": 0xFF all, 0x01 all but ID, 0x02 all but ID and
    # Baud Rate.
    reset_keeps={0xFF: (), 0x01: (Register.ID,), 0x02: (Register.ID, Register.BAUD_RATE)},
)

R, RW = Access.R, Access.RW
U = Encoding.UNSIGNED
TWOS = Encoding.TWOS_COMPLEMENT
_I16 = (-(2**15), 2**15 - 1)
_I32 = (-(2**31), 2**31 - 1)
_U32 = (0, 2**32 - 1)

_Row = tuple[Register, int, int, Access, int, int, int, Encoding, str, str]
# Indexed rows: register, index, address, size, access, lo, hi, default, unit, maker's name.
_IndexedRow = tuple[Register, int, int, int, Access, int, int, int, str, str]

# Rows every model of the series has. Columns: register, address, size, access, lo, hi,
# default, encoding, unit, maker's name. Per-model values are patched from _X_MODELS.
_X_COMMON: tuple[_Row, ...] = (
    # EEPROM area (writable only with Torque Enable 0)
    (Register.MODEL_NUMBER, 0, 2, R, 0, 65535, 0, U, "", "Model Number"),
    (Register.MODEL_INFORMATION, 2, 4, R, *_U32, 0, U, "", "Model Information"),
    (Register.FIRMWARE, 6, 1, R, 0, 255, 52, U, "", "Firmware Version"),
    (Register.ID, 7, 1, RW, 0, 252, 1, U, "", "ID"),
    (Register.BAUD_RATE, 8, 1, RW, 0, 7, 1, U, "code", "Baud Rate"),
    (Register.RETURN_DELAY, 9, 1, RW, 0, 254, 250, U, "2 us", "Return Delay Time"),
    (Register.DRIVE_MODE, 10, 1, RW, 0, 5, 0, U, "bits", "Drive Mode"),
    (Register.OPERATING_MODE, 11, 1, RW, 0, 16, 3, U, "", "Operating Mode"),
    (Register.SECONDARY_ID, 12, 1, RW, 0, 255, 255, U, "", "Secondary(Shadow) ID"),
    (Register.PROTOCOL_TYPE, 13, 1, RW, 1, 2, 2, U, "", "Protocol Type"),
    (Register.HOMING_OFFSET, 20, 4, RW, -1044479, 1044479, 0, TWOS, "tick", "Homing Offset"),
    (Register.MOVING_THRESHOLD, 24, 4, RW, 0, 1023, 10, U, "0.229 rpm", "Moving Threshold"),
    (Register.TEMPERATURE_LIMIT, 31, 1, RW, 0, 100, 80, U, "degC", "Temperature Limit"),
    (Register.MAX_VOLTAGE_LIMIT, 32, 2, RW, 95, 160, 160, U, "0.1 V", "Max Voltage Limit"),
    (Register.MIN_VOLTAGE_LIMIT, 34, 2, RW, 95, 160, 95, U, "0.1 V", "Min Voltage Limit"),
    (Register.PWM_LIMIT, 36, 2, RW, 0, 885, 885, U, "0.113 %", "PWM Limit"),
    (Register.CURRENT_LIMIT, 38, 2, RW, 0, 1193, 1193, U, "2.69 mA", "Current Limit"),
    (Register.VELOCITY_LIMIT, 44, 4, RW, 0, 1023, 200, U, "0.229 rpm", "Velocity Limit"),
    (Register.MAX_POSITION_LIMIT, 48, 4, RW, 0, 4095, 4095, U, "tick", "Max Position Limit"),
    (Register.MIN_POSITION_LIMIT, 52, 4, RW, 0, 4095, 0, U, "tick", "Min Position Limit"),
    (Register.STARTUP_CONFIGURATION, 60, 1, RW, 0, 3, 0, U, "bits", "Startup Configuration"),
    (Register.SHUTDOWN, 63, 1, RW, 0, 255, 52, U, "bits", "Shutdown"),
    # RAM area
    (Register.TORQUE_ENABLE, 64, 1, RW, 0, 1, 0, U, "", "Torque Enable"),
    (Register.LED, 65, 1, RW, 0, 1, 0, U, "", "LED"),
    (Register.STATUS_RETURN_LEVEL, 68, 1, RW, 0, 2, 2, U, "", "Status Return Level"),
    (Register.REGISTERED_INSTRUCTION, 69, 1, R, 0, 1, 0, U, "", "Registered Instruction"),
    (Register.HARDWARE_ERROR, 70, 1, R, 0, 255, 0, U, "bits", "Hardware Error Status"),
    (Register.VELOCITY_I_GAIN, 76, 2, RW, 0, 16383, 1920, U, "", "Velocity I Gain"),
    (Register.VELOCITY_P_GAIN, 78, 2, RW, 0, 16383, 100, U, "", "Velocity P Gain"),
    (Register.D_GAIN, 80, 2, RW, 0, 16383, 0, U, "", "Position D Gain"),
    (Register.I_GAIN, 82, 2, RW, 0, 16383, 0, U, "", "Position I Gain"),
    (Register.P_GAIN, 84, 2, RW, 0, 16383, 800, U, "", "Position P Gain"),
    (Register.FEEDFORWARD_2ND_GAIN, 88, 2, RW, 0, 16383, 0, U, "", "Feedforward 2nd Gain"),
    (Register.FEEDFORWARD_1ST_GAIN, 90, 2, RW, 0, 16383, 0, U, "", "Feedforward 1st Gain"),
    (Register.BUS_WATCHDOG, 98, 1, RW, 0, 127, 0, TWOS, "20 ms", "Bus Watchdog"),
    (Register.GOAL_PWM, 100, 2, RW, -885, 885, 0, TWOS, "0.113 %", "Goal PWM"),
    (Register.GOAL_CURRENT, 102, 2, RW, -1193, 1193, 0, TWOS, "2.69 mA", "Goal Current"),
    (Register.GOAL_VELOCITY, 104, 4, RW, -1023, 1023, 0, TWOS, "0.229 rpm", "Goal Velocity"),
    (Register.PROFILE_ACCELERATION, 108, 4, RW, 0, 32767, 0, U, "214.577 rpm2",
     "Profile Acceleration"),
    (Register.PROFILE_VELOCITY, 112, 4, RW, 0, 32767, 0, U, "0.229 rpm", "Profile Velocity"),
    (Register.GOAL_POSITION, 116, 4, RW, -1048575, 1048575, 0, TWOS, "tick", "Goal Position"),
    (Register.REALTIME_TICK, 120, 2, R, 0, 32767, 0, U, "ms", "Realtime Tick"),
    (Register.MOVING, 122, 1, R, 0, 1, 0, U, "", "Moving"),
    (Register.MOVING_STATUS, 123, 1, R, 0, 255, 0, U, "bits", "Moving Status"),
    (Register.PRESENT_PWM, 124, 2, R, *_I16, 0, TWOS, "0.113 %", "Present PWM"),
    (Register.PRESENT_LOAD, 126, 2, R, *_I16, 0, TWOS, "2.69 mA", "Present Current"),
    (Register.PRESENT_VELOCITY, 128, 4, R, *_I32, 0, TWOS, "0.229 rpm", "Present Velocity"),
    (Register.PRESENT_POSITION, 132, 4, R, *_I32, 0, TWOS, "tick", "Present Position"),
    (Register.VELOCITY_TRAJECTORY, 136, 4, R, *_I32, 0, TWOS, "0.229 rpm",
     "Velocity Trajectory"),
    (Register.POSITION_TRAJECTORY, 140, 4, R, *_I32, 0, TWOS, "tick", "Position Trajectory"),
    (Register.PRESENT_VOLTAGE, 144, 2, R, 0, 65535, 0, U, "0.1 V", "Present Input Voltage"),
    (Register.PRESENT_TEMPERATURE, 146, 1, R, 0, 255, 0, U, "degC", "Present Temperature"),
    (Register.BACKUP_READY, 147, 1, R, 0, 1, 0, U, "", "Backup Ready"),
)

# Indirect Address n / Indirect Data n: 20 slots on the XL330, 56 (in two blocks) on the
# X430/X540 models (e-Manual "Indirect Address, Indirect Data").
_INDIRECT_XL330 = (IndirectBlock(1, 20, 168, 208),)
_INDIRECT_X430 = (IndirectBlock(1, 28, 168, 224), IndirectBlock(29, 28, 578, 634))


@dataclass(frozen=True)
class _Patch:
    """A per-model change to a common row (``None``: keep the common value)."""

    lo: int | None = None
    hi: int | None = None
    default: int | None = None
    unit: str | None = None
    name: str | None = None
    values: tuple[int, ...] | None = None


@dataclass(frozen=True)
class _XModel:
    """What differs between the X-series models (e-Manual)."""

    model_number: int
    voltage: float  # nominal supply [V]
    rpm: float  # no-load speed at the nominal supply [rev/min]
    modes: tuple[int, ...]  # Operating Mode values
    indirect: tuple[IndirectBlock, ...]
    memory_size: int  # last address of the table + 1
    patches: dict[Register, _Patch]
    absent: frozenset[Register] = frozenset()
    extra: tuple[_Row, ...] = ()
    extra_indexed: tuple[_IndexedRow, ...] = ()


_XL330_PATCHES: dict[Register, _Patch] = {
    Register.BAUD_RATE: _Patch(hi=6),
    # 2 (Protocol 2.0), 20 (S.BUS), 21 (iBUS), 22 (RC-PWM)
    Register.PROTOCOL_TYPE: _Patch(lo=2, hi=22, values=(2, 20, 21, 22)),
    Register.TEMPERATURE_LIMIT: _Patch(default=70),
    Register.MAX_VOLTAGE_LIMIT: _Patch(lo=31, hi=70, default=70),
    Register.MIN_VOLTAGE_LIMIT: _Patch(lo=31, hi=70, default=35),
    Register.CURRENT_LIMIT: _Patch(hi=1750, default=1750, unit="1 mA"),
    Register.SHUTDOWN: _Patch(default=53),
    Register.GOAL_CURRENT: _Patch(lo=-1750, hi=1750, unit="1 mA"),
    Register.GOAL_VELOCITY: _Patch(lo=-2047, hi=2047),
    Register.PRESENT_LOAD: _Patch(unit="1 mA"),
}

# XL330 only: PWM Slope (EEPROM 62).
_PWM_SLOPE: _Row = (Register.PWM_SLOPE, 62, 1, RW, 1, 255, 140, U, "1.977 mV/ms", "PWM Slope")


def _xl330(model_number: int, rpm: float, velocity_limit: int, gains: tuple[int, int, int, int]
           ) -> _XModel:
    """An XL330 model: the XL330 patches plus its Velocity Limit and gains.

    ``gains`` are the defaults of Velocity I, Velocity P, Position I and Position P.
    """
    vi, vp, pi, pp = gains
    patches = dict(_XL330_PATCHES)
    patches.update({
        Register.VELOCITY_LIMIT: _Patch(hi=2047, default=velocity_limit),
        Register.VELOCITY_I_GAIN: _Patch(default=vi),
        Register.VELOCITY_P_GAIN: _Patch(default=vp),
        Register.I_GAIN: _Patch(default=pi),
        Register.P_GAIN: _Patch(default=pp),
    })
    return _XModel(model_number, 5.0, rpm, (0, 1, 3, 4, 5, 16), _INDIRECT_XL330, 228, patches,
                   extra=(_PWM_SLOPE,))


_X_MODELS: dict[str, _XModel] = {
    # e-Manual XL330-M077-T
    "xl330-m077": _xl330(1190, 383.0, 1620, (400, 40, 400, 400)),
    # e-Manual XL330-M288-T
    "xl330-m288": _xl330(1200, 103.0, 445, (1600, 180, 0, 400)),
    # e-Manual XL430-W250-T: no current sensing (Present Load, no Current Limit/Goal Current).
    "xl430-w250": _XModel(
        1060, 11.1, 57.0, (1, 3, 4, 16), _INDIRECT_X430, 662,
        {Register.DRIVE_MODE: _Patch(hi=13),  # bit 3 too (Torque On by Goal Update)
         Register.TEMPERATURE_LIMIT: _Patch(default=72),
         Register.MAX_VOLTAGE_LIMIT: _Patch(lo=60, hi=140, default=140),
         Register.MIN_VOLTAGE_LIMIT: _Patch(lo=60, hi=140, default=60),
         Register.VELOCITY_LIMIT: _Patch(default=265),
         Register.VELOCITY_I_GAIN: _Patch(default=1000),
         Register.D_GAIN: _Patch(default=4000),
         Register.P_GAIN: _Patch(default=640),
         Register.PRESENT_LOAD: _Patch(lo=-1000, hi=1000, unit="0.1 %", name="Present Load")},
        absent=frozenset({Register.CURRENT_LIMIT, Register.GOAL_CURRENT})),
    # e-Manual XM430-W350-T/R
    "xm430-w350": _XModel(1020, 12.0, 46.0, (0, 1, 3, 4, 5, 16), _INDIRECT_X430, 662, {}),
    # e-Manual XM540-W270-T/R: three external ports.
    "xm540-w270": _XModel(
        1120, 12.0, 30.0, (0, 1, 3, 4, 5, 16), _INDIRECT_X430, 662,
        {Register.CURRENT_LIMIT: _Patch(hi=2047, default=2047),
         Register.GOAL_CURRENT: _Patch(lo=-2047, hi=2047),
         Register.VELOCITY_LIMIT: _Patch(default=128)},
        extra_indexed=(
            *((Register.EXTERNAL_PORT_MODE, n, 55 + n, 1, RW, 0, 3, 3, "",
               f"External Port Mode {n}") for n in (1, 2, 3)),
            *((Register.EXTERNAL_PORT_DATA, n, 150 + 2 * n, 2, RW, 0, 65535, 0, "",
               f"External Port Data {n}") for n in (1, 2, 3)),
        )),
}


def _patched(row: _Row, patch: _Patch | None) -> RegisterSpec:
    reg, addr, size, acc, lo, hi, default, enc, unit, name = row
    spec = RegisterSpec(reg, addr, size, acc, lo, hi, default, enc, 31, unit, name)
    if patch is None:
        return spec
    return replace(
        spec,
        lo=spec.lo if patch.lo is None else patch.lo,
        hi=spec.hi if patch.hi is None else patch.hi,
        default=spec.default if patch.default is None else patch.default,
        unit=spec.unit if patch.unit is None else patch.unit,
        name=spec.name if patch.name is None else patch.name,
        values=spec.values if patch.values is None else patch.values,
    )


def _indirect_items(blocks: tuple[IndirectBlock, ...], top: int) -> list[RegisterSpec]:
    """Indirect Address n (default: the address of Indirect Data n) and Indirect Data n."""
    items = []
    for block in blocks:
        for index in range(block.first_index, block.first_index + block.count):
            data = block.data_of(index)
            items.append(RegisterSpec(Register.INDIRECT_ADDRESS, block.address_of(index), 2, RW,
                                      EEPROM_END, top, data, U, 31, "address",
                                      f"Indirect Address {index}", index))
            items.append(RegisterSpec(Register.INDIRECT_DATA, data, 1, RW, 0, 255, 0, U, 31, "",
                                      f"Indirect Data {index}", index))
    return items


def _x_series(model: str) -> ControlTable:
    info = _X_MODELS[model]
    regs: dict[Register, RegisterSpec] = {}
    for row in (*_X_COMMON, *info.extra):
        if row[0] in info.absent:
            continue
        spec = _patched(row, info.patches.get(row[0]))
        if spec.register is Register.MODEL_NUMBER:
            spec = replace(spec, default=info.model_number)
        if spec.register is Register.OPERATING_MODE:
            spec = replace(spec, values=info.modes)
        regs[spec.register] = spec
    items = list(regs.values())
    items += _indirect_items(info.indirect, info.memory_size - 1)
    for reg, index, addr, size, acc, lo, hi, default, unit, name in info.extra_indexed:
        items.append(RegisterSpec(reg, addr, size, acc, lo, hi, default, U, 31, unit, name,
                                  index))
    return ControlTable(
        model=model, model_number=info.model_number, vendor=VENDOR, registers=regs,
        eeprom_end=EEPROM_END, memory_size=info.memory_size, nominal_voltage=info.voltage,
        max_speed=info.rpm / 60.0 * 4096, operating_modes=info.modes,
        items=tuple(sorted(items, key=lambda s: s.address)), indirect=info.indirect,
    )


TABLES: dict[str, ControlTable] = {m: _x_series(m) for m in _X_MODELS}
