"""One simulated servo: its control table memory, access rules and motion dynamics.

Memory follows the model's :class:`~armctl.servo_tables.ControlTable`. Writes are checked like the
real servo checks them: Dynamixel answers with an error number (0x04 range, 0x05 length,
0x06 limit, 0x07 access, including an EEPROM write while torque is on); Feetech silently ignores
EEPROM writes while the EEPROM is locked or torque is on, and clamps goals to its angle limits.

Motion: with torque on, the encoder position tracks the goal under a trapezoidal velocity
profile (Dynamixel Profile Velocity / Acceleration, Feetech Goal Speed / Acceleration; 0 means
the model's maximum). Present velocity follows the profile; present load is a plausible mix of
acceleration, speed and holding effort. Homing offsets apply as on the hardware: Dynamixel
``present = actual + offset``, Feetech ``present = actual - offset``.
"""

from __future__ import annotations

import math

from armctl.clock import Clock, default_clock
from armctl.servo.codec import decode, encode, from_le, to_le
from armctl.servo_tables import ControlTable, Encoding, Register

__all__ = ["SimServo"]

# Dynamixel error numbers (e-Manual P2 "Error").
ERR_INSTRUCTION, ERR_CRC, ERR_RANGE, ERR_LENGTH, ERR_LIMIT, ERR_ACCESS = 2, 3, 4, 5, 6, 7

_STEP = 0.002  # [s] integration step


class SimServo:
    """A simulated servo.

    Args:
        table: The model's control table.
        servo_id: Initial id.
        baudrate: Initial baud rate [bit/s] (stored as the model's baud code).
        position: Initial present position [tick].
        clock: Time base of the motion dynamics (default :func:`~armctl.clock.default_clock`).
    """

    def __init__(self, table: ControlTable, servo_id: int, baudrate: int, position: int = 2048,
                 clock: Clock | None = None):
        self.table = table
        self.clock = clock if clock is not None else default_clock()
        self.vendor = table.vendor  # units and conventions of the family
        self.feetech = self.vendor.feetech
        self.mem = bytearray(table.memory_size)
        self._regs = table.registers
        self._present_from = min(table.spec(r).address for r in (
            Register.HARDWARE_ERROR, Register.PRESENT_POSITION))
        self._cover = {a: s for s in table.registers.values()
                       for a in range(s.address, s.address + s.size)}
        self.actual = float(position)  # encoder position before the homing offset [tick]
        self.velocity = 0.0  # [tick/s]
        self.accel = 0.0  # [tick/s^2]
        self.target = float(position)  # [tick], in encoder frame
        self.alarm_bits = 0
        self.locked_up = False
        #: An obstacle: (encoder position [tick], side +1/-1/0 the shaft must stay on), or None.
        self.obstacle: tuple[float, int] | None = None
        self.model_override: int | None = None
        self.registered: tuple[int, bytes] | None = None
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
        sid, baud = self.get(Register.ID), self.get(Register.BAUD_RATE)
        for spec in self.table.registers.values():
            self._put(spec.register, spec.default)
        if keep_id:
            self._put(Register.ID, sid)
        if keep_baud:
            self._put(Register.BAUD_RATE, baud)
        self.alarm_bits = 0
        self.target = self.actual
        self.velocity = self.accel = 0.0

    def _put(self, reg: Register, value: int) -> None:
        spec = self._regs[reg]
        self.mem[spec.address:spec.address + spec.size] = to_le(encode(spec, value), spec.size)

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
        if self.feetech:
            return self.get(Register.HARDWARE_ERROR) & 0x7F
        return 0x80 if self.get(Register.HARDWARE_ERROR) else 0

    # ---- position frames ------------------------------------------------------------------
    def _offset(self) -> int:
        u = self.vendor
        off = u.homing_sign * self.get(Register.HOMING_OFFSET)
        if u.multi_turn_mode is not None and abs(off) > u.homing_limit and \
                self.get(Register.OPERATING_MODE) != u.multi_turn_mode:
            return 0  # position mode honours only offsets within +-homing_limit (e-Manual)
        return off

    def _multi_turn(self) -> bool:
        if self.feetech:
            return bool(self.get(Register.PHASE) & 0x10)
        return self.get(Register.OPERATING_MODE) in (4, 5)

    def present_position(self) -> int:
        """Present position [tick] as the servo reports it."""
        p = round(self.actual) + self._offset()
        return p if self._multi_turn() else p % self.table.ticks_per_rev

    def set_present_position(self, ticks: int) -> None:
        """Move the shaft by hand so that the present position reads ``ticks`` (torque off)."""
        self._update(self.clock.now())
        self.actual += ticks - self.present_position()
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
            if not self._multi_turn():
                n = self.table.ticks_per_rev
                delta = (delta + n // 2) % n - n // 2
            at = self.actual + delta
        side = 0 if abs(self.actual - at) < 0.5 else (1 if self.actual > at else -1)
        self.obstacle = (at, side)

    def _pressing(self) -> bool:
        """Whether the shaft is held by the obstacle while the goal lies beyond it."""
        if self.obstacle is None or not self.torque:
            return False
        at, side = self.obstacle
        return abs(self.actual - at) < 0.5 and (side == 0 or (self.target - at) * side < 0)

    # ---- dynamics -------------------------------------------------------------------------
    def _limits(self) -> tuple[float, float]:
        vmax = self.table.max_speed
        u = self.vendor
        v = abs(self.get(Register.PROFILE_VELOCITY)) * u.velocity_unit
        if v == 0 and self.table.has(Register.VELOCITY_LIMIT):
            v = self.get(Register.VELOCITY_LIMIT) * u.velocity_unit
        a = self.get(Register.PROFILE_ACCELERATION) * u.acceleration_unit
        v = vmax if v <= 0 else min(v, vmax)
        return v, (8.0 * vmax if a <= 0 else a)

    def _update(self, now: float) -> None:
        dt = now - self.t
        self.t = now
        if dt <= 0:
            return
        if not self.torque:
            self.velocity, self.accel = 0.0, 0.0
            return
        vmax, amax = self._limits()
        while dt > 0:
            h = min(dt, _STEP)
            dt -= h
            err = self.target - self.actual
            want = math.copysign(min(vmax, math.sqrt(2.0 * amax * abs(err))), err)
            dv = max(-amax * h, min(amax * h, want - self.velocity))
            self.accel = dv / h
            self.velocity += dv
            self.actual += self.velocity * h
            if self.obstacle is not None:
                at, side = self.obstacle
                if (side == 0 and self.actual != at) or (self.actual - at) * side < 0:
                    self.actual, self.velocity, self.accel = at, 0.0, 0.0  # stopped by it
            if abs(self.target - self.actual) < 0.5 and abs(self.velocity) < amax * _STEP:
                self.actual, self.velocity, self.accel = self.target, 0.0, 0.0
                break

    def _refresh(self) -> None:
        """Write the present-state registers from the dynamics."""
        load = 0.0
        if self.torque:
            vmax, amax = self._limits()
            load = 0.35 * self.accel / amax + 0.15 * self.velocity / vmax + 0.05
        if self._pressing():
            load = math.copysign(0.95, self.target - self.actual)
        if self.alarm_bits & 0x20:
            load = 1.0
        load = max(-1.0, min(1.0, load))
        self._put(Register.PRESENT_POSITION, self.present_position())
        self._put(Register.PRESENT_VELOCITY, round(self.velocity / self.vendor.velocity_unit))
        self._put(Register.PRESENT_LOAD, round(1000 * load))
        volts = self.table.nominal_voltage
        if self.alarm_bits & 0x01:
            volts = self.get(Register.MAX_VOLTAGE_LIMIT) / 10.0 + 1.0
        self._put(Register.PRESENT_VOLTAGE, round(10 * volts))
        temp = 31 + round(8 * abs(load))
        if self.alarm_bits & 0x04:
            temp = self.get(Register.TEMPERATURE_LIMIT) + 2
        self._put(Register.PRESENT_TEMPERATURE, temp)
        self._put(Register.MOVING, int(abs(self.velocity) > 1.0))
        self._put(Register.HARDWARE_ERROR, self.alarm_bits)

    def clear_multi_turn(self) -> int:
        """Dynamixel Clear: drop the turn count (0, or Result Fail while moving)."""
        self._update(self.clock.now())
        if abs(self.velocity) > 1.0:
            return 1
        n = self.table.ticks_per_rev
        self.actual -= n * math.floor(self.actual / n)
        self.target = self.actual
        return 0

    # ---- alarms and reboot ----------------------------------------------------------------
    def raise_alarm(self, bits: int) -> None:
        """Latch hardware alarm bits (family bit layout); overload/overheat drop torque."""
        self._update(self.clock.now())
        self.alarm_bits |= bits
        if bits & 0x24:  # overheating or overload: the servo switches its torque off
            self._put(Register.TORQUE_ENABLE, 0)
            self.velocity = self.accel = 0.0
        self._refresh()

    def reboot(self) -> None:
        """Reboot: RAM back to defaults, alarms and lock-up cleared, position kept."""
        self._update(self.clock.now())
        for spec in self.table.registers.values():
            if spec.address >= self.table.eeprom_end:
                self._put(spec.register, spec.default)
        self.alarm_bits = 0
        self.locked_up = False
        self.registered = None
        self.target = self.actual
        self.velocity = self.accel = 0.0
        self._refresh()

    # ---- host access ----------------------------------------------------------------------
    def read(self, address: int, length: int) -> bytes | None:
        """The bytes at ``address`` (``None``: outside the table, a Dynamixel access error)."""
        if address < 0 or length < 0 or address + length > self.table.memory_size:
            return None
        self._update(self.clock.now())
        if address + length > self._present_from:  # only then the present state is needed
            self._refresh()
        return bytes(self.mem[address:address + length])

    def write(self, address: int, data: bytes) -> int:
        """Write ``data`` at ``address`` under the access rules.

        Returns:
            0, or a Dynamixel error number (Feetech always returns 0 and ignores bad writes).
        """
        self._update(self.clock.now())
        end = address + len(data)
        specs = []
        a = address
        while a < end:
            spec = self._cover.get(a)
            if spec is None or not spec.writable:
                return ERR_ACCESS if self.vendor.reports_errors else 0
            if spec.address != a or spec.address + spec.size > end:
                return ERR_LENGTH if self.vendor.reports_errors else 0
            specs.append(spec)
            a += spec.size
        values = {}
        for spec in specs:
            raw = from_le(data[spec.address - address:spec.address - address + spec.size])
            values[spec.register] = decode(spec, raw)
        eeprom = any(s.address < self.table.eeprom_end for s in specs)
        if self.feetech:
            if eeprom and (self.torque or self.get(Register.LOCK) == 1):
                values = {r: v for r, v in values.items()
                          if self.table.spec(r).address >= self.table.eeprom_end}
            values = {r: v for r, v in values.items()
                      if self.table.spec(r).lo <= v <= self.table.spec(r).hi}
        else:
            if eeprom and self.torque:
                return ERR_ACCESS
            for reg, v in values.items():
                spec = self.table.spec(reg)
                if not spec.lo <= v <= spec.hi:
                    return ERR_RANGE
                if reg is Register.OPERATING_MODE and v not in self.table.operating_modes:
                    return ERR_RANGE
            goal = values.get(Register.GOAL_POSITION)
            if goal is not None and not self._multi_turn() and not (
                    self.get(Register.MIN_POSITION_LIMIT) <= goal
                    <= self.get(Register.MAX_POSITION_LIMIT)):
                return ERR_LIMIT
        for reg, v in values.items():
            self._apply(reg, v)
        return 0

    def _apply(self, reg: Register, value: int) -> None:
        if reg is Register.TORQUE_ENABLE:
            if self.feetech and value == 128:  # CalibrationOfs: present position becomes 2048
                raw = round(self.actual) % self.table.ticks_per_rev
                self._put(Register.HOMING_OFFSET, raw - 2048)
                return
            if value and self.alarm_bits & 0x24:
                return  # torque cannot come back while the alarm is latched
            if value and not self.torque:
                self.target = self.actual
                self._put(Register.GOAL_POSITION, self.present_position())
        if reg is Register.GOAL_POSITION:
            if self.feetech:
                lo = self.get(Register.MIN_POSITION_LIMIT)
                hi = self.get(Register.MAX_POSITION_LIMIT)
                if lo or hi:
                    value = max(lo, min(hi, value))
            self.target = self.actual + (value - self.present_position())
        if reg in (Register.OPERATING_MODE, Register.HOMING_OFFSET, Register.PHASE):
            self.target = self.actual
        self._put(reg, value)
