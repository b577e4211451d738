"""How a simulated Dynamixel X-series servo behaves (Protocol 2.0, and the 1.0 variant).

On the wire, in its operating modes and in how its Present Position counts turns.

Sources: ROBOTIS e-Manual "Protocol 2.0" (status error numbers, Status Return Level, Ping
parameters, Factory Reset options, Clear, Control Table Backup, Fast Sync/Bulk Read),
"Protocol 1.0" (status error bits, Reset without options) and the X-series control table pages
(Torque Enable locks the EEPROM area; Goal Position within the Position Limits in Position
Control Mode; Goal Velocity/PWM/Current within their limits; a Bus Watchdog error makes the goal
values read-only; Shutdown; Startup Configuration; Backup Ready; Operating Mode numbers; Drive
Mode bits; the gain conversions KPP = P/128, KPI = I/65536, KPD = D/16, KFF = FF/4, KVP = P/128,
KVI = I/65536; Present Position). What each Factory Reset option keeps is table data
(``Vendor.reset_keeps``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from armctl.servo.sim.motor import Command, ControlMode
from armctl.servo.sim.rules import (
    ACTION,
    BULK_READ,
    BULK_WRITE,
    CLEAR,
    CONTROL_TABLE_BACKUP,
    ERR_ACCESS,
    ERR_CRC,
    ERR_INSTRUCTION,
    ERR_LIMIT,
    ERR_RANGE,
    ERR_RESULT_FAIL,
    FACTORY_RESET,
    FAST_BULK_READ,
    FAST_SYNC_READ,
    PING,
    READ,
    REG_WRITE,
    SYNC_READ,
    SYNC_WRITE,
    WRITE,
    ServoRules,
    ServoState,
)
from armctl.servo.sim.wire import Protocol1Wire, Protocol2Wire, Wire
from armctl.servo_tables import ControlTable, Register, RegisterSpec
from armctl.servo_tables.motors import MotorSpec

__all__ = ["DynamixelProtocol1Rules", "DynamixelRules"]

_READS = frozenset({READ, SYNC_READ, FAST_SYNC_READ, BULK_READ, FAST_BULK_READ})
_MULTI_TURN_MODES = (4, 5)  # extended position, current-based position (e-Manual Operating Mode)
_POSITION_MODE = 3  # Position Control Mode (single turn)
#: Operating Mode (e-Manual X series "Operating Mode") -> what the controller does.
_MODES = {0: ControlMode.CURRENT, 1: ControlMode.VELOCITY, 3: ControlMode.POSITION,
          4: ControlMode.EXTENDED_POSITION, 5: ControlMode.CURRENT_POSITION, 16: ControlMode.PWM}
_REVERSE, _TIME_BASED = 0x01, 0x04  # Drive Mode bits 0 and 2
# Simulator scaling of the velocity loop (the e-Manual gives the gain conversions, not the units
# of the controller's inputs): velocity PI output per (KVP x velocity error in 0.229 rpm).
_VELOCITY_SCALE = 16.0
_MOVING_THRESHOLD = 10  # Moving Threshold's factory value, for models without the register
_CLEAR_MULTI_TURN = b"\x01\x44\x58\x4c\x22"  # e-Manual Clear: option 0x01 and its fixed values
_BACKUP_KEY = b"\x43\x54\x52\x4c"  # "CTRL", e-Manual Control Table Backup
_BACKUP_STORE, _BACKUP_RESTORE = 0x01, 0x02
_RESET_ALL = 0xFF  # Factory Reset option "reset all" (the others keep the ID, and the baud rate)
# Goal registers and the limit register whose magnitude bounds them (e-Manual X series).
_GOAL_LIMITS = {Register.GOAL_PWM: Register.PWM_LIMIT,
                Register.GOAL_CURRENT: Register.CURRENT_LIMIT,
                Register.GOAL_VELOCITY: Register.VELOCITY_LIMIT}
_GOALS = frozenset({Register.GOAL_PWM, Register.GOAL_CURRENT, Register.GOAL_VELOCITY,
                    Register.GOAL_POSITION})
# RAM items kept by Control Table Backup besides the EEPROM area (e-Manual Control Table Backup).
_BACKUP_RAM = frozenset({Register.VELOCITY_I_GAIN, Register.VELOCITY_P_GAIN, Register.D_GAIN,
                         Register.I_GAIN, Register.P_GAIN, Register.FEEDFORWARD_2ND_GAIN,
                         Register.FEEDFORWARD_1ST_GAIN, Register.PROFILE_ACCELERATION,
                         Register.PROFILE_VELOCITY, Register.INDIRECT_ADDRESS})
_WATCHDOG_ERROR = (-1, 0xFF)  # Bus Watchdog after a time-out (decoded, or stored unsigned)


class DynamixelRules(ServoRules):
    """A Dynamixel X-series servo speaking Protocol 2.0."""

    wire: type[Wire] = Protocol2Wire
    silent = False
    group_reads = frozenset({SYNC_READ, FAST_SYNC_READ, BULK_READ, FAST_BULK_READ})
    group_writes = frozenset({SYNC_WRITE, BULK_WRITE})
    fast_reads = frozenset({FAST_SYNC_READ, FAST_BULK_READ})
    modes = _MODES
    folds_at_power_on = True  # e-Manual Present Position: "when the actuator is turned on or
    # when rebooted using a Reboot Instruction"

    def status_error(self, number: int, hardware_error: int) -> int:
        """Error number in bits 0-6, Alert (bit 7) while Hardware Error Status is not 0."""
        return number | (0x80 if hardware_error else 0)

    def answers(self, level: int, inst: int) -> bool:
        """Ping always; level 1 Read instructions only; level 2 everything."""
        return inst == PING or level >= 2 or (level == 1 and inst in _READS)

    def ping_params(self, servo: ServoState) -> bytes:
        """Model Number (2 bytes) and Firmware Version."""
        return servo.model_number.to_bytes(2, "little") + bytes([servo.get(Register.FIRMWARE)])

    def multi_turn(self, servo: ServoState) -> bool:
        """Extended and current-based position control count turns."""
        return servo.get(Register.OPERATING_MODE) in _MULTI_TURN_MODES

    def wraps_position(self, servo: ServoState) -> bool:
        """Never: Present Position is a 4-byte continuous count (e-Manual Present Position)."""
        return False

    def homing_offset(self, servo: ServoState) -> int:
        """Homing Offset, ignored in Position Control Mode beyond +-1,024 (the vendor's limit).

        e-Manual Homing Offset(20): "In case of the Position Control Mode(Joint Mode) that
        rotates less than 360 degrees, any invalid Homing Offset(20) values will be
        ignored(valid range : -1,024 ~ 1,024)"; its sign is kept in Reverse Mode.
        """
        off = super().homing_offset(servo)
        if abs(off) > servo.table.vendor.homing_limit and \
                servo.get(Register.OPERATING_MODE) == _POSITION_MODE:
            return 0
        return off

    def folds_turns(self, servo: ServoState, reg: Register, old: int, new: int) -> bool:
        """Present Position comes back within one turn (e-Manual X series, Present Position).

        "Present Position(132) represents a 4 byte continuous range from -2,147,483,648 to
        2,147,483,647 when Torque is turned off regardless of Operating Mode(11). However,
        Present Position(132) will be reset to an absolute position value within one full
        rotation in the following cases: 1. When the Operating Mode(11) is changed to Position
        Control Mode. 2. When torque is turned on in Position Control Mode. 3. When the
        actuator is turned on or when rebooted" (3 is :attr:`folds_at_power_on`). Assumed (the
        e-Manual is silent): switching Drive Mode's reverse bit also starts the count afresh
        within one turn, in the new direction.
        """
        if reg is Register.OPERATING_MODE:
            return new == _POSITION_MODE
        if reg is Register.TORQUE_ENABLE:
            return old == 0 and new == 1 and \
                servo.get(Register.OPERATING_MODE) == _POSITION_MODE
        if reg is Register.DRIVE_MODE:
            return bool((old ^ new) & _REVERSE)
        return False

    def command(self, table: ControlTable, motor: MotorSpec, get: Callable[[Register], int]
                ) -> Command:
        """The X-series controller's inputs (e-Manual gain conversions, Drive Mode bits)."""
        has = table.has

        def reg(r: Register, default: int = 0) -> int:
            return get(r) if has(r) else default

        u = table.vendor
        mode = self.control_mode(get(Register.OPERATING_MODE))
        drive_mode = reg(Register.DRIVE_MODE)
        direction = -1 if drive_mode & _REVERSE else 1
        time_based = bool(drive_mode & _TIME_BASED) and mode.positional
        pwm_limit = reg(Register.PWM_LIMIT, motor.pwm_full) / motor.pwm_full
        duty = pwm_limit
        if mode is not ControlMode.PWM and has(Register.GOAL_PWM):
            duty = min(duty, abs(get(Register.GOAL_PWM)) / motor.pwm_full)
        cu = motor.current_unit
        current_limit = math.inf
        if cu is not None and has(Register.CURRENT_LIMIT):
            current_limit = get(Register.CURRENT_LIMIT) * cu
        goal_current = 0.0
        if cu is not None and has(Register.GOAL_CURRENT):
            goal_current = get(Register.GOAL_CURRENT) * cu
        if mode is ControlMode.CURRENT_POSITION:
            current_limit = min(current_limit, abs(goal_current))
        pv = get(Register.PROFILE_VELOCITY)
        pa = get(Register.PROFILE_ACCELERATION)
        vu = u.velocity_unit
        if time_based:
            pvel, pacc = pv / 1000.0, pa / 1000.0
        elif drive_mode & _TIME_BASED and mode is ControlMode.VELOCITY:
            goal_v = abs(get(Register.GOAL_VELOCITY)) * vu  # t1 = Profile Acceleration [ms]
            pvel, pacc = 0.0, (goal_v / (pa / 1000.0) if pa > 0 and goal_v > 0 else 0.0)
        else:
            vl = reg(Register.VELOCITY_LIMIT) * vu
            pvel = pv * vu
            if vl > 0 and pvel > 0:  # Velocity Limit caps Profile Velocity (0: no profile)
                pvel = min(pvel, vl)
            pacc = pa * u.acceleration_unit
        full = float(motor.pwm_full)
        return Command(
            mode=mode, torque=get(Register.TORQUE_ENABLE) == 1,
            temperature_limit=float(get(Register.TEMPERATURE_LIMIT)),
            direction=direction, time_based=time_based,
            profile_velocity=pvel, profile_acceleration=pacc,
            kp=get(Register.P_GAIN) / 128.0 / full,
            ki=get(Register.I_GAIN) / 65536.0 / full * 1000.0,
            kd=get(Register.D_GAIN) / 16.0 / full / 1000.0,
            kff1=reg(Register.FEEDFORWARD_1ST_GAIN) / 4.0 / full / 1000.0,
            kff2=reg(Register.FEEDFORWARD_2ND_GAIN) / 4.0 / full / 1e6,
            kvp=_VELOCITY_SCALE * reg(Register.VELOCITY_P_GAIN) / 128.0 / full / vu,
            kvi=_VELOCITY_SCALE * reg(Register.VELOCITY_I_GAIN) / 65536.0 / full / vu * 1000.0,
            duty_limit=max(0.0, min(1.0, duty)), current_limit=current_limit,
            goal_velocity=direction * get(Register.GOAL_VELOCITY) * vu,
            goal_current=direction * max(-current_limit, min(current_limit, goal_current))
            if mode is ControlMode.CURRENT else 0.0,
            goal_duty=direction * max(-pwm_limit, min(pwm_limit, reg(Register.GOAL_PWM) / full)),
            moving_threshold=reg(Register.MOVING_THRESHOLD, _MOVING_THRESHOLD) * vu)

    def check_write(self, servo: ServoState, values: dict[RegisterSpec, int], eeprom: bool
                    ) -> tuple[int, dict[RegisterSpec, int]]:
        """Access error for EEPROM with torque on; range, operating mode and limit checks."""
        if eeprom and servo.torque:
            return ERR_ACCESS, {}
        table = servo.table
        for spec, v in values.items():
            reg = spec.register
            if not spec.accepts(v):  # the range, and the listed values of enumerated items
                return ERR_RANGE, {}
            if reg is Register.OPERATING_MODE and v not in table.operating_modes:
                return ERR_RANGE, {}
            if reg not in _GOALS:
                continue
            if table.has(Register.BUS_WATCHDOG) and \
                    servo.get(Register.BUS_WATCHDOG) in _WATCHDOG_ERROR:
                return ERR_RANGE, {}  # goal values are read-only after a watchdog time-out
            limit = _GOAL_LIMITS.get(reg)
            if limit is not None and table.has(limit) and abs(v) > servo.get(limit):
                return ERR_LIMIT, {}
            if reg is Register.GOAL_POSITION and not self.multi_turn(servo) and not (
                    servo.get(Register.MIN_POSITION_LIMIT) <= v
                    <= servo.get(Register.MAX_POSITION_LIMIT)):
                return ERR_LIMIT, {}
        return 0, values

    def instruction(self, servo: ServoState, inst: int, params: bytes, broadcast: bool
                    ) -> tuple[int, bytes] | None:
        """Clear, Factory Reset (options 0xFF, 0x01, 0x02) and Control Table Backup."""
        if inst == CLEAR:
            if params != _CLEAR_MULTI_TURN:
                return ERR_INSTRUCTION, b""
            return servo.clear_multi_turn(), b""
        if inst == FACTORY_RESET:
            option = params[0] if len(params) == 1 else -1
            keeps = servo.table.vendor.reset_keeps.get(option)
            if keeps is None:
                return ERR_RANGE, b""
            if not (broadcast and option == _RESET_ALL):  # not carried out (firmware 42+)
                servo.reset_registers(frozenset(keeps))
            return 0, b""
        if inst == CONTROL_TABLE_BACKUP and servo.table.has(Register.BACKUP_READY):
            return self._backup(servo, params), b""
        return None

    def _backup(self, servo: ServoState, params: bytes) -> int:
        if len(params) != 5 or params[1:] != _BACKUP_KEY or params[0] not in (
                _BACKUP_STORE, _BACKUP_RESTORE):
            return ERR_RANGE
        if servo.torque:
            return ERR_RESULT_FAIL
        table = servo.table
        if params[0] == _BACKUP_STORE:
            specs = [s for s in table.items if s.writable and (
                s.address < table.eeprom_end or s.register in _BACKUP_RAM)]
            servo.backup = servo.snapshot(specs)
            servo.set(Register.BACKUP_READY, 1)
            return 0
        if servo.backup is None:
            return ERR_RESULT_FAIL
        servo.restore({s: b for s, b in servo.backup.items() if s.address < table.eeprom_end})
        servo.reboot()  # the servo reboots itself after a restore
        return 0

    def shutdown_mask(self, servo: ServoState) -> int:
        """The Shutdown register."""
        return servo.get(Register.SHUTDOWN)


# Protocol 1.0 status error bits (e-Manual Protocol 1.0 "Status Packet") for the error numbers.
_P1_ERRORS = {ERR_INSTRUCTION: 0x40, ERR_CRC: 0x10}
_P1_RANGE = 0x08
_P1_ALARMS = 0x25  # input voltage, overheating, overload: the same bits as Hardware Error Status


class DynamixelProtocol1Rules(DynamixelRules):
    """A Dynamixel X-series servo switched to Protocol 1.0 (Protocol Type 1).

    The status byte is a bit field, Ping has no parameters, there is no Reboot, Sync Read, Bulk
    Write, Clear or Control Table Backup, and Reset (0x06) has no option: everything goes back
    to the factory values.
    """

    wire = Protocol1Wire
    basic = frozenset({PING, READ, WRITE, REG_WRITE, ACTION})  # Protocol 1.0 has no Reboot
    group_reads = frozenset()
    group_writes = frozenset({SYNC_WRITE})
    fast_reads = frozenset()

    def status_error(self, number: int, hardware_error: int) -> int:
        """Instruction (0x40), checksum (0x10) or range (0x08) bit, plus the alarm bits."""
        bits = _P1_ERRORS.get(number, _P1_RANGE) if number else 0
        return bits | (hardware_error & _P1_ALARMS)

    def ping_params(self, servo: ServoState) -> bytes:
        """No parameters."""
        return b""

    def instruction(self, servo: ServoState, inst: int, params: bytes, broadcast: bool
                    ) -> tuple[int, bytes] | None:
        """Reset (0x06): every register to its factory value, id and baud rate included."""
        if inst == FACTORY_RESET:
            servo.reset_registers()
            return 0, b""
        return None
