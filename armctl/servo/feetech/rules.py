"""How a simulated Feetech STS servo behaves: on the wire (SCS/STS protocol) and in its modes.

Sources: the Feetech SCS/STS protocol as implemented by ``scservo_sdk`` (status byte of alarm
bits, Status Return Level 0 answering Read and Ping only, Ping without parameters, Sync Read and
Sync Write) and the STS memory table (``SMS_STS.h``: the Lock register guards the EEPROM area,
Torque Enable 128 re-centres the position, ``INST_RECOVERY`` 0x06 restores the factory values).
A Feetech servo never reports a bad request: it stays silent or ignores the write; a goal
position beyond the angle limits is stored as written but the shaft stops at the limit.
Operating_Mode 0 position, 1 wheel (velocity), 2 PWM (Goal_Time as the duty), 3 step; the
present position is reported within one turn unless the Phase register's multi-turn bit is set.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from armctl.servo.sim.motor import Command, ControlMode
from armctl.servo.sim.rules import (
    FACTORY_RESET,
    PING,
    READ,
    SYNC_READ,
    SYNC_WRITE,
    ServoRules,
    ServoState,
)
from armctl.servo.sim.wire import Protocol1Wire
from armctl.servo_tables import ControlTable, Register, RegisterSpec
from armctl.servo_tables.motors import MotorSpec

__all__ = ["FeetechRules"]

_RECOVERY = FACTORY_RESET  # 0x06, INST_RECOVERY in Feetech's SDKs
_CALIBRATE = 128  # Torque Enable value: the present position becomes the centre
_CENTRE = 2048  # [tick]
_PHASE_MULTI_TURN = 0x10  # Phase bit of the multi-turn (step) position mode
_SHUTDOWN_DEFAULT = 0x24  # overheating and overload, when the model has no Unloading Condition
#: Operating_Mode (STS memory table) -> what the controller does.
_MODES = {0: ControlMode.POSITION, 1: ControlMode.VELOCITY, 2: ControlMode.PWM,
          3: ControlMode.STEP}
_PROTECTION_ALARMS = 0x28  # overcurrent, overload: the output is then held to Protective_Torque
# Simulator scaling of the controller (the memory table gives no units; these make the factory
# gains behave like the servo: a few ticks of error under a moderate load).
_POSITION_SCALE = 2048.0  # duty = P x error [tick] / this (P = 32: full output at 64 ticks)
_VELOCITY_GAIN = 4.0  # wheel mode: duty per relative speed error
_VELOCITY_I = 40.0  # [1/s] its integral action


class FeetechRules(ServoRules):
    """A Feetech STS servo."""

    wire = Protocol1Wire
    silent = True
    group_reads = frozenset({SYNC_READ})
    group_writes = frozenset({SYNC_WRITE})
    fast_reads = frozenset()
    modes = _MODES

    def status_error(self, number: int, hardware_error: int) -> int:
        """The alarm bits (bit 7 never set); a bad request has no error bit."""
        return hardware_error & 0x7F

    def answers(self, level: int, inst: int) -> bool:
        """Level 0 answers Ping and Read only; level 1 everything."""
        return inst in (PING, READ) or level >= 1

    def ping_params(self, servo: ServoState) -> bytes:
        """No parameters."""
        return b""

    def multi_turn(self, servo: ServoState) -> bool:
        """The Phase register's multi-turn bit."""
        return bool(servo.get(Register.PHASE) & _PHASE_MULTI_TURN)

    def wraps_position(self, servo: ServoState) -> bool:
        """Within one turn unless the Phase register's multi-turn bit is set."""
        return not self.multi_turn(servo)

    def command(self, table: ControlTable, motor: MotorSpec, get: Callable[[Register], int]
                ) -> Command:
        """The STS controller's inputs (Torque_Limit, Goal_Speed, dead zones, protections)."""
        has = table.has

        def reg(r: Register, default: int = 0) -> int:
            return get(r) if has(r) else default

        u = table.vendor
        vmax = motor.no_load_speed_rad * table.ticks_per_rev / (2.0 * math.pi)  # [tick/s]
        mode = self.control_mode(get(Register.OPERATING_MODE))
        limit = reg(Register.TORQUE_LIMIT, reg(Register.MAX_TORQUE, 1000)) / 1000.0
        if get(Register.HARDWARE_ERROR) & _PROTECTION_ALARMS and has(Register.PROTECTIVE_TORQUE):
            limit = min(limit, get(Register.PROTECTIVE_TORQUE) / 100.0)  # after a protection
        speed = get(Register.PROFILE_VELOCITY)  # Goal_Speed [tick/s], signed in wheel mode
        accel = get(Register.PROFILE_ACCELERATION) * u.acceleration_unit
        max_acc = reg(Register.MAX_ACCELERATION) * u.acceleration_unit
        if max_acc > 0:
            accel = max_acc if accel <= 0 else min(accel, max_acc)
        dead = max(reg(Register.CW_DEAD_ZONE), reg(Register.CCW_DEAD_ZONE))
        overload = overcurrent = None
        if has(Register.OVERLOAD_TORQUE) and has(Register.PROTECTION_TIME):
            overload = (get(Register.OVERLOAD_TORQUE) / 100.0,
                        get(Register.PROTECTION_TIME) * 0.01)
        if has(Register.PROTECTION_CURRENT) and has(Register.OVERCURRENT_PROTECTION_TIME) \
                and motor.current_unit is not None:
            overcurrent = (get(Register.PROTECTION_CURRENT) * motor.current_unit,
                           get(Register.OVERCURRENT_PROTECTION_TIME) * 0.01)
        goal_time = reg(Register.GOAL_TIME)
        return Command(
            mode=mode, torque=get(Register.TORQUE_ENABLE) == 1,
            temperature_limit=float(get(Register.TEMPERATURE_LIMIT)),
            profile_velocity=float(abs(speed)) if mode.positional else 0.0,
            profile_acceleration=accel,
            kp=get(Register.P_GAIN) / _POSITION_SCALE,
            ki=get(Register.I_GAIN) / _POSITION_SCALE * 1000.0,
            kd=get(Register.D_GAIN) / _POSITION_SCALE / 1000.0,
            kvp=_VELOCITY_GAIN / vmax, kvi=_VELOCITY_GAIN * _VELOCITY_I / vmax,
            duty_limit=max(0.0, min(1.0, limit)),
            goal_velocity=float(speed) if mode is ControlMode.VELOCITY else 0.0,
            goal_duty=max(-1.0, min(1.0, goal_time / 1000.0)),
            dead_zone=float(dead), moving_threshold=1.0,
            overload=overload, overcurrent=overcurrent)

    def check_write(self, servo: ServoState, values: dict[RegisterSpec, int], eeprom: bool
                    ) -> tuple[int, dict[RegisterSpec, int]]:
        """Drop EEPROM items while locked or with torque on, and out-of-range values."""
        table = servo.table
        if eeprom and (servo.torque or servo.get(Register.LOCK) == 1):
            values = {s: v for s, v in values.items() if s.address >= table.eeprom_end}
        return 0, {s: v for s, v in values.items() if s.accepts(v)}

    def goal_limits(self, servo: ServoState) -> tuple[int, int] | None:
        """The angle limits, unless both are 0 (then the goal is free)."""
        lo = servo.get(Register.MIN_POSITION_LIMIT)
        hi = servo.get(Register.MAX_POSITION_LIMIT)
        return (lo, hi) if lo or hi else None

    def special_write(self, servo: ServoState, spec: RegisterSpec, value: int) -> bool:
        """Torque Enable 128: the homing offset is set so that the present position reads 2048."""
        if spec.register is Register.TORQUE_ENABLE and value == _CALIBRATE:
            servo.set(Register.HOMING_OFFSET, servo.encoder_position() - _CENTRE)
            return True
        return False

    def instruction(self, servo: ServoState, inst: int, params: bytes, broadcast: bool
                    ) -> tuple[int, bytes] | None:
        """Recovery (0x06): every register back to its factory value, id and baud included."""
        if inst == _RECOVERY:
            servo.reset_registers()
            return 0, b""
        return None

    def shutdown_mask(self, servo: ServoState) -> int:
        """The Unloading Condition register (overheating and overload on models without it)."""
        if servo.table.has(Register.UNLOADING_CONDITION):
            return servo.get(Register.UNLOADING_CONDITION)
        return _SHUTDOWN_DEFAULT

    def read_outside(self, length: int) -> tuple[int, bytes]:
        """Zeros (the servo answers whatever its memory holds there)."""
        return 0, bytes(length)
