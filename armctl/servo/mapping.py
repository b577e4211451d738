"""The joint <-> servo mapping: the one place where joint values become servo ticks.

For a joint with servo zero tick ``z``, joint value at that tick ``q0``, direction ``d`` (+1/-1),
gear ratio ``g`` (servo turns per joint turn, or servo [rad] per joint [m] for a prismatic joint)
and ``N`` ticks per servo turn::

    ticks = z + d * g * (q - q0) * N / (2 pi)          q = q0 + d * (ticks - z) * 2 pi / (g N)

Without calibration ``z`` is the servo's centre tick (``N / 2``) and ``q0`` the config's
``offset``; a calibration file replaces both with measured values and narrows the limits to the
measured range. Joint limits are checked here, before any tick is computed for a write.

Single-turn servos report 0..N-1: a reading is unwrapped onto the side of the encoder wrap that
lies nearest the joint's range. A goal whose ticks would fall outside 0..N-1 means the encoder
wrap lies inside the joint's travel; that is refused (calibrate to move the wrap out of the
travel). Joints whose range exceeds one servo turn use multi-turn (extended position) mode,
available on Dynamixel X servos.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

from armctl.config.schema import ArmSpec, JointType
from armctl.errors import ConfigError, InputError, JointLimitError, KeyPath, UnknownNameError
from armctl.servo.calibration import Calibration, JointCalibration
from armctl.servo_tables import Register, Vendor, table_for

__all__ = ["JointMap", "JointMapping", "LimitSource"]

_TURN_MARGIN = 0.97  # a joint using more than this fraction of a servo turn needs multi-turn
_EPS = 1e-9


class LimitSource(Enum):
    """Where one side of a joint's range comes from (see :mod:`armctl.servo.effective_limits`)."""

    CONFIG = "config"  # the arm YAML's joint limits
    CALIBRATION = "calibration"  # the range swept during 'armctl calibrate'
    SERVO_REGISTER = "servo_register"  # the servo's own Min/Max Position Limit register

    def advice(self) -> str:
        """What to do about a value beyond a side bounded by this source (one sentence).

        The one place for this advice: the mapping's own check and the effective limits
        (:mod:`armctl.servo.effective_limits`, which adds the register's name and value) use it.
        """
        if self is LimitSource.CALIBRATION:
            return ("Choose a value inside the limits, or re-run 'armctl calibrate CONFIG' and "
                    "sweep the joint further (to its mechanical stop) to use more travel.")
        if self is LimitSource.SERVO_REGISTER:
            return ("Choose a value inside the limits, or write a wider value to the servo's "
                    "own position limit register (torque off) to use more travel.")
        return ("Choose a value inside the limits, or widen them in the arm config if the joint "
                "can really go further.")


@dataclass(frozen=True)
class JointMap:
    """The mapping of one joint onto its servo.

    Attributes:
        name: Joint name.
        servo_id: Servo id.
        model: Servo model.
        joint_type: Revolute, continuous or prismatic.
        zero_tick: Servo position [tick] where the joint value is ``zero_value``.
        zero_value: Joint value [rad] or [m] at ``zero_tick``.
        direction: +1, or -1 when the servo turns against the joint axis.
        gear_ratio: Servo turns per joint turn (servo [rad] per joint [m] when prismatic).
        lower: Lowest joint value allowed [rad] or [m].
        upper: Highest joint value allowed.
        ticks_per_rev: Encoder ticks per servo turn.
        multi_turn: Whether the servo runs in multi-turn (extended position) mode.
        rest: A safe joint value inside the limits (home pose, else 0 clipped).
        homing_offset: The Homing Offset register value this mapping assumes [tick].
        lower_source: What bounds ``lower``: the config, or the calibrated range.
        upper_source: What bounds ``upper``.
        servo_reverse: Whether the servo's Drive Mode register must have its reverse bit set
            (``True``) or clear (``False``), from a calibration that recorded it; ``None``
            leaves the register alone.
    """

    name: str
    servo_id: int
    model: str
    joint_type: JointType
    zero_tick: float
    zero_value: float
    direction: int
    gear_ratio: float
    lower: float
    upper: float
    ticks_per_rev: int = 4096
    multi_turn: bool = False
    rest: float = 0.0
    homing_offset: int = 0
    lower_source: LimitSource = LimitSource.CONFIG
    upper_source: LimitSource = LimitSource.CONFIG
    servo_reverse: bool | None = None

    @property
    def _k(self) -> float:
        """Ticks per joint unit, signed."""
        return self.direction * self.gear_ratio * self.ticks_per_rev / (2.0 * math.pi)

    def to_ticks(self, q: float) -> float:
        """Servo position [tick] (unrounded, unwrapped) for joint value ``q``."""
        return self.zero_tick + self._k * (q - self.zero_value)

    def to_joint_raw(self, ticks: float) -> float:
        """Joint value for ``ticks`` without unwrapping."""
        return self.zero_value + (float(ticks) - self.zero_tick) / self._k

    def to_joint(self, ticks: float) -> float:
        """Joint value for a reported servo position, unwrapped on single-turn servos."""
        t = float(ticks)
        if not self.multi_turn and math.isfinite(self.lower) and math.isfinite(self.upper):
            lo, hi = sorted((self.to_ticks(self.lower), self.to_ticks(self.upper)))
            n = self.ticks_per_rev
            best = min((t + k * n for k in (-1, 0, 1)),
                       key=lambda c: max(lo - c, 0.0, c - hi))
            t = best
        return self.zero_value + (t - self.zero_tick) / self._k

    def check(self, q: float, context: str = "") -> None:
        """Refuse a value outside the limits (or not a number).

        Raises:
            JointLimitError: Outside ``[lower, upper]``; the advice names the source of the
                limit that was crossed (the config or the calibration).
        """
        if not (self.lower - _EPS <= q <= self.upper + _EPS):
            source = self.lower_source if q < self.lower else self.upper_source
            if q != q:  # NaN
                source = LimitSource.CONFIG
            raise JointLimitError(self.name, float(q), self.lower, self.upper, context,
                                  advice=f"That limit is the {source.value.replace('_', ' ')}'s. "
                                  + source.advice())

    def goal_ticks(self, q: float) -> int:
        """The goal position [tick] to send for ``q`` (limits checked first).

        Raises:
            JointLimitError: ``q`` is outside the limits.
            ConfigError: The goal lies across the encoder wrap of a single-turn servo.
        """
        self.check(q, "servo goal")
        t = round(self.to_ticks(q))
        if not self.multi_turn and not 0 <= t < self.ticks_per_rev:
            raise ConfigError(
                f"joint {self.name!r}: {q:.6g} needs servo tick {t}, outside the single-turn "
                f"range 0..{self.ticks_per_rev - 1}: the encoder wrap lies inside the joint's "
                "travel; nothing was sent",
                fix="run 'armctl calibrate CONFIG' (it moves the wrap out of the travel) or "
                    "fix the joint's offset in the bus section")
        return t

    def wrap_inside(self) -> bool:
        """Whether the joint's range crosses the single-turn encoder wrap."""
        if self.multi_turn or not (math.isfinite(self.lower) and math.isfinite(self.upper)):
            return False
        lo, hi = sorted((self.to_ticks(self.lower), self.to_ticks(self.upper)))
        return lo < -0.5 or hi > self.ticks_per_rev - 0.5


def calibrated_range(j: JointMap, cal: JointCalibration) -> tuple[float, float]:
    """The joint range ``(lower, upper)`` [rad]/[m] swept during calibration.

    Args:
        j: The joint's mapping built with that calibration's zero tick and value.
        cal: The joint's calibration.
    """
    a, b = sorted((j.to_joint_raw(cal.min_tick), j.to_joint_raw(cal.max_tick)))
    return a, b


def _unwrap_window(j: JointMap) -> tuple[float, float, int, bool]:
    """The tick range a reading of ``j`` is unwrapped towards, for :meth:`JointMapping.from_ticks`.

    Returns:
        ``(lo, hi, n, window)``: the joint's range in ticks ``lo <= hi`` and the ticks per turn
        ``n`` as :meth:`JointMap.to_joint` computes them, and whether the range is narrower
        than a turn (at most one of ``t - n, t, t + n`` lies inside it: the fast rule). ``n``
        is 0 when readings are not unwrapped (multi-turn, or an unbounded range).
    """
    if j.multi_turn or not (math.isfinite(j.lower) and math.isfinite(j.upper)):
        return 0.0, 0.0, 0, False
    lo, hi = sorted((j.to_ticks(j.lower), j.to_ticks(j.upper)))
    n = j.ticks_per_rev
    return lo, hi, n, hi - lo < n


def _wrap_shift(j: JointMap, vendor: Vendor) -> int:
    """The smallest tick shift that brings a joint's travel inside 0..N-1, or 0 if none can.

    A Dynamixel servo in Position mode honours homing offsets within +-1024 only (e-Manual);
    a Feetech offset is sign-magnitude with 11 bits (+-2047).
    """
    n = j.ticks_per_rev
    lo, hi = sorted((j.to_ticks(j.lower), j.to_ticks(j.upper)))
    margin = 16.0
    if hi - lo > n - 1 - 2 * margin:
        return 0
    s_lo, s_hi = math.ceil(margin - lo), math.floor(n - 1 - margin - hi)
    shift = min(max(0, s_lo), s_hi)
    return shift if abs(shift) <= vendor.homing_limit else 0


class JointMapping:
    """The mapping of every servo-driven joint of an arm, in the arm's joint order.

    Args:
        joints: One :class:`JointMap` per servo-driven joint.
    """

    def __init__(self, joints: Sequence[JointMap]):
        self.joints: tuple[JointMap, ...] = tuple(joints)
        self.names: tuple[str, ...] = tuple(j.name for j in self.joints)
        self.ids: tuple[int, ...] = tuple(j.servo_id for j in self.joints)
        self._by_name = {j.name: j for j in self.joints}
        self.lower = np.array([j.lower for j in self.joints])
        self.upper = np.array([j.upper for j in self.joints])
        # Per-joint constants of the per-cycle conversions, computed once: the same float
        # operations as JointMap's methods (so the results are identical), without re-deriving
        # the tick range and slope of every joint on every reading. Plain tuples and a Python
        # loop: for six joints about 1 us a reading, against 6 us for the same in numpy calls.
        self._read_plan: tuple[tuple[JointMap, int, float, float, float, float, float, int,
                                     bool], ...] = tuple(
            (j, j.servo_id, j.zero_tick, j.zero_value, j._k, *_unwrap_window(j))
            for j in self.joints)
        self._goal_plan: tuple[tuple[JointMap, int, float, float, float, float, float, int],
                               ...] = tuple(
            (j, j.servo_id, j.zero_tick, j.zero_value, j._k, j.lower - _EPS, j.upper + _EPS,
             0 if j.multi_turn else j.ticks_per_rev) for j in self.joints)

    @classmethod
    def from_spec(cls, spec: ArmSpec, calibration: Calibration | None = None) -> JointMapping:
        """The mapping of an arm config's ``bus:`` section (no I/O).

        Raises:
            ConfigError: No bus section, or a joint that needs a turn count its servo lacks.
        """
        if spec.bus is None:
            raise ConfigError(f"arm {spec.name!r} has no 'bus:' section",
                              KeyPath(spec.file) if spec.file is not None else None,
                              spec.no_bus_fix(sim=False))
        by_joint = {s.joint: s for s in spec.bus.servos}
        home = spec.poses.get("home", {})
        maps = []
        for joint in spec.actuated_joints:
            s = by_joint.get(joint.name)
            if s is None:
                continue
            table = table_for(s.model)
            vendor = table.vendor
            if table.family is not spec.bus.protocol.family:
                raise ConfigError(f"servo model {s.model!r} does not speak "
                                  f"{spec.bus.protocol.value}", s.where,
                                  "fix the model or the bus protocol")
            n = table.ticks_per_rev
            lower, upper = joint.limits.lower, joint.limits.upper
            zero_tick, zero_value = n / 2.0, s.offset
            cal = calibration.joints.get(joint.name) if calibration is not None else None
            direction, servo_reverse = s.direction, None
            if cal is not None:
                zero_tick, zero_value = cal.zero_tick, cal.zero_value
                if cal.drive_mode is not None:  # reversed by the servo, else by the mapping
                    if Register.DRIVE_MODE in table.registers:
                        servo_reverse = bool(cal.drive_mode & 1)
                    elif cal.drive_mode & 1:
                        direction = -direction
            span = (upper - lower) * s.gear_ratio / (2.0 * math.pi)
            multi = joint.type is JointType.CONTINUOUS or not math.isfinite(span) or \
                span > _TURN_MARGIN or (cal is not None and cal.multi_turn)
            if multi and vendor.multi_turn_mode is None:
                raise ConfigError(
                    f"joint {joint.name!r} spans {span:.2f} servo turns; {s.model} servos are "
                    "driven single-turn by armctl", s.where,
                    "narrow the joint limits below one servo turn or use a Dynamixel servo")
            jm = JointMap(joint.name, s.id, s.model, joint.type, zero_tick, zero_value,
                          direction, s.gear_ratio, lower, upper, n, multi)
            homing = 0
            sources = (LimitSource.CONFIG, LimitSource.CONFIG)
            if cal is not None:
                a, b = calibrated_range(jm, cal)
                sources = (LimitSource.CALIBRATION if a > lower else LimitSource.CONFIG,
                           LimitSource.CALIBRATION if b < upper else LimitSource.CONFIG)
                lower, upper = max(lower, a), min(upper, b)
                homing = cal.homing_offset
            elif jm.wrap_inside():
                shift = _wrap_shift(jm, vendor)
                if shift:  # move the encoder wrap out of the travel with the homing offset
                    zero_tick += shift
                    homing = vendor.homing_sign * shift
            if joint.type.nq != 1:  # the config refuses these; a spec built in code may not
                raise ConfigError(f"arm {spec.name!r}: joint {joint.name!r} is a "
                                  f"{joint.type.value} joint, which servos cannot drive",
                                  KeyPath(spec.file) if spec.file else None,
                                  "drive 1-DOF joints with servos; remove this joint's servo "
                                  "from the 'bus:' section")
            rest_value = home.get(joint.name, 0.0)
            rest = float(rest_value) if not isinstance(rest_value, tuple) else 0.0
            rest = min(max(rest, lower), upper) if math.isfinite(lower) or math.isfinite(
                upper) else rest
            maps.append(JointMap(joint.name, s.id, s.model, joint.type, zero_tick, zero_value,
                                 direction, s.gear_ratio, lower, upper, n, multi, rest,
                                 homing, *sources, servo_reverse))
        if not maps:
            raise ConfigError(f"arm {spec.name!r}: the bus section drives no joint", None,
                              "list the servos under bus.servos by joint name")
        return cls(maps)

    def joint(self, name: str) -> JointMap:
        """The mapping of joint ``name``.

        Raises:
            UnknownNameError: For a joint without a servo.
        """
        try:
            return self._by_name[name]
        except KeyError:
            raise UnknownNameError("servo joint", name, self.names) from None

    def as_vector(self, q: npt.ArrayLike) -> npt.NDArray[np.float64]:
        """``q`` as a float vector with one value per servo joint.

        Raises:
            InputError: For the wrong length.
        """
        arr = np.asarray(q, dtype=float).reshape(-1)
        if arr.shape != (len(self.joints),):
            raise InputError(f"expected {len(self.joints)} joint values "
                             f"({', '.join(self.names)}), got {arr.size}")
        return arr

    def goal_ticks(self, q: npt.ArrayLike) -> dict[int, int]:
        """Goal ticks by servo id; every limit is checked before any tick is returned.

        Equal to :meth:`JointMap.goal_ticks` of every joint (the same checks, errors and
        rounding), with the per-joint constants computed once.

        Raises:
            InputError: For the wrong number of values.
            JointLimitError: A value outside its joint's limits (the first such joint).
            ConfigError: A goal across the encoder wrap of a single-turn servo.
        """
        values = self.as_vector(q).tolist()
        plan = self._goal_plan
        for (j, _, _, _, _, lo, hi, _), v in zip(plan, values, strict=True):
            if not lo <= v <= hi:  # NaN too
                j.check(v, "servo goal")  # raises, naming the joint and the limit's source
        out = {}
        for (j, sid, zero_tick, zero_value, k, _, _, n), v in zip(plan, values, strict=True):
            t = round(zero_tick + k * (v - zero_value))
            if n and not 0 <= t < n:
                j.goal_ticks(v)  # raises: the goal lies across the encoder wrap
            out[sid] = t
        return out

    def from_ticks(self, ticks: Mapping[int, float]) -> npt.NDArray[np.float64]:
        """Joint values from present positions by servo id.

        Equal to :meth:`JointMap.to_joint` of every joint (the same unwrapping onto the side of
        the encoder wrap nearest the joint's range), with the per-joint constants computed once.
        """
        out = []
        for j, sid, zero_tick, zero_value, k, lo, hi, n, window in self._read_plan:
            t = float(ticks[sid])
            if window:
                if t < lo:  # below the range: one turn up if that lies nearer to it
                    c = t + n
                    if max(lo - c, 0.0, c - hi) < lo - t:
                        t = c
                elif t > hi:  # above: one turn down if that lies as near or nearer
                    c = t - n
                    if max(lo - c, 0.0, c - hi) <= t - hi:
                        t = c
            elif n:  # a range of a turn or more: the general rule
                out.append(j.to_joint(t))
                continue
            out.append(zero_value + (t - zero_tick) / k)
        return np.array(out)

