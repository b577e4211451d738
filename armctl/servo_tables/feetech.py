"""Feetech STS: the family's conventions and control tables.

The STS3215 memory table is transcribed from Feetech's STS memory table (the "SMS/STS
memory table" of the Feetech STS user manual: addresses, sizes, access, ranges, initial
values, units and which area each address is in: EPROM 0-39 behind the Lock flag, SRAM
40-70, factory parameters from 80) and the official SDK's ``SMS_STS`` address constants
(FTServo ``sms_sts.py`` / ``SMS_STS.h``). Item names are the ones LeRobot's
``STS_SMS_SERIES_CONTROL_TABLE`` gives them (``Torque_Limit``, ``Maximum_Acceleration``...),
which clients ask for by name; the factory-parameter items (80-86) are known only by those
names, and their initial values are not published (recorded here as 0). Negative values are
sign-magnitude (one sign bit: 15 for positions and speeds, 11 for the offset, 10 for the
load and for Goal_Time, which carries the duty in PWM mode: the SDK's ``WritePWM`` sets bit
10).

Where the memory table's range column and its notes disagree, the notes win: Max_Position_Limit
takes 0 (with a minimum of 0, multi-turn operation) although the column starts at 1;
Operating_Mode takes 3 (step mode) although the column stops at 2; Torque_Enable takes 128;
Goal_Velocity is signed like Goal_Position (bit 15). Lock reads 1 at power-up (the table's
initial value column says 0; servos report 1 until the host clears it).
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

__all__ = ["EEPROM_END", "TABLES", "VENDOR"]

#: First SRAM address (Torque_Enable); below it is the EPROM, written only with Lock 0.
EEPROM_END = 40

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
U = Encoding.UNSIGNED
SM = Encoding.SIGN_MAGNITUDE

# Feetech STS3215 memory table. Columns: register, address, size, access, lo, hi, default,
# encoding, sign bit, unit, name.
_STS3215: tuple[tuple[Register, int, int, Access, int, int, int, Encoding, int, str, str],
                ...] = (
    # Version information (read-only)
    (Register.FIRMWARE, 0, 1, R, 0, 255, 3, U, 15, "", "Firmware_Major_Version"),
    (Register.FIRMWARE_MINOR, 1, 1, R, 0, 255, 10, U, 15, "", "Firmware_Minor_Version"),
    (Register.BYTE_ORDER, 2, 1, R, 0, 1, 0, U, 15, "", "END"),
    (Register.MODEL_NUMBER, 3, 2, R, 0, 65535, 777, U, 15, "", "Model_Number"),
    # EPROM (written only with Lock 0; kept through power cycles)
    (Register.ID, 5, 1, RW, 0, 253, 1, U, 15, "", "ID"),
    (Register.BAUD_RATE, 6, 1, RW, 0, 7, 0, U, 15, "code", "Baud_Rate"),
    (Register.RETURN_DELAY, 7, 1, RW, 0, 254, 0, U, 15, "2 us", "Return_Delay_Time"),
    (Register.STATUS_RETURN_LEVEL, 8, 1, RW, 0, 1, 1, U, 15, "", "Response_Status_Level"),
    (Register.MIN_POSITION_LIMIT, 9, 2, RW, 0, 4094, 0, U, 15, "tick", "Min_Position_Limit"),
    (Register.MAX_POSITION_LIMIT, 11, 2, RW, 0, 4095, 4095, U, 15, "tick",
     "Max_Position_Limit"),
    (Register.TEMPERATURE_LIMIT, 13, 1, RW, 0, 100, 70, U, 15, "degC", "Max_Temperature_Limit"),
    (Register.MAX_VOLTAGE_LIMIT, 14, 1, RW, 0, 254, 80, U, 15, "0.1 V", "Max_Voltage_Limit"),
    (Register.MIN_VOLTAGE_LIMIT, 15, 1, RW, 0, 254, 40, U, 15, "0.1 V", "Min_Voltage_Limit"),
    (Register.MAX_TORQUE, 16, 2, RW, 0, 1000, 1000, U, 15, "0.1 %", "Max_Torque_Limit"),
    (Register.PHASE, 18, 1, RW, 0, 254, 12, U, 15, "bits", "Phase"),
    (Register.UNLOADING_CONDITION, 19, 1, RW, 0, 254, 44, U, 15, "bits", "Unloading_Condition"),
    (Register.LED_ALARM_CONDITION, 20, 1, RW, 0, 254, 47, U, 15, "bits", "LED_Alarm_Condition"),
    (Register.P_GAIN, 21, 1, RW, 0, 254, 32, U, 15, "", "P_Coefficient"),
    (Register.D_GAIN, 22, 1, RW, 0, 254, 32, U, 15, "", "D_Coefficient"),
    (Register.I_GAIN, 23, 1, RW, 0, 254, 0, U, 15, "", "I_Coefficient"),
    (Register.MIN_STARTUP_FORCE, 24, 2, RW, 0, 1000, 16, U, 15, "0.1 %",
     "Minimum_Startup_Force"),
    (Register.CW_DEAD_ZONE, 26, 1, RW, 0, 32, 1, U, 15, "tick", "CW_Dead_Zone"),
    (Register.CCW_DEAD_ZONE, 27, 1, RW, 0, 32, 1, U, 15, "tick", "CCW_Dead_Zone"),
    (Register.PROTECTION_CURRENT, 28, 2, RW, 0, 511, 500, U, 15, "6.5 mA",
     "Protection_Current"),
    (Register.ANGULAR_RESOLUTION, 30, 1, RW, 1, 100, 1, U, 15, "", "Angular_Resolution"),
    (Register.HOMING_OFFSET, 31, 2, RW, -2047, 2047, 0, SM, 11, "tick", "Homing_Offset"),
    (Register.OPERATING_MODE, 33, 1, RW, 0, 3, 0, U, 15, "", "Operating_Mode"),
    (Register.PROTECTIVE_TORQUE, 34, 1, RW, 0, 254, 20, U, 15, "1 %", "Protective_Torque"),
    (Register.PROTECTION_TIME, 35, 1, RW, 0, 254, 200, U, 15, "10 ms", "Protection_Time"),
    (Register.OVERLOAD_TORQUE, 36, 1, RW, 0, 254, 80, U, 15, "1 %", "Overload_Torque"),
    (Register.VELOCITY_P_GAIN, 37, 1, RW, 0, 254, 10, U, 15, "",
     "Velocity_closed_loop_P_proportional_coefficient"),
    (Register.OVERCURRENT_PROTECTION_TIME, 38, 1, RW, 0, 254, 200, U, 15, "10 ms",
     "Over_Current_Protection_Time"),
    (Register.VELOCITY_I_GAIN, 39, 1, RW, 0, 254, 10, U, 15, "",
     "Velocity_closed_loop_I_integral_coefficient"),
    # SRAM control (lost at power-off)
    (Register.TORQUE_ENABLE, 40, 1, RW, 0, 128, 0, U, 15, "", "Torque_Enable"),
    (Register.PROFILE_ACCELERATION, 41, 1, RW, 0, 254, 0, U, 15, "100 tick/s2", "Acceleration"),
    (Register.GOAL_POSITION, 42, 2, RW, -32766, 32766, 0, SM, 15, "tick", "Goal_Position"),
    (Register.GOAL_TIME, 44, 2, RW, -1000, 1000, 0, SM, 10, "0.1 %", "Goal_Time"),
    (Register.PROFILE_VELOCITY, 46, 2, RW, -32766, 32766, 0, SM, 15, "tick/s", "Goal_Velocity"),
    (Register.TORQUE_LIMIT, 48, 2, RW, 0, 1000, 1000, U, 15, "0.1 %", "Torque_Limit"),
    (Register.LOCK, 55, 1, RW, 0, 1, 1, U, 15, "", "Lock"),
    # SRAM feedback (read-only)
    (Register.PRESENT_POSITION, 56, 2, R, -32767, 32767, 0, SM, 15, "tick", "Present_Position"),
    (Register.PRESENT_VELOCITY, 58, 2, R, -32767, 32767, 0, SM, 15, "tick/s",
     "Present_Velocity"),
    (Register.PRESENT_LOAD, 60, 2, R, -1023, 1023, 0, SM, 10, "0.1 %", "Present_Load"),
    (Register.PRESENT_VOLTAGE, 62, 1, R, 0, 255, 0, U, 15, "0.1 V", "Present_Voltage"),
    (Register.PRESENT_TEMPERATURE, 63, 1, R, 0, 255, 0, U, 15, "degC", "Present_Temperature"),
    (Register.REGISTERED_INSTRUCTION, 64, 1, R, 0, 1, 0, U, 15, "", "Sync_Write_Flag"),
    (Register.HARDWARE_ERROR, 65, 1, R, 0, 255, 0, U, 15, "bits", "Status"),
    (Register.MOVING, 66, 1, R, 0, 1, 0, U, 15, "", "Moving"),
    (Register.PRESENT_CURRENT, 69, 2, R, 0, 65535, 0, U, 15, "6.5 mA", "Present_Current"),
    # Factory parameters
    (Register.MOVING_THRESHOLD, 80, 1, RW, 0, 254, 0, U, 15, "", "Moving_Velocity_Threshold"),
    (Register.DTS, 81, 1, RW, 0, 254, 0, U, 15, "ms", "DTs"),
    (Register.VELOCITY_UNIT_FACTOR, 82, 1, RW, 0, 254, 0, U, 15, "", "Velocity_Unit_factor"),
    (Register.HTS, 83, 1, RW, 0, 254, 0, U, 15, "ns", "Hts"),
    (Register.MAX_VELOCITY_LIMIT, 84, 1, RW, 0, 254, 0, U, 15, "", "Maximum_Velocity_Limit"),
    (Register.MAX_ACCELERATION, 85, 1, RW, 0, 254, 0, U, 15, "", "Maximum_Acceleration"),
    (Register.ACCELERATION_MULTIPLIER, 86, 1, RW, 0, 254, 0, U, 15, "",
     "Acceleration_Multiplier"),
)


# Items whose range has holes: Torque_Enable takes 0 (off), 1 (on), 2 (damping) and 128
# (make the present position 2048).
_VALUES: dict[Register, tuple[int, ...]] = {Register.TORQUE_ENABLE: (0, 1, 2, 128)}


def _sts3215() -> ControlTable:
    regs = {row[0]: RegisterSpec(*row, values=_VALUES.get(row[0], ())) for row in _STS3215}
    return ControlTable(
        model="sts3215", model_number=777, vendor=VENDOR, registers=regs,
        eeprom_end=EEPROM_END, memory_size=87, nominal_voltage=7.4,
        max_speed=45.0 / 60.0 * 4096, operating_modes=(0, 1, 2, 3),
    )


TABLES: dict[str, ControlTable] = {"sts3215": _sts3215()}
