"""The motor of a simulated servo and the control loops that drive it.

A DC motor behind a gear train, seen at the output shaft (parameters per model in
:mod:`armctl.servo_tables.motors`), integrated at a fixed step of :data:`STEP` in the time of the
servo's clock::

    i = (u V - Ke w) / R                      winding current [A] (inductance neglected)
    J dw/dt = Kt i - Tc sgn(w) - b w - T_ext   output torque balance [N m]

``u`` is the PWM duty in [-1, 1] that the operating mode's controller (:class:`ControlMode`)
computes each step:

* PWM: the goal duty, open loop.
* Current: an ideal current loop, ``u = (i_goal R + Ke w) / V``.
* Velocity: the goal velocity ramped by the profile acceleration, then a PI loop.
* Position (single-turn, extended, current-based, step): a profile generator (trapezoidal,
  triangular or rectangular velocity profile, or a step; velocity- or time-based) feeding a PID
  loop with feed-forward; current-based position then limits the current to the goal current.

The duty is limited by :attr:`Command.duty_limit`. Present PWM, current, load, velocity,
trajectory, moving status and temperature follow from the state. Which Operating Mode number
runs which controller, and how a family's registers become a :class:`Command` (units, gain
conversions), the servo's :class:`~armctl.servo.sim.rules.ServoRules` say. Positions are in
encoder ticks ("encoder frame": before the homing offset, and in the motor's own direction;
Drive Mode's reverse bit mirrors the register frame, see :class:`Command`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum

from armctl.servo_tables import ControlTable, Register
from armctl.servo_tables.motors import MotorSpec

__all__ = ["COMMAND_REGISTERS", "STEP", "Command", "ControlMode", "Drive", "ExternalLoad",
           "command_spans"]

STEP = 0.001  # [s] integration step (the servo firmware's control period is about 1 ms)
AMBIENT = 31.0  # [degC] an idle servo inside: room temperature plus its electronics
SUPPLY_RESISTANCE = 0.1  # [ohm] the supply's source resistance: the input voltage sags under load

#: An external torque on the output shaft [N m]: a constant, or a function of the encoder
#: position [rad], the velocity [rad/s] and the time [s].
ExternalLoad = float | Callable[[float, float, float], float]

IN_POSITION_WINDOW = 8.0  # [tick] In-Position bit of Moving Status (not published for X series)
FOLLOWING_ERROR = 512.0  # [tick] Following Error bit: the shaft lags its trajectory this much

# Moving Status (e-Manual X series "Moving Status")
IN_POSITION, PROFILE_ONGOING, FOLLOWING = 0x01, 0x02, 0x08
TRAPEZOIDAL, TRIANGULAR, RECTANGULAR = 0x30, 0x20, 0x10


class ControlMode(Enum):
    """What the controller holds to (an Operating Mode, whatever its number)."""

    CURRENT = "current"
    VELOCITY = "velocity"
    POSITION = "position"
    EXTENDED_POSITION = "extended_position"
    CURRENT_POSITION = "current_based_position"
    PWM = "pwm"
    STEP = "step"

    @property
    def positional(self) -> bool:
        """Whether the mode follows a goal position."""
        return self in _POSITIONAL


_POSITIONAL = frozenset({ControlMode.POSITION, ControlMode.EXTENDED_POSITION,
                         ControlMode.CURRENT_POSITION, ControlMode.STEP})


@dataclass(frozen=True)
class Command:
    """The control inputs of one servo, read from its registers (encoder frame, SI-like units).

    Attributes:
        mode: The operating mode.
        torque: Whether torque is on (Torque Enable).
        temperature_limit: Temperature Limit [degC] (0: none).
        direction: +1, or -1 when Drive Mode's reverse bit is set (register frame = direction x
            encoder frame).
        time_based: Drive Mode's time-based profile bit: profile velocity/acceleration are
            times [s].
        profile_velocity: [tick/s] (0: no limit), or the move time [s] when time-based.
        profile_acceleration: [tick/s^2] (0: no limit), or the acceleration time [s].
        kp: Position proportional gain [duty/tick].
        ki: Position integral gain [duty/(tick s)].
        kd: Position derivative gain [duty/(tick/s)].
        kff1: Velocity feed-forward [duty/(tick/s)].
        kff2: Acceleration feed-forward [duty/(tick/s^2)].
        kvp: Velocity proportional gain [duty/(tick/s)].
        kvi: Velocity integral gain [duty/(tick/s s)].
        duty_limit: Largest duty magnitude (PWM Limit, Goal PWM, Torque_Limit) in [0, 1].
        current_limit: Largest current magnitude in current-limited modes [A].
        goal_velocity: [tick/s] (velocity mode).
        goal_current: [A] (current mode).
        goal_duty: [-1, 1] (PWM mode).
        dead_zone: Position error the loop ignores [tick] (CW/CCW dead zones).
        moving_threshold: Speed above which the servo reports Moving [tick/s].
        overload: Overload protection: (fraction of the stall current, time [s]), or ``None``.
        overcurrent: Overcurrent protection: (current [A], time [s]), or ``None``.
    """

    mode: ControlMode
    torque: bool = False
    temperature_limit: float = 0.0
    direction: int = 1
    time_based: bool = False
    profile_velocity: float = 0.0
    profile_acceleration: float = 0.0
    kp: float = 0.0
    ki: float = 0.0
    kd: float = 0.0
    kff1: float = 0.0
    kff2: float = 0.0
    kvp: float = 0.0
    kvi: float = 0.0
    duty_limit: float = 1.0
    current_limit: float = math.inf
    goal_velocity: float = 0.0
    goal_current: float = 0.0
    goal_duty: float = 0.0
    dead_zone: float = 0.0
    moving_threshold: float = 1.0
    overload: tuple[float, float] | None = None
    overcurrent: tuple[float, float] | None = None


#: Every register a family's :meth:`~armctl.servo.sim.rules.ServoRules.command` reads (a
#: change of any of them changes the command).
COMMAND_REGISTERS = (
    Register.TORQUE_ENABLE, Register.TEMPERATURE_LIMIT, Register.HOMING_OFFSET, Register.PHASE,
    Register.OPERATING_MODE, Register.DRIVE_MODE, Register.TORQUE_LIMIT, Register.MAX_TORQUE,
    Register.HARDWARE_ERROR, Register.PROTECTIVE_TORQUE, Register.PROFILE_VELOCITY,
    Register.PROFILE_ACCELERATION, Register.MAX_ACCELERATION, Register.CW_DEAD_ZONE,
    Register.CCW_DEAD_ZONE, Register.OVERLOAD_TORQUE, Register.PROTECTION_TIME,
    Register.PROTECTION_CURRENT, Register.OVERCURRENT_PROTECTION_TIME, Register.GOAL_TIME,
    Register.P_GAIN, Register.I_GAIN, Register.D_GAIN, Register.PWM_LIMIT, Register.GOAL_PWM,
    Register.CURRENT_LIMIT, Register.GOAL_CURRENT, Register.VELOCITY_LIMIT,
    Register.FEEDFORWARD_1ST_GAIN, Register.FEEDFORWARD_2ND_GAIN, Register.VELOCITY_P_GAIN,
    Register.VELOCITY_I_GAIN, Register.GOAL_VELOCITY, Register.MOVING_THRESHOLD,
)


def command_spans(table: ControlTable) -> tuple[tuple[int, int], ...]:
    """Address ranges ``[start, end)`` covering :data:`COMMAND_REGISTERS` of ``table``."""
    spans: list[list[int]] = []
    for spec in sorted((table.spec(r) for r in COMMAND_REGISTERS if table.has(r)),
                       key=lambda s: s.address):
        if spans and spec.address <= spans[-1][1] + 8:
            spans[-1][1] = max(spans[-1][1], spec.address + spec.size)
        else:
            spans.append([spec.address, spec.address + spec.size])
    return tuple((a, b) for a, b in spans)


class Drive:
    """The motor, gear train and controller state of one servo.

    Args:
        motor: The model's motor parameters.
        ticks_per_rev: Encoder ticks per output turn.
        position: Initial encoder position [tick].

    Attributes:
        pos: Encoder position [tick] (float: the shaft is between ticks).
        vel: Velocity [tick/s].
        current: Winding current [A] (signed, encoder direction).
        duty: Applied PWM duty in [-1, 1] (encoder direction).
        goal: Goal position [tick] (positional modes).
        traj_pos: Position trajectory of the profile [tick].
        traj_vel: Velocity trajectory [tick/s].
        temperature: Winding temperature [degC].
        load: External torque on the shaft (see :data:`ExternalLoad`).
        extra_inertia: Inertia of what the shaft carries [kg m^2].
        obstacle: (encoder position [tick], side +1/-1/0 the shaft must stay on), or ``None``.
        profile_type: Moving Status profile bits of the move in progress.
    """

    def __init__(self, motor: MotorSpec, ticks_per_rev: int, position: float):
        self.motor = motor
        self.tick = ticks_per_rev / (2.0 * math.pi)  # [tick/rad]
        self._r = motor.resistance
        self._ke = motor.back_emf_constant / self.tick  # [V per tick/s]
        self._kt = motor.torque_constant
        self._tc = motor.coulomb_friction
        self._b = motor.viscous_friction / self.tick  # [N m per tick/s]
        self._v = motor.voltage
        self.pos = float(position)
        self.vel = 0.0
        self.current = 0.0
        self.duty = 0.0
        self.goal = float(position)
        self.traj_pos = float(position)
        self.traj_vel = 0.0
        self.traj_acc = 0.0
        self.temperature = AMBIENT
        self.load: ExternalLoad = 0.0
        self.extra_inertia = 0.0
        self.obstacle: tuple[float, int] | None = None
        self.profile_type = 0
        self.time = 0.0
        self._integ = 0.0  # position error integral [tick s]
        self._vinteg = 0.0  # velocity error integral [tick]
        self._prof: tuple[float, float] = (0.0, 0.0)  # (velocity, acceleration) of the move
        self._overload = 0.0  # [s] time over the overload torque
        self._overcurrent = 0.0  # [s] time over the protection current
        self._i2 = 0.0  # sum of i^2 h over the current advance (thermal model)

    # ---- goals ---------------------------------------------------------------------------
    def hold(self, at: float | None = None) -> None:
        """Hold still where the shaft is (or at ``at``): trajectory and integrators reset."""
        p = self.pos if at is None else float(at)
        self.goal = self.traj_pos = p
        self.traj_vel = self.traj_acc = 0.0
        self._integ = self._vinteg = 0.0
        self.profile_type = 0

    def set_goal(self, goal: float, cmd: Command) -> None:
        """A new goal position [tick, encoder frame]: plan the profile from the trajectory."""
        self.goal = float(goal)
        dist = abs(self.goal - self.traj_pos)
        v, a = cmd.profile_velocity, cmd.profile_acceleration
        if cmd.time_based:  # e-Manual "Profile Velocity": t3 total, t1 acceleration time
            t3, t1 = v, min(a, v / 2.0)
            if t3 <= 0:
                v, a = 0.0, 0.0
            elif t1 <= 0:
                v, a = dist / t3, 0.0
            else:
                v = dist / (t3 - t1)
                a = v / t1
        self._prof = (v, a)
        if v <= 0:
            self.profile_type = 0
        elif a <= 0:
            self.profile_type = RECTANGULAR
        else:
            self.profile_type = TRIANGULAR if v * v / a > dist else TRAPEZOIDAL

    def profile_ongoing(self) -> bool:
        """Whether the trajectory has not reached the goal yet."""
        return self.traj_pos != self.goal or self.traj_vel != 0.0

    # ---- integration ---------------------------------------------------------------------
    def advance(self, dt: float, cmd: Command, torque: bool, t0: float = 0.0) -> int:
        """Integrate ``dt`` [s] of motion under ``cmd``.

        Args:
            dt: Time to advance [s].
            cmd: The control inputs.
            torque: Whether torque is on (off: no current, the shaft coasts).
            t0: The time at the start [s] (for a load that depends on time).

        Returns:
            Protection alarm bits (0x20 overload, 0x08 overcurrent) that stopped the
            integration early (at :attr:`time`), else 0.
        """
        self._i2 = 0.0
        alarms = 0
        remaining = dt
        constant_load = not callable(self.load)
        while remaining > 1e-12:
            if self._at_rest(cmd, torque, constant_load):
                self._i2 += self.current * self.current * remaining
                remaining = 0.0
                break
            h = STEP if remaining > STEP else remaining
            remaining -= h
            alarms = self._step(h, cmd, torque, t0 + dt - remaining)
            if alarms:
                self._overload = self._overcurrent = 0.0
                break
        elapsed = dt - remaining
        self._heat(elapsed)
        self.time = t0 + elapsed
        return alarms

    def _at_rest(self, cmd: Command, torque: bool, constant_load: bool) -> bool:
        """Whether nothing would change over the next step (the steps can be skipped)."""
        if self.vel != 0.0 or not constant_load:
            return False
        t_ext = float(self.load)  # type: ignore[arg-type]
        if not torque:
            self.current = self.duty = 0.0
            return abs(t_ext) <= self._tc
        mode = cmd.mode
        if mode.positional:
            if self.traj_pos != self.goal or self.traj_vel != 0.0:
                return False
            if cmd.ki != 0.0 and round(self.pos) != self.goal:
                return False
        elif mode is ControlMode.VELOCITY and (cmd.goal_velocity != 0.0 or self.traj_vel != 0.0):
            return False
        # the duty of the last step holds, and its torque stays below the dry friction or
        # presses the shaft against an obstacle
        i = self.current
        if self.duty != self._duty(cmd, 0.0) or i != (self.duty * self._v) / self._r:
            return False  # the current still follows a change (the shaft just stopped)
        if cmd.overload is not None and abs(i) / self.motor.stall_current >= cmd.overload[0] > 0:
            return False  # the protection's timer runs
        if cmd.overcurrent is not None and abs(i) >= cmd.overcurrent[0] > 0:
            return False
        push = self._kt * i - t_ext
        if abs(push) <= self._tc:
            return True
        if self.obstacle is None:
            return False
        at, side = self.obstacle
        return self.pos == at and (side == 0 or push * side < 0)

    def _profile(self, h: float, cmd: Command) -> None:
        """Advance the trajectory generator by ``h`` [s]."""
        mode = cmd.mode
        if mode is ControlMode.VELOCITY:
            a = cmd.profile_acceleration
            dv = cmd.goal_velocity - self.traj_vel
            if a > 0:
                dv = max(-a * h, min(a * h, dv))
            self.traj_vel += dv
            self.traj_acc = dv / h
            self.traj_pos += self.traj_vel * h
            return
        if not mode.positional:
            self.traj_pos, self.traj_vel, self.traj_acc = self.pos, self.vel, 0.0
            return
        err = self.goal - self.traj_pos
        if err == 0.0 and self.traj_vel == 0.0:
            self.traj_acc = 0.0
            return
        v, a = self._prof
        if v <= 0:  # no profile: the goal is a step
            self.traj_pos, self.traj_vel, self.traj_acc = self.goal, 0.0, 0.0
            return
        if a > 0:
            want = math.copysign(min(v, math.sqrt(2.0 * a * abs(err))), err)
            dv = max(-a * h, min(a * h, want - self.traj_vel))
        else:
            want = math.copysign(min(v, abs(err) / h), err)
            dv = want - self.traj_vel
        self.traj_vel += dv
        self.traj_acc = dv / h
        step = self.traj_vel * h
        if abs(step) >= abs(err) or (abs(err) < 0.5 and abs(self.traj_vel) <= a * h + 1e-9):
            self.traj_pos, self.traj_vel, self.traj_acc = self.goal, 0.0, 0.0
        else:
            self.traj_pos += step

    def _duty(self, cmd: Command, h: float) -> float:
        """The controller's duty for the present state (``h`` > 0 integrates its I terms)."""
        mode = cmd.mode
        r, v = self._r, self._v
        if mode is ControlMode.PWM:
            u = cmd.goal_duty
        elif mode is ControlMode.CURRENT:
            u = (cmd.goal_current * r + self._ke * self.vel) / v
        elif mode is ControlMode.VELOCITY:
            ev = self.traj_vel - self.vel
            self._vinteg += ev * h
            u = cmd.kvp * ev + cmd.kvi * self._vinteg
        else:
            e = self.traj_pos - round(self.pos)  # the controller sees whole encoder ticks
            if abs(e) <= cmd.dead_zone:
                e = 0.0
            self._integ += e * h
            u = (cmd.kp * e + cmd.ki * self._integ + cmd.kd * (self.traj_vel - self.vel)
                 + cmd.kff1 * self.traj_vel + cmd.kff2 * self.traj_acc)
        lim = cmd.duty_limit
        if u > lim or u < -lim:
            u = math.copysign(lim, u)
            if h > 0.0:  # anti-windup: stop integrating while saturated
                self._integ -= (self.traj_pos - round(self.pos)) * h if mode.positional else 0.0
                self._vinteg -= (self.traj_vel - self.vel) * h if mode is ControlMode.VELOCITY \
                    else 0.0
        ilim = cmd.current_limit
        if ilim != math.inf:
            i = (u * v - self._ke * self.vel) / r
            if i > ilim or i < -ilim:
                u = (math.copysign(ilim, i) * r + self._ke * self.vel) / v
                u = max(-lim, min(lim, u))
        return u

    def _step(self, h: float, cmd: Command, torque: bool, t: float) -> int:
        """One integration step of ``h`` [s] ending at time ``t``; returns protection alarms."""
        alarms = 0
        if torque:
            self._profile(h, cmd)
            u = self._duty(cmd, h)
            i = (u * self._v - self._ke * self.vel) / self._r
        else:
            u = i = 0.0
            self.traj_pos, self.traj_vel, self.traj_acc = self.pos, self.vel, 0.0
        self.duty, self.current = u, i
        self._i2 += i * i * h
        load = self.load
        t_ext = float(load(self.pos / self.tick, self.vel / self.tick, t)) if callable(load) \
            else float(load)
        drive = self._kt * i - t_ext - self._b * self.vel
        kj = self.tick / (self.motor.inertia + self.extra_inertia)  # [tick/s^2 per N m]
        tc = self._tc
        vel = self.vel
        if vel == 0.0:
            if -tc <= drive <= tc:  # stiction holds
                acc = 0.0
            else:
                acc = (drive - math.copysign(tc, drive)) * kj
            new = acc * h
        else:
            new = vel + (drive - math.copysign(tc, vel)) * kj * h
            if new * vel < 0.0:  # friction stops it within the step
                new = 0.0 if -tc <= drive <= tc else new
        self.vel = new
        self.pos += new * h
        if self.obstacle is not None:
            at, side = self.obstacle
            if (side == 0 and self.pos != at) or (self.pos - at) * side < 0:
                self.pos, self.vel = at, 0.0  # stopped by it
        if cmd.overload is not None and torque:
            frac, limit = cmd.overload
            over = abs(i) / self.motor.stall_current >= frac > 0
            self._overload = self._overload + h if over else 0.0
            if over and self._overload >= limit:
                alarms |= 0x20
        if cmd.overcurrent is not None and torque:
            amps, limit = cmd.overcurrent
            over = abs(i) >= amps > 0
            self._overcurrent = self._overcurrent + h if over else 0.0
            if over and self._overcurrent >= limit:
                alarms |= 0x08
        return alarms

    def _heat(self, dt: float) -> None:
        """First-order thermal model: ``tau dT/dt = P Rth - (T - T_amb)``, P = mean I^2 R."""
        if dt <= 0:
            return
        m = self.motor
        power = self._i2 / dt * m.resistance
        target = AMBIENT + power * m.thermal_resistance
        self.temperature = target + (self.temperature - target) * math.exp(
            -dt / m.thermal_time_constant)

    # ---- readings ------------------------------------------------------------------------
    def supply_voltage(self) -> float:
        """The input voltage under the present current [V]."""
        return self._v - SUPPLY_RESISTANCE * abs(self.current)

    def load_fraction(self) -> float:
        """Output torque of the motor as a fraction of the stall torque (signed)."""
        return self.current / self.motor.stall_current

    def moving_status(self, cmd: Command) -> int:
        """Moving Status bits (e-Manual X series)."""
        if not cmd.mode.positional:
            return 0
        bits = self.profile_type
        if self.profile_ongoing():
            bits |= PROFILE_ONGOING
        elif abs(self.goal - self.pos) <= IN_POSITION_WINDOW:
            bits |= IN_POSITION
        if abs(self.traj_pos - self.pos) > FOLLOWING_ERROR:
            bits |= FOLLOWING
        return bits
