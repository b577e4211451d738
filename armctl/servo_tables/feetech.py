"""Feetech STS: the family's conventions and control tables.

The STS3215 table is transcribed from the official ``SMS_STS.h`` memory table
(ftservo/FTServo_Arduino) and LeRobot ``motors/feetech/tables.py``
(``STS_SMS_SERIES_CONTROL_TABLE``, sign bits from LeRobot PR #2223). Negative values are
sign-magnitude (one sign bit).
"""

from __future__ import annotations

from armctl.servo_tables.common import (
    Access,
    ControlTable,
    Encoding,
    Family,
    Register,
    RegisterSpec,
    Vendor,
)

__all__ = ["TABLES", "VENDOR"]

VENDOR = Vendor(
    family=Family.FEETECH, velocity_unit=1.0, acceleration_unit=100.0, homing_sign=-1,
    homing_limit=2047, eeprom_lock=True, reports_errors=False, position_mode=0, sets_mode=False,
    zero_limits_off=True,
    multi_turn_mode=None, position_limit_name="Angle Limit", generic_model="sts3215",
    # Feetech official INST.h / sms_sts.py
    baud_codes={0: 1_000_000, 1: 500_000, 2: 250_000, 3: 128_000, 4: 115_200, 5: 76_800,
                6: 57_600, 7: 38_400},
)

R, RW = Access.R, Access.RW
SM = Encoding.SIGN_MAGNITUDE

# Feetech STS3215 (official SMS_STS.h; LeRobot STS_SMS_SERIES_CONTROL_TABLE; sign bits PR #2223).
_STS3215: tuple[tuple[Register, int, int, Access, int, int, int, Encoding, int, str], ...] = (
    (Register.FIRMWARE, 0, 1, R, 0, 255, 3, Encoding.UNSIGNED, 15, ""),
    (Register.FIRMWARE_MINOR, 1, 1, R, 0, 255, 10, Encoding.UNSIGNED, 15, ""),
    (Register.MODEL_NUMBER, 3, 2, R, 0, 65535, 777, Encoding.UNSIGNED, 15, ""),
    (Register.ID, 5, 1, RW, 0, 253, 1, Encoding.UNSIGNED, 15, ""),
    (Register.BAUD_RATE, 6, 1, RW, 0, 7, 0, Encoding.UNSIGNED, 15, "code"),
    (Register.RETURN_DELAY, 7, 1, RW, 0, 254, 0, Encoding.UNSIGNED, 15, "2 us"),
    (Register.STATUS_RETURN_LEVEL, 8, 1, RW, 0, 1, 1, Encoding.UNSIGNED, 15, ""),
    (Register.MIN_POSITION_LIMIT, 9, 2, RW, 0, 4095, 0, Encoding.UNSIGNED, 15, "tick"),
    (Register.MAX_POSITION_LIMIT, 11, 2, RW, 0, 4095, 4095, Encoding.UNSIGNED, 15, "tick"),
    (Register.TEMPERATURE_LIMIT, 13, 1, RW, 0, 100, 70, Encoding.UNSIGNED, 15, "degC"),
    (Register.MAX_VOLTAGE_LIMIT, 14, 1, RW, 0, 254, 80, Encoding.UNSIGNED, 15, "0.1 V"),
    (Register.MIN_VOLTAGE_LIMIT, 15, 1, RW, 0, 254, 40, Encoding.UNSIGNED, 15, "0.1 V"),
    (Register.MAX_TORQUE, 16, 2, RW, 0, 1000, 1000, Encoding.UNSIGNED, 15, "0.1 %"),
    (Register.PHASE, 18, 1, RW, 0, 255, 12, Encoding.UNSIGNED, 15, "bits"),
    (Register.P_GAIN, 21, 1, RW, 0, 254, 32, Encoding.UNSIGNED, 15, ""),
    (Register.D_GAIN, 22, 1, RW, 0, 254, 32, Encoding.UNSIGNED, 15, ""),
    (Register.I_GAIN, 23, 1, RW, 0, 254, 0, Encoding.UNSIGNED, 15, ""),
    (Register.HOMING_OFFSET, 31, 2, RW, -2047, 2047, 0, SM, 11, "tick"),
    (Register.OPERATING_MODE, 33, 1, RW, 0, 3, 0, Encoding.UNSIGNED, 15, ""),
    (Register.TORQUE_ENABLE, 40, 1, RW, 0, 128, 0, Encoding.UNSIGNED, 15, ""),
    (Register.PROFILE_ACCELERATION, 41, 1, RW, 0, 254, 0, Encoding.UNSIGNED, 15, "100 tick/s2"),
    (Register.GOAL_POSITION, 42, 2, RW, -32767, 32767, 0, SM, 15, "tick"),
    (Register.GOAL_TIME, 44, 2, RW, 0, 65535, 0, Encoding.UNSIGNED, 15, "ms"),
    (Register.PROFILE_VELOCITY, 46, 2, RW, -32767, 32767, 0, SM, 15, "tick/s"),
    (Register.LOCK, 55, 1, RW, 0, 1, 1, Encoding.UNSIGNED, 15, ""),
    (Register.PRESENT_POSITION, 56, 2, R, -32767, 32767, 0, SM, 15, "tick"),
    (Register.PRESENT_VELOCITY, 58, 2, R, -32767, 32767, 0, SM, 15, "tick/s"),
    (Register.PRESENT_LOAD, 60, 2, R, -1023, 1023, 0, SM, 10, "0.1 %"),
    (Register.PRESENT_VOLTAGE, 62, 1, R, 0, 255, 0, Encoding.UNSIGNED, 15, "0.1 V"),
    (Register.PRESENT_TEMPERATURE, 63, 1, R, 0, 255, 0, Encoding.UNSIGNED, 15, "degC"),
    (Register.REGISTERED_INSTRUCTION, 64, 1, R, 0, 1, 0, Encoding.UNSIGNED, 15, ""),
    (Register.HARDWARE_ERROR, 65, 1, R, 0, 255, 0, Encoding.UNSIGNED, 15, "bits"),
    (Register.MOVING, 66, 1, R, 0, 1, 0, Encoding.UNSIGNED, 15, ""),
    (Register.PRESENT_CURRENT, 69, 2, R, 0, 65535, 0, Encoding.UNSIGNED, 15, "6.5 mA"),
)


def _sts3215() -> ControlTable:
    regs = {row[0]: RegisterSpec(*row) for row in _STS3215}
    return ControlTable(
        model="sts3215", model_number=777, vendor=VENDOR, registers=regs, eeprom_end=40,
        memory_size=87, nominal_voltage=7.4, max_speed=45.0 / 60.0 * 4096, operating_modes=(0,),
    )


TABLES: dict[str, ControlTable] = {"sts3215": _sts3215()}
