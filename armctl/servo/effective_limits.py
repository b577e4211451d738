"""Effective joint limits: the range each joint may really be commanded to, and where it comes from.

A joint's effective range is the intersection of

* the **config** limits (the arm YAML's ``joints[i].limits``),
* the **calibration**: the travel swept during ``armctl calibrate``, when the arm is calibrated,
* the **servo registers**: the servo's own position limits (Dynamixel Min/Max Position Limit,
  addresses 52/48; Feetech Min/Max Angle Limit, addresses 9/11), read from the servo. They are
  ignored where they limit nothing: in multi-turn (extended position) mode, when a Feetech
  servo has both at 0 (its "no limit" setting), and on a side set to the encoder's end (0 or
  ticks per turn - 1),

and the measured bounds (calibration and registers) are moved inwards by a safety margin of
:data:`MARGIN_TICKS` servo ticks, so that a goal never presses a joint against the stop it was
swept to or sits on the edge where the servo starts refusing or clamping goals. The config's
limits are the user's own choice and are used as written.

Every bound records its source, so a refused goal says which limit it crossed and how to change
that limit (edit the config, re-run the calibration, or write the servo's register).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from armctl.arm import Arm
from armctl.config.schema import ArmSpec, JointType
from armctl.errors import ConfigError, JointLimitError, KeyPath
from armctl.servo.arm_bus import ArmBus
from armctl.servo.calibration import Calibration
from armctl.servo.mapping import JointMap, JointMapping, LimitSource, calibrated_range
from armctl.servo_tables import Register, table_for
from armctl.typing import Array

__all__ = [
    "MARGIN_TICKS",
    "EffectiveLimits",
    "JointLimits",
    "LimitBound",
    "LimitSource",
    "PositionLimitRegisters",
    "effective_limits",
    "format_joint_value",
    "limits_of_bus",
    "read_position_limits",
]


#: Safety margin taken off the measured bounds (calibration, servo registers) [servo tick]:
#: 8 ticks of a 4096-tick servo are 0.70 deg of servo travel (0.0123 rad at gear ratio 1).
MARGIN_TICKS = 8
_EPS = 1e-9


@dataclass(frozen=True)
class PositionLimitRegisters:
    """A servo's own position limit registers, as read from it.

    Attributes:
        servo_id: The servo.
        minimum: Min Position Limit (Feetech Min Angle Limit) [tick].
        maximum: Max Position Limit (Feetech Max Angle Limit) [tick].
        operating_mode: The Operating Mode register (Dynamixel 3 / Feetech 0 is position mode).
    """

    servo_id: int
    minimum: int
    maximum: int
    operating_mode: int


@dataclass(frozen=True)
class LimitBound:
    """One side of a joint's effective range.

    Attributes:
        value: The bound [rad]/[m], margin applied.
        source: What sets it.
        origin: What that limit is, e.g. the config key with file and line, or the register
            and its value.
        fix: How to move it.
    """

    value: float
    source: LimitSource
    origin: str
    fix: str


@dataclass(frozen=True)
class JointLimits:
    """Everything that limits one joint, and the effective range that results.

    Attributes:
        name: Joint name.
        joint_type: Revolute, continuous or prismatic.
        servo_id: Its servo (``None`` for a joint without one).
        config: ``(lower, upper)`` of the arm config [rad]/[m].
        calibration: ``(lower, upper)`` swept during calibration, ``None`` when not calibrated.
        register: ``(lower, upper)`` the servo's position limit registers allow (``-inf`` or
            ``inf`` on a side they do not limit); ``None`` when they limit nothing, do not apply
            (multi-turn, not position mode) or were not read.
        register_ticks: ``(minimum, maximum)`` of the registers as read [tick] where they
            apply, else ``None``.
        lower: The effective lower bound.
        upper: The effective upper bound.
        margin: The safety margin of :data:`MARGIN_TICKS` servo ticks in joint units [rad]/[m]
            (0 for a joint without a servo).
    """

    name: str
    joint_type: JointType
    servo_id: int | None
    config: tuple[float, float]
    calibration: tuple[float, float] | None
    register: tuple[float, float] | None
    register_ticks: tuple[int, int] | None
    lower: LimitBound
    upper: LimitBound
    margin: float = 0.0

    def bound(self, value: float) -> LimitBound:
        """The bound that ``value`` crosses (the nearer one for a value inside)."""
        if value < self.lower.value:
            return self.lower
        if value > self.upper.value:
            return self.upper
        return self.lower if value - self.lower.value < self.upper.value - value else self.upper

    def as_dict(self) -> dict[str, Any]:
        """A JSON-friendly description (SI units, ``None`` for what is not known)."""
        return {"joint": self.name, "servo_id": self.servo_id,
                "config": list(self.config),
                "calibration": list(self.calibration) if self.calibration else None,
                "servo_register": list(self.register) if self.register else None,
                "servo_register_ticks": list(self.register_ticks) if self.register_ticks
                else None,
                "effective": [self.lower.value, self.upper.value],
                "lower_source": self.lower.source.value, "upper_source": self.upper.source.value}


@dataclass(frozen=True)
class EffectiveLimits:
    """The effective limits of an arm's joints (arm joint order).

    Attributes:
        arm: Arm name.
        joints: One entry per actuated joint.
        margin_ticks: The safety margin applied to measured bounds [tick].
    """

    arm: str
    joints: tuple[JointLimits, ...]
    margin_ticks: int = MARGIN_TICKS

    @property
    def names(self) -> tuple[str, ...]:
        """Joint names."""
        return tuple(j.name for j in self.joints)

    @property
    def lower(self) -> Array:
        """Effective lower bounds ``(dof,)`` [rad]/[m]."""
        return np.array([j.lower.value for j in self.joints])

    @property
    def upper(self) -> Array:
        """Effective upper bounds ``(dof,)`` [rad]/[m]."""
        return np.array([j.upper.value for j in self.joints])

    def joint(self, name: str) -> JointLimits:
        """The limits of joint ``name``.

        Raises:
            UnknownNameError: For a joint the arm does not have.
        """
        for j in self.joints:
            if j.name == name:
                return j
        from armctl.errors import UnknownNameError

        raise UnknownNameError("joint", name, self.names, f"arm {self.arm!r}")

    def narrowed(self) -> dict[str, tuple[str, ...]]:
        """The joints whose range is narrower than the config's, with what narrows them."""
        out = {}
        for j in self.joints:
            srcs = tuple(dict.fromkeys(b.source.value for b in (j.lower, j.upper)
                                       if b.source is not LimitSource.CONFIG))
            if srcs:
                out[j.name] = srcs
        return out

    def explain(self, joint: str, value: float) -> str:
        """Which limit ``value`` crosses, where it comes from and how to change it."""
        j = self.joint(joint)
        b = j.bound(value)
        side = "lower" if b is j.lower else "upper"
        return (f"The effective {side} limit {format_joint_value(b.value, j.joint_type)} of joint "
                f"{joint!r} is {b.origin}. {b.fix}")

    def error(self, joint: str, value: float, context: str = "") -> JointLimitError:
        """The error for ``value`` outside the effective limits of ``joint``."""
        j = self.joint(joint)
        exc = JointLimitError(joint, float(value), j.lower.value, j.upper.value, context,
                              advice=self.explain(joint, value))
        exc.details["limit_source"] = j.bound(value).source.value
        return exc

    def check(self, q: npt.ArrayLike, context: str = "", tol: float = _EPS) -> Array:
        """Return ``q`` ``(dof,)`` if every value is inside the effective limits.

        Raises:
            JointLimitError: For the first joint outside, naming the limit's source and how to
                change it.
        """
        arr = np.asarray(q, dtype=float)
        for j, v in zip(self.joints, arr, strict=True):
            if not j.lower.value - tol <= v <= j.upper.value + tol:
                raise self.error(j.name, float(v), context)
        return arr

    def apply(self, arm: Arm) -> Arm:
        """The arm with these limits as its position limits (the same arm if they are equal).

        Planners and IK solvers given the result plan and solve inside the effective limits.
        """
        if np.array_equal(self.lower, arm.lower) and np.array_equal(self.upper, arm.upper):
            return arm
        by_name = {j.name: j for j in self.joints}
        joints = []
        for js in arm.spec.joints:
            lim = by_name.get(js.name)
            if lim is not None and js.type.actuated:
                js = replace(js, limits=replace(js.limits, lower=lim.lower.value,
                                                upper=lim.upper.value))
            joints.append(js)
        return type(arm)(replace(arm.spec, joints=tuple(joints)))

    def as_dict(self) -> dict[str, Any]:
        """A JSON-friendly description, by joint name."""
        return {"margin_ticks": self.margin_ticks,
                "joints": {j.name: j.as_dict() for j in self.joints}}


# ---- building ---------------------------------------------------------------------------------
def read_position_limits(bus: ArmBus) -> dict[int, PositionLimitRegisters]:
    """Read every servo's position limit and operating mode registers (an open bus).

    Raises:
        BusError: If a servo does not answer.
    """
    sb = bus.servo_bus
    out = {}
    for j in bus.mapping.joints:
        table = table_for(j.model)
        if not (table.has(Register.MIN_POSITION_LIMIT) and table.has(Register.MAX_POSITION_LIMIT)):
            continue
        mode = sb.read(j.servo_id, Register.OPERATING_MODE) \
            if table.has(Register.OPERATING_MODE) else 0
        out[j.servo_id] = PositionLimitRegisters(
            j.servo_id, sb.read(j.servo_id, Register.MIN_POSITION_LIMIT),
            sb.read(j.servo_id, Register.MAX_POSITION_LIMIT), mode)
    return out


def limits_of_bus(spec: ArmSpec, bus: ArmBus) -> EffectiveLimits:
    """The effective limits of an arm on its open bus: config, calibration and registers.

    Raises:
        BusError: If a servo does not answer.
        ConfigError: If a joint has no allowed range left.
    """
    return effective_limits(spec, bus.calibration, read_position_limits(bus))


def effective_limits(spec: ArmSpec, calibration: Calibration | None = None,
                     registers: Mapping[int, PositionLimitRegisters] | None = None
                     ) -> EffectiveLimits:
    """The effective limits from the config, a calibration and servo registers (no I/O).

    Args:
        spec: The arm config.
        calibration: The calibration in use (``None``: not calibrated).
        registers: Position limit registers by servo id, as read (``None``: not read, as
            without a bus).

    Raises:
        ConfigError: If a joint has no allowed range left (the sources do not overlap).
    """
    maps: dict[str, JointMap] = {}
    if spec.bus is not None:
        maps = {j.name: j for j in JointMapping.from_spec(spec, calibration).joints}
    cal_file = calibration.file if calibration is not None else None
    out = []
    for js in spec.actuated_joints:
        lo, hi = js.limits.lower, js.limits.upper
        w = js.where
        fix = LimitSource.CONFIG.advice()
        lower = LimitBound(lo, LimitSource.CONFIG, _config_origin(w, "lower"), fix)
        upper = LimitBound(hi, LimitSource.CONFIG, _config_origin(w, "upper"), fix)
        jm = maps.get(js.name)
        cal_range = reg_range = reg_ticks = None
        margin = 0.0
        if jm is not None:
            margin = MARGIN_TICKS / abs(jm.to_ticks(1.0) - jm.to_ticks(0.0))
            jc = calibration.joints.get(js.name) if calibration is not None else None
            if jc is not None:
                cal_range = calibrated_range(jm, jc)
                lower, upper = _tighten(lower, upper, cal_range, margin,
                                        _calibration_bounds(cal_range, js.type, cal_file))
            regs = (registers or {}).get(jm.servo_id)
            if regs is not None and _registers_apply(jm, regs):
                reg_ticks = (regs.minimum, regs.maximum)
                reg_range = _register_range(jm, regs)
                if not any(math.isfinite(v) for v in reg_range):
                    reg_range = None  # the whole encoder range: they limit nothing
                if reg_range is not None:
                    lower, upper = _tighten(lower, upper, reg_range, margin,
                                            _register_bounds(jm, regs, reg_range))
        if lower.value > upper.value:
            raise ConfigError(
                f"joint {js.name!r} has no allowed range left: its {lower.source.value} "
                f"allows nothing below {format_joint_value(lower.value, js.type)} and its "
                f"{upper.source.value} nothing above {format_joint_value(upper.value, js.type)}",
                w, f"{lower.fix} {upper.fix}" if lower.fix != upper.fix else lower.fix)
        out.append(JointLimits(js.name, js.type, jm.servo_id if jm else None, (lo, hi),
                               cal_range, reg_range, reg_ticks, lower, upper, margin))
    return EffectiveLimits(spec.name, tuple(out))


def _config_origin(where: KeyPath, side: str) -> str:
    key = KeyPath(where.file, (*where.keys, "limits", side), where.line, where.label)
    return f"the arm config's limit ({key.where()})" if where.file else \
        f"the arm config's limit (joint {side} limit)"


def _tighten(lower: LimitBound, upper: LimitBound, rng: tuple[float, float], margin: float,
             make: tuple[Any, Any]) -> tuple[LimitBound, LimitBound]:
    """Intersect with ``rng`` moved inwards by ``margin``; ``make`` builds the new bounds."""
    lo, hi = rng[0] + margin, rng[1] - margin
    if math.isfinite(rng[0]) and lo > lower.value:
        lower = make[0](lo)
    if math.isfinite(rng[1]) and hi < upper.value:
        upper = make[1](hi)
    return lower, upper


def _calibration_bounds(rng: tuple[float, float], jtype: JointType, file: Path | None
                        ) -> tuple[Any, Any]:
    where = f" ({file})" if file is not None else ""
    fix = LimitSource.CALIBRATION.advice()

    def make(side: int) -> Any:
        swept = format_joint_value(rng[side], jtype)
        return lambda v: LimitBound(
            v, LimitSource.CALIBRATION, f"the calibrated range{where}: the joint was swept to "
            f"{swept} during 'armctl calibrate', less a safety margin of {MARGIN_TICKS} servo "
            "ticks", fix)
    return make(0), make(1)


def _registers_apply(jm: JointMap, regs: PositionLimitRegisters) -> bool:
    """Whether a servo's position limit registers limit its goals at all."""
    if jm.multi_turn:
        return False
    vendor = table_for(jm.model).vendor
    if vendor.zero_limits_off and (regs.minimum, regs.maximum) == (0, 0):
        return False
    return regs.operating_mode == vendor.position_mode


def _register_range(jm: JointMap, regs: PositionLimitRegisters) -> tuple[float, float]:
    """The joint range the registers allow (infinite on a side they do not limit)."""
    n = jm.ticks_per_rev
    lo_t = regs.minimum if regs.minimum > 0 else None
    hi_t = regs.maximum if regs.maximum < n - 1 else None
    a = jm.to_joint_raw(lo_t) if lo_t is not None else None
    b = jm.to_joint_raw(hi_t) if hi_t is not None else None
    if jm.to_ticks(1.0) < jm.to_ticks(0.0):  # ticks fall as the joint value rises
        a, b = b, a
    return (a if a is not None else -math.inf, b if b is not None else math.inf)


def _register_bounds(jm: JointMap, regs: PositionLimitRegisters, rng: tuple[float, float]
                     ) -> tuple[Any, Any]:
    table = table_for(jm.model)
    limit_name = table.vendor.position_limit_name
    falling = jm.to_ticks(1.0) < jm.to_ticks(0.0)

    def make(side: int) -> Any:
        reg = (Register.MAX_POSITION_LIMIT if (side == 1) != falling
               else Register.MIN_POSITION_LIMIT)
        ticks = regs.maximum if reg is Register.MAX_POSITION_LIMIT else regs.minimum
        label = ("Max " if reg is Register.MAX_POSITION_LIMIT else "Min ") + limit_name
        full = table.ticks_per_rev - 1 if reg is Register.MAX_POSITION_LIMIT else 0
        at = format_joint_value(rng[side], jm.joint_type)
        origin = (f"servo {jm.servo_id}'s own {label} register (address "
                  f"{table.spec(reg).address}) = {ticks} ticks, that is {at}, less a safety "
                  f"margin of {MARGIN_TICKS} servo ticks")
        fix = (f"{LimitSource.SERVO_REGISTER.advice()} It is an EEPROM register: e.g. "
               f"ArmBus.write_eeprom({jm.servo_id}, [(Register.{reg.name}, {full})]) in Python "
               "or the servo maker's setup tool; then check the config's limits still fit the "
               "arm.")
        return lambda v: LimitBound(v, LimitSource.SERVO_REGISTER, origin, fix)
    return make(0), make(1)


def format_joint_value(value: float, jtype: JointType) -> str:
    """A joint value for messages: SI units with degrees (rotary) or millimetres (prismatic)."""
    if not math.isfinite(value):
        return f"{value}"
    if jtype is JointType.PRISMATIC:
        return f"{value:.6g} m ({value * 1000:.2f} mm)"
    return f"{value:.6g} rad ({math.degrees(value):.2f} deg)"
