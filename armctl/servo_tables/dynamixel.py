"""Dynamixel X series: the family's conventions and control tables.

Addresses, sizes, access, ranges and defaults are transcribed from the ROBOTIS e-Manual pages
``docs/en/dxl/x/xl330-m288.md``, ``xl430-w250.md``, ``xm430-w350.md`` (control table sections),
cross-checked with LeRobot ``motors/dynamixel/tables.py`` (``X_SERIES_CONTROL_TABLE``). Negative
values are two's complement.
"""

from __future__ import annotations

from dataclasses import dataclass

from armctl.servo_tables.common import (
    Access,
    ControlTable,
    Encoding,
    Family,
    Register,
    RegisterSpec,
    Vendor,
)

__all__ = ["RPM_UNIT", "TABLES", "VENDOR"]

RPM_UNIT = 0.229  # [rev/min] per velocity count (e-Manual "Velocity Limit")

VENDOR = Vendor(
    family=Family.DYNAMIXEL, velocity_unit=RPM_UNIT / 60.0 * 4096,
    acceleration_unit=214.577 / 3600.0 * 4096, homing_sign=1, homing_limit=1024,
    eeprom_lock=False, reports_errors=True, position_mode=3, sets_mode=True,
    zero_limits_off=False, multi_turn_mode=4,
    position_limit_name="Position Limit", generic_model="xl430-w250",
    # e-Manual X series "Baud Rate"
    baud_codes={0: 9600, 1: 57_600, 2: 115_200, 3: 1_000_000, 4: 2_000_000, 5: 3_000_000,
                6: 4_000_000, 7: 4_500_000},
)

R, RW = Access.R, Access.RW
TWOS = Encoding.TWOS_COMPLEMENT
_I32 = (-(2**31), 2**31 - 1)

# Dynamixel X series (e-Manual control tables). Columns: register, address, size, access, lo, hi,
# default, encoding, unit. Per-model values are patched in _x_series() below.
_X_COMMON: tuple[tuple[Register, int, int, Access, int, int, int, Encoding, str], ...] = (
    (Register.MODEL_NUMBER, 0, 2, R, 0, 65535, 0, Encoding.UNSIGNED, ""),
    (Register.FIRMWARE, 6, 1, R, 0, 255, 52, Encoding.UNSIGNED, ""),
    (Register.ID, 7, 1, RW, 0, 252, 1, Encoding.UNSIGNED, ""),
    (Register.BAUD_RATE, 8, 1, RW, 0, 7, 1, Encoding.UNSIGNED, "code"),
    (Register.RETURN_DELAY, 9, 1, RW, 0, 254, 250, Encoding.UNSIGNED, "2 us"),
    (Register.DRIVE_MODE, 10, 1, RW, 0, 13, 0, Encoding.UNSIGNED, ""),
    (Register.OPERATING_MODE, 11, 1, RW, 0, 16, 3, Encoding.UNSIGNED, ""),
    (Register.HOMING_OFFSET, 20, 4, RW, -1044479, 1044479, 0, TWOS, "tick"),
    (Register.TEMPERATURE_LIMIT, 31, 1, RW, 0, 100, 80, Encoding.UNSIGNED, "degC"),
    (Register.MAX_VOLTAGE_LIMIT, 32, 2, RW, 31, 160, 160, Encoding.UNSIGNED, "0.1 V"),
    (Register.MIN_VOLTAGE_LIMIT, 34, 2, RW, 31, 160, 95, Encoding.UNSIGNED, "0.1 V"),
    (Register.VELOCITY_LIMIT, 44, 4, RW, 0, 2047, 200, Encoding.UNSIGNED, "0.229 rpm"),
    (Register.MAX_POSITION_LIMIT, 48, 4, RW, 0, 4095, 4095, Encoding.UNSIGNED, "tick"),
    (Register.MIN_POSITION_LIMIT, 52, 4, RW, 0, 4095, 0, Encoding.UNSIGNED, "tick"),
    (Register.SHUTDOWN, 63, 1, RW, 0, 255, 52, Encoding.UNSIGNED, "bits"),
    (Register.TORQUE_ENABLE, 64, 1, RW, 0, 1, 0, Encoding.UNSIGNED, ""),
    (Register.LED, 65, 1, RW, 0, 1, 0, Encoding.UNSIGNED, ""),
    (Register.STATUS_RETURN_LEVEL, 68, 1, RW, 0, 2, 2, Encoding.UNSIGNED, ""),
    (Register.REGISTERED_INSTRUCTION, 69, 1, R, 0, 1, 0, Encoding.UNSIGNED, ""),
    (Register.HARDWARE_ERROR, 70, 1, R, 0, 255, 0, Encoding.UNSIGNED, "bits"),
    (Register.D_GAIN, 80, 2, RW, 0, 16383, 0, Encoding.UNSIGNED, ""),
    (Register.I_GAIN, 82, 2, RW, 0, 16383, 0, Encoding.UNSIGNED, ""),
    (Register.P_GAIN, 84, 2, RW, 0, 16383, 800, Encoding.UNSIGNED, ""),
    (Register.GOAL_VELOCITY, 104, 4, RW, -2047, 2047, 0, TWOS, "0.229 rpm"),
    (Register.PROFILE_ACCELERATION, 108, 4, RW, 0, 32767, 0, Encoding.UNSIGNED, "214.577 rpm2"),
    (Register.PROFILE_VELOCITY, 112, 4, RW, 0, 32767, 0, Encoding.UNSIGNED, "0.229 rpm"),
    (Register.GOAL_POSITION, 116, 4, RW, -1048575, 1048575, 0, TWOS, "tick"),
    (Register.MOVING, 122, 1, R, 0, 1, 0, Encoding.UNSIGNED, ""),
    (Register.PRESENT_LOAD, 126, 2, R, -32768, 32767, 0, TWOS, "0.1 %"),
    (Register.PRESENT_VELOCITY, 128, 4, R, *_I32, 0, TWOS, "0.229 rpm"),
    (Register.PRESENT_POSITION, 132, 4, R, *_I32, 0, TWOS, "tick"),
    (Register.PRESENT_VOLTAGE, 144, 2, R, 0, 65535, 0, Encoding.UNSIGNED, "0.1 V"),
    (Register.PRESENT_TEMPERATURE, 146, 1, R, 0, 255, 0, Encoding.UNSIGNED, "degC"),
)

# Per-model differences (e-Manual): model number, limits, gains, load unit, speed, voltage.
@dataclass(frozen=True)
class _XModel:
    """What differs between the X-series models (e-Manual)."""

    model_number: int
    voltage: float  # nominal supply [V]
    rpm: float  # no-load speed at the nominal supply [rev/min]
    defaults: dict[Register, int]
    load_unit: str  # Present Load (0.1 %) or Present Current (mA) at address 126
    modes: tuple[int, ...]  # Operating Mode values
    baud_max: int  # highest Baud Rate code


_X_MODELS: dict[str, _XModel] = {
    "xl330-m288": _XModel(
        1200, 5.0, 103.0,
        {Register.TEMPERATURE_LIMIT: 70, Register.MAX_VOLTAGE_LIMIT: 70,
         Register.MIN_VOLTAGE_LIMIT: 35, Register.VELOCITY_LIMIT: 445, Register.SHUTDOWN: 53,
         Register.P_GAIN: 400, Register.D_GAIN: 0},
        "1 mA", (0, 1, 3, 4, 5, 16), 6),
    "xl430-w250": _XModel(
        1060, 11.1, 57.0,
        {Register.TEMPERATURE_LIMIT: 72, Register.MAX_VOLTAGE_LIMIT: 140,
         Register.MIN_VOLTAGE_LIMIT: 60, Register.VELOCITY_LIMIT: 265, Register.P_GAIN: 640,
         Register.D_GAIN: 4000},
        "0.1 %", (1, 3, 4, 16), 7),
    "xm430-w350": _XModel(
        1020, 12.0, 46.0,
        {Register.TEMPERATURE_LIMIT: 80, Register.VELOCITY_LIMIT: 200, Register.P_GAIN: 800,
         Register.D_GAIN: 0},
        "2.69 mA", (0, 1, 3, 4, 5, 16), 7),
}

def _x_series(model: str) -> ControlTable:
    info = _X_MODELS[model]
    regs: dict[Register, RegisterSpec] = {}
    for reg, addr, size, acc, lo, hi, default, enc, unit in _X_COMMON:
        if reg is Register.MODEL_NUMBER:
            default = info.model_number
        if reg is Register.BAUD_RATE:
            hi = info.baud_max
        if reg is Register.PRESENT_LOAD:
            unit = info.load_unit
        regs[reg] = RegisterSpec(reg, addr, size, acc, lo, hi, info.defaults.get(reg, default),
                                 enc, 31, unit)
    return ControlTable(
        model=model, model_number=info.model_number, vendor=VENDOR, registers=regs,
        eeprom_end=64, memory_size=228, nominal_voltage=info.voltage,
        max_speed=info.rpm / 60.0 * 4096, operating_modes=info.modes,
    )


TABLES: dict[str, ControlTable] = {m: _x_series(m) for m in _X_MODELS}
