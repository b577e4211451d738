"""One simulated servo: its control table memory, access rules and motion dynamics.

Memory follows the model's :class:`~armctl.servo_tables.ControlTable`, every item of it. A write
must cover whole writable items (else an access or length error, or silence, as the family's
:class:`~armctl.servo.sim.rules.ServoRules` say); the rules then check the values (Dynamixel
answers with an error number: 0x04 range, 0x06 limit, 0x07 access, including an EEPROM write
while torque is on; Feetech silently ignores EEPROM writes while the EEPROM is locked or torque
is on, and keeps the shaft within its angle limits). Indirect Data items stand for the byte their
Indirect Address names, in reads and writes. Realtime Tick, Registered Instruction, Moving
Status, Bus Watchdog, Secondary ID, Shutdown and Startup Configuration behave as the maker's
manual describes for models that have them.

Motion: a DC motor behind its gears, driven by the operating mode's control loop
(:mod:`.motor`; parameters per model in :mod:`armctl.servo_tables.motors`): position modes follow
a velocity profile (Dynamixel Profile Velocity / Acceleration, velocity- or time-based; Feetech
Goal Speed / Acceleration) with the PID gains; velocity, current and PWM modes as the makers
describe. Present position, velocity, current/load, PWM, trajectory, voltage and temperature
follow from the motor's state and an optional external load (:meth:`SimServo.set_load`).

Position frame: ``present = direction x actual + sign x offset`` (Drive Mode's reverse bit
makes the direction -1; the vendor's ``homing_sign`` says whether the offset is added or
subtracted). The rules say whether it is reported within one turn at every read, or is a
continuous count that comes back within one turn only on the events they name (at power-on, when
torque comes on in single-turn position control, ...): :meth:`SimServo.fold_turns`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import replace

from armctl.clock import Clock, default_clock
from armctl.servo.codec import decode, encode, from_le, to_le
from armctl.servo.sim.motor import (
    Command,
    ControlMode,
    Drive,
    ExternalLoad,
    command_spans,
)
from armctl.servo.sim.rules import (
    ERR_ACCESS,
    ERR_CRC,
    ERR_INSTRUCTION,
    ERR_LENGTH,
    ERR_LIMIT,
    ERR_RANGE,
    ServoRules,
)
from armctl.servo.vendor_rules import rules_for_family
from armctl.servo_tables import ControlTable, Encoding, Register, RegisterSpec
from armctl.servo_tables.motors import MotorSpec, motor_for

__all__ = ["ERR_ACCESS", "ERR_CRC", "ERR_INSTRUCTION", "ERR_LENGTH", "ERR_LIMIT", "ERR_RANGE",
           "SimServo"]

_STEP = 0.002  # [s] integration step
_TICK_WRAP = 32768  # Realtime Tick counts milliseconds modulo 32768 (e-Manual X series)
_WATCHDOG_UNIT = 0.020  # [s] per count of Bus Watchdog
_SECONDARY_OFF = 253  # Secondary ID values from 253 up switch the function off
_STARTUP_TORQUE, _STARTUP_RESTORE_RAM = 0x01, 0x02  # Startup Configuration bits


#: The registers :meth:`SimServo._refresh` writes.
_PRESENT = (Register.PRESENT_POSITION, Register.PRESENT_VELOCITY, Register.PRESENT_LOAD,
            Register.PRESENT_CURRENT, Register.PRESENT_PWM, Register.VELOCITY_TRAJECTORY,
            Register.POSITION_TRAJECTORY, Register.PRESENT_VOLTAGE,
            Register.PRESENT_TEMPERATURE, Register.MOVING, Register.HARDWARE_ERROR)
_LOAD_PERCENT = "0.1 %"  # the unit of a load register (motor torque over stall torque)


class SimServo:
    """A simulated servo.

    Args:
        table: The model's control table.
        servo_id: Initial id.
        baudrate: Initial baud rate [bit/s] (stored as the model's baud code).
        position: Initial present position [tick].
        clock: Time base of the motion dynamics (default :func:`~armctl.clock.default_clock`).
        rules: The family's wire behaviour (default: the table's family in its factory
            protocol, :func:`~armctl.servo.vendor_rules.rules_for_family`).
    """

    def __init__(self, table: ControlTable, servo_id: int, baudrate: int, position: int = 2048,
                 clock: Clock | None = None, rules: ServoRules | None = None):
        self.table = table
        self.clock = clock if clock is not None else default_clock()
        self.vendor = table.vendor  # units and conventions of the family
        self.rules = rules if rules is not None else rules_for_family(table.family)
        self.mem = bytearray(table.memory_size)
        self._regs = table.registers
        self._present_from = min(table.spec(r).address for r in (
            Register.HARDWARE_ERROR, Register.PRESENT_POSITION))
        self._cover = {a: s for s in table.items for a in range(s.address, s.address + s.size)}
        #: Indirect Data address -> address of its Indirect Address item.
        self._indirect = {b.data_of(i): b.address_of(i) for b in table.indirect
                          for i in range(b.first_index, b.first_index + b.count)}
        self._has = {r: table.has(r) for r in (
            Register.BUS_WATCHDOG, Register.SECONDARY_ID, Register.REALTIME_TICK,
            Register.MOVING_STATUS, Register.STARTUP_CONFIGURATION,
            Register.REGISTERED_INSTRUCTION, Register.BACKUP_READY)}
        self._watchdog_at = table.spec(Register.BUS_WATCHDOG).address \
            if self._has[Register.BUS_WATCHDOG] else None
        #: Control Table Backup area (Dynamixel), kept across reboots and factory resets.
        self.backup: dict[RegisterSpec, bytes] | None = None
        self._booted = self._heard = self.clock.now()  # power-on and last instruction [s]
        #: The motor, gears and control loops (:mod:`.motor`).
        self.drive = Drive(motor_for(table.model), table.ticks_per_rev, float(position))
        #: Whole turns [tick] taken off a continuous Present Position (see :meth:`fold_turns`).
        self._turns = 0
        self._cmd: Command | None = None
        self._cmd_key = b""
        self._cmd_spans = command_spans(table)
        self._shown: tuple[object, ...] = ()  # the state the present registers show
        self._shown_bytes = b""
        #: PRESENT_LOAD holds the motor torque over the stall torque (else a current).
        self._load_percent = table.spec(Register.PRESENT_LOAD).unit == _LOAD_PERCENT
        self._present_spans = tuple((s.address, s.address + s.size) for s in (
            table.spec(r) for r in _PRESENT if table.has(r)))
        self.alarm_bits = 0
        self.locked_up = False
        self.model_override: int | None = None
        #: The write Reg Write keeps for Action: (address, data, sent to the Secondary ID).
        self.registered: tuple[int, bytes, bool] | None = None
        self.t = self.clock.now()
        codes = self.vendor.baud_codes
        code = next((c for c, b in codes.items() if b == baudrate), None)
        if code is None:
            raise ValueError(f"baud rate {baudrate} has no code on {self.table.model}")
        self.factory_reset()
        self._put(Register.ID, servo_id)
        self._put(Register.BAUD_RATE, code)
        self._put(Register.RETURN_DELAY, 0)  # configured as LeRobot and armctl users do

    # ---- memory ---------------------------------------------------------------------------
    def factory_reset(self, keep_id: bool = False, keep_baud: bool = False) -> None:
        """Every register back to its factory default (id 1 unless kept); position kept."""
        keep = {Register.ID} if keep_id else set()
        if keep_baud:
            keep.add(Register.BAUD_RATE)
        self.reset_registers(frozenset(keep))

    def reset_registers(self, keep: frozenset[Register] = frozenset()) -> None:
        """Every item back to its factory default except those in ``keep``; position kept."""
        saved = {r: self.get(r) for r in keep}
        for spec in self.table.items:
            self._store(spec, spec.default)
        for reg, value in saved.items():
            self._put(reg, value)
        self._show_backup()
        self.alarm_bits = 0
        self.registered = None
        self.target = self.actual
        self.velocity = self.accel = 0.0
        self._power_on_goals()
        if self.rules.folds_at_power_on:  # at power-on, and the mode is Position again
            self.fold_turns()

    def _show_backup(self) -> None:
        """Backup Ready reads 1 while a Control Table Backup exists."""
        if self._has[Register.BACKUP_READY]:
            self._put(Register.BACKUP_READY, int(self.backup is not None))

    def _put(self, reg: Register, value: int) -> None:
        self._store(self._regs[reg], value)

    def _store(self, spec: RegisterSpec, value: int) -> None:
        try:
            raw = encode(spec, value)
        except OverflowError:
            # A counter the servo keeps (Present Position after many turns) rolls over in its
            # bytes as on the hardware; any other value saturates at the item's range.
            if spec.encoding is Encoding.TWOS_COMPLEMENT:
                raw = value & ((1 << (8 * spec.size)) - 1)
            else:
                raw = encode(spec, max(spec.lo, min(spec.hi, value)))
        self.mem[spec.address:spec.address + spec.size] = to_le(raw, spec.size)

    def snapshot(self, specs: Iterable[RegisterSpec]) -> dict[RegisterSpec, bytes]:
        """The raw bytes of ``specs`` (for Control Table Backup)."""
        return {s: bytes(self.mem[s.address:s.address + s.size]) for s in specs}

    def restore(self, saved: Mapping[RegisterSpec, bytes]) -> None:
        """Put back raw bytes taken by :meth:`snapshot`."""
        for spec, raw in saved.items():
            self.mem[spec.address:spec.address + len(raw)] = raw

    def get(self, reg: Register) -> int:
        """The decoded value of a register (no dynamics update)."""
        spec = self._regs[reg]
        raw = int.from_bytes(self.mem[spec.address:spec.address + spec.size], "little")
        return raw if spec.encoding is Encoding.UNSIGNED else decode(spec, raw)

    def set(self, reg: Register, value: int) -> None:
        """Store a register value directly (bypassing the access rules; for setup and tests)."""
        self._put(reg, value)

    @property
    def id(self) -> int:
        """The current id register."""
        return self.get(Register.ID)

    @property
    def secondary_id(self) -> int | None:
        """The Secondary ID the servo also obeys (without replying), or ``None``."""
        if not self._has[Register.SECONDARY_ID]:
            return None
        sid = self.get(Register.SECONDARY_ID)
        return sid if sid < _SECONDARY_OFF else None

    @property
    def baudrate(self) -> int:
        """The baud rate the servo listens at [bit/s]."""
        codes = self.vendor.baud_codes
        return codes.get(self.get(Register.BAUD_RATE), 0)

    @property
    def return_delay(self) -> float:
        """Return delay time [s]."""
        return 2e-6 * self.get(Register.RETURN_DELAY)

    @property
    def torque(self) -> bool:
        """Whether torque is on."""
        return self.get(Register.TORQUE_ENABLE) == 1

    @property
    def model_number(self) -> int:
        """The model number the servo reports."""
        return self.model_override if self.model_override is not None else self.table.model_number

    @property
    def error_byte(self) -> int:
        """The error field of a status packet (without an error number)."""
        return self.status_error(0)

    def status_error(self, number: int) -> int:
        """The error field of a status packet for error ``number`` (0: none)."""
        return self.rules.status_error(number, self.get(Register.HARDWARE_ERROR))

    # ---- position frames ------------------------------------------------------------------
    def _offset(self) -> int:
        return self.rules.homing_offset(self)

    def _wraps(self) -> bool:
        return self.rules.wraps_position(self)

    def fold_turns(self) -> None:
        """Bring the continuous Present Position back within one turn (homing offset added).

        Only the count changes: the shaft stays where it is.
        """
        n = self.table.ticks_per_rev
        self._turns = n * math.floor(self._direction() * round(self.actual) / n)

    def encoder_position(self) -> int:
        """Encoder position within one turn [tick], before the homing offset."""
        return round(self.actual) % self.table.ticks_per_rev

    def present_position(self) -> int:
        """Present position [tick] as the servo reports it (Drive Mode reverse mirrors it)."""
        return self._frame(self.actual)

    def set_present_position(self, ticks: int) -> None:
        """Move the shaft by hand so that the present position reads ``ticks`` (torque off)."""
        self._update(self.clock.now())
        self.actual += self._direction() * (ticks - self.present_position())
        self.target = self.actual
        self.velocity = 0.0

    def block_at(self, ticks: int | None) -> None:
        """Put an obstacle at present position ``ticks`` (``None``: where the shaft is now).

        The shaft cannot move past it from the side it is on (both ways when it is there).
        """
        self._update(self.clock.now())
        at = self.actual
        if ticks is not None:
            delta = ticks - self.present_position()
            if self._wraps():
                n = self.table.ticks_per_rev
                delta = (delta + n // 2) % n - n // 2
            at = self.actual + self._direction() * delta  # Drive Mode reverse mirrors ticks
        side = 0 if abs(self.actual - at) < 0.5 else (1 if self.actual > at else -1)
        self.obstacle = (at, side)

    def _pressing(self) -> bool:
        """Whether the shaft is held by the obstacle while the goal lies beyond it."""
        if self.obstacle is None or not self.torque:
            return False
        at, side = self.obstacle
        return abs(self.actual - at) < 0.5 and (side == 0 or (self.target - at) * side < 0)

    # ---- dynamics -------------------------------------------------------------------------
    @property
    def actual(self) -> float:
        """Encoder position before the homing offset [tick] (the shaft is between ticks)."""
        return self.drive.pos

    @actual.setter
    def actual(self, value: float) -> None:
        self.drive.pos = float(value)

    @property
    def velocity(self) -> float:
        """Shaft velocity [tick/s] in the encoder's direction."""
        return self.drive.vel

    @velocity.setter
    def velocity(self, value: float) -> None:
        self.drive.vel = float(value)

    @property
    def target(self) -> float:
        """Goal position [tick] in the encoder frame."""
        return self.drive.goal

    @target.setter
    def target(self, value: float) -> None:
        """Hold at ``value``: the profile and the integrators start afresh."""
        self.drive.hold(value)

    @property
    def obstacle(self) -> tuple[float, int] | None:
        """An obstacle: (encoder position [tick], side +1/-1/0 the shaft must stay on)."""
        return self.drive.obstacle

    @obstacle.setter
    def obstacle(self, value: tuple[float, int] | None) -> None:
        self.drive.obstacle = value

    def set_load(self, load: ExternalLoad, inertia: float = 0.0) -> None:
        """An external load on the output shaft, e.g. gravity on the link it drives.

        Args:
            load: Torque against the encoder's positive direction [N m]: a constant, or a
                function of the encoder angle [rad], velocity [rad/s] and time [s].
            inertia: Inertia of what the shaft carries [kg m^2].
        """
        self._update(self.clock.now())
        self.drive.load = load
        self.drive.extra_inertia = float(inertia)

    def use_motor(self, motor: MotorSpec) -> None:
        """Drive the shaft with other motor parameters (e.g. fitted to a real servo).

        The shaft keeps its position, goal and external load; it starts at rest.
        """
        self._update(self.clock.now())
        old = self.drive
        drive = Drive(motor, self.table.ticks_per_rev, old.pos)
        drive.goal, drive.traj_pos = old.goal, old.traj_pos
        drive.load, drive.extra_inertia, drive.obstacle = old.load, old.extra_inertia, old.obstacle
        self.drive = drive
        self._cmd = None

    def _command(self) -> Command:
        """The control inputs from the registers (rebuilt only when one of them changed)."""
        mem = self.mem
        key = b"".join([mem[a:b] for a, b in self._cmd_spans])
        if self._watchdog_at is not None:
            key += mem[self._watchdog_at:self._watchdog_at + 1]
        if self._cmd is None or key != self._cmd_key:
            self._cmd_key = key
            self._cmd = self._starved(self.rules.command(self.table, self.drive.motor, self.get))
        return self._cmd

    def _direction(self) -> int:
        """-1 when Drive Mode's reverse bit mirrors the register frame, else +1."""
        return self._command().direction

    def _power_on_goals(self) -> None:
        """Set the goals the firmware sets at power-on.

        Goal PWM = PWM Limit, Goal Current = Current Limit (e-Manual X series); Torque_Limit =
        Max_Torque (Feetech memory table).
        """
        for goal, limit in ((Register.GOAL_PWM, Register.PWM_LIMIT),
                            (Register.GOAL_CURRENT, Register.CURRENT_LIMIT),
                            (Register.TORQUE_LIMIT, Register.MAX_TORQUE)):
            if self.table.has(goal) and self.table.has(limit):
                self._put(goal, self.get(limit))

    def _update(self, now: float) -> None:
        """Run the motor and its control loop up to ``now`` [s]."""
        start = self.t
        if now <= start:
            return
        self.t = now
        cmd = self._command()
        drive = self.drive
        t = start
        while t < now:
            alarms = drive.advance(now - t, cmd, cmd.torque, t)
            t = drive.time if alarms else now
            if not alarms:
                break
            fresh = alarms & ~self.alarm_bits
            if fresh:
                self._latch(fresh)  # Feetech protection; Unloading Condition cuts torque
            cmd = self._command()
        if drive.temperature >= cmd.temperature_limit > 0 and not self.alarm_bits & 0x04:
            self._latch(0x04)  # overheating (the same bit on both families)

    def _refresh(self) -> None:
        """Write the present-state registers from the motor's state (if it changed)."""
        d = self.drive
        cmd = self._command()
        mem = self.mem
        shown = (d.pos, d.vel, d.current, d.duty, d.traj_pos, d.traj_vel, round(d.temperature),
                 self.alarm_bits, self._turns, cmd)
        if shown == self._shown and shown[-1] is self._shown[-1] and \
                b"".join([mem[a:b] for a, b in self._present_spans]) == self._shown_bytes:
            return  # the registers show this state already
        sign = cmd.direction
        motor = d.motor
        has = self.table.has
        offset, wraps = self._offset(), self._wraps()
        self._put(Register.PRESENT_POSITION, self._frame(d.pos, sign, offset, wraps))
        self._put(Register.PRESENT_VELOCITY, round(sign * d.vel / self.vendor.velocity_unit))
        amps, duty = (d.current, d.duty) if cmd.torque else (0.0, 0.0)  # bridge off: no current
        if self._load_percent or motor.current_unit is None:  # Present Load [0.1 %]
            load = max(-1.0, min(1.0, sign * amps / motor.stall_current))
            self._put(Register.PRESENT_LOAD, round(1000 * load))
        else:  # Present Current [current unit]
            self._put(Register.PRESENT_LOAD, round(sign * amps / motor.current_unit))
        if has(Register.PRESENT_CURRENT) and motor.current_unit is not None:
            self._put(Register.PRESENT_CURRENT, round(abs(amps) / motor.current_unit))
        if has(Register.PRESENT_PWM):
            self._put(Register.PRESENT_PWM, round(sign * duty * motor.pwm_full))
        if has(Register.VELOCITY_TRAJECTORY):
            self._put(Register.VELOCITY_TRAJECTORY,
                      round(sign * d.traj_vel / self.vendor.velocity_unit))
        if has(Register.POSITION_TRAJECTORY):
            self._put(Register.POSITION_TRAJECTORY, self._frame(d.traj_pos, sign, offset, wraps))
        volts = d.supply_voltage()
        if self.alarm_bits & 0x01:
            volts = self.get(Register.MAX_VOLTAGE_LIMIT) / 10.0 + 1.0
        self._put(Register.PRESENT_VOLTAGE, round(10 * volts))
        temp = round(d.temperature)
        if self.alarm_bits & 0x04:
            temp = max(temp, round(cmd.temperature_limit) + 2)
        self._put(Register.PRESENT_TEMPERATURE, temp)
        moving = abs(d.vel) > cmd.moving_threshold or (
            cmd.torque and cmd.mode.positional and d.profile_ongoing())
        self._put(Register.MOVING, int(moving))
        self._put(Register.HARDWARE_ERROR, self.alarm_bits)
        self._shown = shown
        self._shown_bytes = b"".join([mem[a:b] for a, b in self._present_spans])

    def _frame(self, encoder: float, direction: int | None = None, offset: int | None = None,
               wraps: bool | None = None) -> int:
        """The register-frame position [tick] of an encoder-frame one.

        Reported within one turn when the rules say it wraps; else a continuous count, less
        the whole turns dropped by the last :meth:`fold_turns`. ``direction``, ``offset`` and
        ``wraps`` may be given when already known.
        """
        sign = self._direction() if direction is None else direction
        off = self._offset() if offset is None else offset
        p = sign * round(encoder) + off
        wrap = self._wraps() if wraps is None else wraps
        return p % self.table.ticks_per_rev if wrap else p - self._turns

    def clear_multi_turn(self) -> int:
        """Clear: Present Position back within one turn (0, or Result Fail while moving)."""
        self._update(self.clock.now())
        if abs(self.velocity) > 1.0:
            return 1
        self.fold_turns()
        self.drive.hold()
        return 0

    # ---- alarms and reboot ----------------------------------------------------------------
    def raise_alarm(self, bits: int) -> None:
        """Latch hardware alarm bits (family bit layout).

        Alarms named by the family's shutdown bits (Dynamixel Shutdown, Feetech Unloading
        Condition) switch the torque off, and it cannot come back until a reboot.
        """
        self._update(self.clock.now())
        self._latch(bits)
        self._refresh()

    def _latch(self, bits: int) -> None:
        """Set alarm bits now (no motion update: the motor loop calls this itself)."""
        self.alarm_bits |= bits
        if bits & self.rules.shutdown_mask(self):
            self._put(Register.TORQUE_ENABLE, 0)
            self.velocity = self.accel = 0.0

    def reboot(self) -> None:
        """Reboot: RAM back to defaults, alarms and lock-up cleared, EEPROM and position kept.

        Startup Configuration (Dynamixel) applies: bit 1 restores the backed-up RAM items,
        bit 0 switches the torque on.
        """
        now = self.clock.now()
        self._update(now)
        for spec in self.table.items:
            if spec.address >= self.table.eeprom_end:
                self._store(spec, spec.default)
        self.alarm_bits = 0
        self.locked_up = False
        self.registered = None
        self.target = self.actual
        self.velocity = self.accel = 0.0
        self._power_on_goals()
        if self.rules.folds_at_power_on:
            self.fold_turns()
        self._booted = self._heard = now
        self._show_backup()
        startup = self.get(Register.STARTUP_CONFIGURATION) \
            if self._has[Register.STARTUP_CONFIGURATION] else 0
        if startup & _STARTUP_RESTORE_RAM and self.backup is not None:
            self.restore({s: b for s, b in self.backup.items()
                          if s.address >= self.table.eeprom_end})
        if startup & _STARTUP_TORQUE:
            self._apply(self._regs[Register.TORQUE_ENABLE], 1)
        self._refresh()

    # ---- bus watchdog -----------------------------------------------------------------------
    def heard(self, now: float | None = None) -> None:
        """An instruction packet went past on the bus (it feeds the Bus Watchdog)."""
        now = self.clock.now() if now is None else now
        if self._watchdog() is not None:
            self._advance(now)  # a time-out before this packet stops the servo first
        self._heard = now

    def _watchdog(self) -> float | None:
        """The Bus Watchdog time-out [s] while it is armed, else ``None``."""
        at = self._watchdog_at
        if at is None:
            return None
        count = self.mem[at]  # 1 byte; -1 (0xFF) is the error state
        return count * _WATCHDOG_UNIT if 0 < count < 128 else None

    def _advance(self, now: float) -> None:
        """Run the dynamics to ``now``, stopping the servo where the Bus Watchdog runs out."""
        limit = self._watchdog()
        if limit is not None and self.torque and now - self._heard > limit:
            self._update(self._heard + limit)
            spec = self._regs[Register.BUS_WATCHDOG]
            self.mem[spec.address:spec.address + spec.size] = b"\xff" * spec.size  # -1: error
            self._halt()
        self._update(now)

    def _halt(self) -> None:
        """Stop at once where the shaft is (profile acceleration and velocity taken as 0)."""
        self.target = self.actual
        self.velocity = self.accel = 0.0

    def _starved(self, cmd: Command) -> Command:
        """The command while a Bus Watchdog error stands: no velocity, current or PWM goal.

        (Positional modes hold where :meth:`_halt` left them: goal writes are refused.)
        """
        at = self._watchdog_at
        if at is None or self.mem[at] != 0xFF or cmd.mode.positional:
            return cmd
        return replace(cmd, goal_velocity=0.0, goal_current=0.0, goal_duty=0.0,
                       profile_acceleration=0.0)

    # ---- status registers ---------------------------------------------------------------------
    def _refresh_status(self, now: float) -> None:
        """Write Realtime Tick and Moving Status (for the models that have them)."""
        if self._has[Register.REALTIME_TICK]:
            self._put(Register.REALTIME_TICK, int((now - self._booted) * 1000.0) % _TICK_WRAP)
        if self._has[Register.MOVING_STATUS]:
            self._put(Register.MOVING_STATUS, self.moving_status())

    def moving_status(self) -> int:
        """Dynamixel Moving Status bits (e-Manual X series "Moving Status").

        Bit 0 in position (within 1 tick of the goal, torque on), bit 1 profile ongoing, bit 3
        following error (the shaft held back from its trajectory), bits 4-5 the velocity
        profile of the last goal: 00 step, 01 rectangular, 10 triangular, 11 trapezoidal.
        """
        if not self.torque:
            return 0
        return self.drive.moving_status(self._command()) | (0x08 if self._pressing() else 0)

    # ---- host access ----------------------------------------------------------------------
    def read(self, address: int, length: int) -> bytes | None:
        """The bytes at ``address`` (``None``: outside the table).

        Indirect Data bytes read the byte their Indirect Address names.
        """
        if address < 0 or length < 0 or address + length > self.table.memory_size:
            return None
        now = self.clock.now()
        self._advance(now)
        end = address + length
        hits = [a for a in range(address, end) if a in self._indirect] if self._indirect else []
        if end > self._present_from or hits:  # only then the present state is needed
            self._refresh()
            self._refresh_status(now)
        data = self.mem[address:end]
        for a in hits:
            data[a - address] = self._indirect_byte(a)
        return bytes(data)

    def _indirect_target(self, data_address: int) -> int:
        at = self._indirect[data_address]
        return self.mem[at] | self.mem[at + 1] << 8

    def _indirect_byte(self, data_address: int) -> int:
        target = self._indirect_target(data_address)
        return self.mem[target] if 0 <= target < len(self.mem) else 0

    def write(self, address: int, data: bytes, secondary: bool = False) -> int:
        """Write ``data`` at ``address`` under the access rules.

        Args:
            address: First byte address.
            data: The bytes; they must cover whole writable items.
            secondary: The instruction was addressed to the Secondary ID (EEPROM items are
                not written).

        Returns:
            0, or an error number (0 also when the family ignores a bad write silently).
        """
        self._advance(self.clock.now())
        refuse = self.rules.refuse
        end = address + len(data)
        values: dict[RegisterSpec, int] = {}
        via: dict[int, int] = {}  # target address -> byte, written through Indirect Data
        a = address
        while a < end:
            spec = self._cover.get(a)
            if spec is None or not spec.writable:
                return refuse(ERR_ACCESS)
            if spec.address != a or spec.address + spec.size > end:
                return refuse(ERR_LENGTH)
            if a in self._indirect:
                via[self._indirect_target(a)] = data[a - address]
            else:
                values[spec] = decode(spec, from_le(data[a - address:a - address + spec.size]))
            a += spec.size
        if via:
            err = self._through_indirect(via, values)
            if err:
                return refuse(err)
        eeprom_end = self.table.eeprom_end
        eeprom = any(s.address < eeprom_end for s in values)
        if secondary and eeprom:
            values = {s: v for s, v in values.items() if s.address >= eeprom_end}
            eeprom = False
        err, values = self.rules.check_write(self, values, eeprom)
        if err:
            return err
        for spec, v in values.items():
            self._apply(spec, v)
        return 0

    def _through_indirect(self, via: dict[int, int], values: dict[RegisterSpec, int]) -> int:
        """Add the items written through Indirect Data to ``values`` (0, or an error number).

        The target item takes on the bytes written; bytes of it that no Indirect Data slot
        names keep their value.
        """
        touched: dict[RegisterSpec, bytearray] = {}
        for target, byte in via.items():
            spec = self._cover.get(target)
            if spec is None or not spec.writable:  # an Indirect Data slot itself: its byte
                return ERR_ACCESS
            raw = touched.get(spec)
            if raw is None:
                raw = touched[spec] = bytearray(self.mem[spec.address:spec.address + spec.size])
            raw[target - spec.address] = byte
        for spec, raw in touched.items():
            values[spec] = decode(spec, from_le(bytes(raw)))
        return 0

    def register_write(self, address: int, data: bytes, secondary: bool = False) -> None:
        """Reg Write: keep the write for Action and set Registered Instruction."""
        self.registered = (address, data, secondary)
        if self._has[Register.REGISTERED_INSTRUCTION]:
            self._put(Register.REGISTERED_INSTRUCTION, 1)

    def action(self) -> int | None:
        """Action: carry out the registered write (``None``: nothing was registered)."""
        if self.registered is None:
            return None
        address, data, secondary = self.registered
        self.registered = None
        if self._has[Register.REGISTERED_INSTRUCTION]:
            self._put(Register.REGISTERED_INSTRUCTION, 0)
        return self.write(address, data, secondary)

    def _apply(self, spec: RegisterSpec, value: int) -> None:
        """Store one checked item value, with what storing it sets off."""
        if self.rules.special_write(self, spec, value):
            return
        reg = spec.register
        if reg is Register.TORQUE_ENABLE and value and \
                self.alarm_bits & self.rules.shutdown_mask(self):
            return  # torque cannot come back while a shutdown alarm is latched
        if spec.index:
            self._store(spec, value)
            return
        old = self.get(reg)
        self._on_write(reg, value)
        self._store(spec, value)
        if self.rules.folds_turns(self, reg, old, value):
            self.fold_turns()
        if reg is Register.TORQUE_ENABLE and value and not old:
            self._put(Register.GOAL_POSITION, self.present_position())

    def _on_write(self, reg: Register, value: int) -> None:
        """What a write of ``reg`` sets off in the motion, just before ``value`` is stored."""
        if reg is Register.TORQUE_ENABLE and value and not self.torque:
            self.target = self.actual  # (Goal Position then reads the present position)
        if reg is Register.GOAL_POSITION:
            cmd = self._command()
            bounds = self.rules.goal_limits(self)  # e.g. angle limits that clamp
            if bounds is not None and cmd.mode is not ControlMode.STEP:
                value = max(bounds[0], min(bounds[1], value))
            if cmd.mode is ControlMode.STEP:  # step mode: a relative move
                goal = self.actual + value
            else:
                goal = self.actual + cmd.direction * (value - self.present_position())
            self.drive.set_goal(goal, cmd)
        if reg in (Register.OPERATING_MODE, Register.HOMING_OFFSET, Register.PHASE,
                   Register.DRIVE_MODE):
            self.target = self.actual
