"""The calibration procedure: measures zero offsets and ranges on an open arm bus.

Procedure (:class:`Calibrator`, driven by ``armctl calibrate`` or by a test):

1. :meth:`Calibrator.start`: torque off, homing offsets reset to 0, so positions are raw encoder
   ticks.
2. :meth:`Calibrator.capture_reference`: the user holds the arm in a reference pose (all joints
   at known values, by default 0); the present ticks become each joint's zero tick.
3. :meth:`Calibrator.sample` (repeated): the user moves every joint through its full travel;
   each sample is unwrapped (a jump of more than half a turn between samples is the encoder
   wrap) and the range of each joint is tracked.
4. :meth:`Calibrator.finish`: a homing offset per single-turn joint moves the middle of its
   travel to the servo's centre tick, so the encoder wrap lies outside the travel; it is written
   to the servo and the :class:`~armctl.servo.calibration.Calibration` returned. An offset
   beyond what Position mode honours (Dynamixel: +-1024) puts the joint in extended position
   mode instead.

The result is data (:mod:`armctl.servo.calibration`); this module sits above the bus.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from armctl.errors import InputError
from armctl.servo.arm_bus import ArmBus
from armctl.servo.calibration import Calibration, JointCalibration
from armctl.servo_tables import Register, table_for

__all__ = ["Calibrator"]

_MIN_SWEEP = 40  # [tick] a joint that moved less than this was not swept


class Calibrator:
    """Step-by-step calibration on an open :class:`ArmBus` built without calibration.

    Args:
        bus: The open arm bus.
        reference: Joint values [rad] or [m] of the reference pose; missing joints are 0.
    """

    def __init__(self, bus: ArmBus, reference: Mapping[str, float] | None = None):
        if bus.calibration is not None:
            raise InputError("calibrate with an ArmBus built without a calibration")
        self.bus = bus
        self.reference = {n: float((reference or {}).get(n, 0.0)) for n in bus.joint_names}
        for n in (reference or {}):
            bus.mapping.joint(n)
        self._ref: dict[str, int] = {}
        self._last: dict[str, float] = {}
        self._lo: dict[str, float] = {}
        self._hi: dict[str, float] = {}
        self._wrapped: dict[str, bool] = {}

    def _raw(self) -> dict[str, int]:
        got = self.bus.servo_bus.read_positions(list(self.bus.mapping.ids))
        return {j.name: got[j.servo_id][0] for j in self.bus.mapping.joints}

    def start(self) -> None:
        """Torque off and homing offsets to 0 (positions become raw encoder ticks)."""
        self.bus.set_torque(False)
        sb = self.bus.servo_bus
        for j in self.bus.mapping.joints:
            if sb.read(j.servo_id, Register.HOMING_OFFSET) != 0:
                self.bus.write_eeprom(j.servo_id, [(Register.HOMING_OFFSET, 0)])

    def capture_reference(self) -> dict[str, int]:
        """Record the present ticks as the reference pose; returns them by joint."""
        self._ref = self._raw()
        for n, t in self._ref.items():
            self._last[n] = self._lo[n] = self._hi[n] = float(t)
            self._wrapped[n] = False
        return dict(self._ref)

    def sample(self) -> None:
        """Read every joint once (one sync read) and extend its unwrapped range."""
        if not self._ref:
            raise InputError("capture the reference pose before sampling the ranges")
        raw = self._raw()
        for j in self.bus.mapping.joints:
            t = float(raw[j.name])
            last = self._last[j.name]
            if not j.multi_turn:
                n = j.ticks_per_rev
                base = math.floor(last / n) * n
                t2 = min((base + t + k * n for k in (-1, 0, 1)), key=lambda c: abs(c - last))
                if math.floor(t2 / n) != math.floor(last / n):
                    self._wrapped[j.name] = True
                t = t2
            self._last[j.name] = t
            self._lo[j.name] = min(self._lo[j.name], t)
            self._hi[j.name] = max(self._hi[j.name], t)

    def finish(self) -> Calibration:
        """Compute and write the homing offsets; return the calibration.

        The arm must be held still while this runs (the present position links the sweep's
        unwrapped ticks to the new frame of a multi-turn joint).

        Raises:
            InputError: A joint was not moved in the sweep, or travels a full servo turn
                without multi-turn support.
        """
        joints = {}
        sb = self.bus.servo_bus
        for j in self.bus.mapping.joints:
            lo, hi, ref = self._lo[j.name], self._hi[j.name], float(self._ref[j.name])
            n = j.ticks_per_rev
            if hi - lo < _MIN_SWEEP:
                raise InputError(f"joint {j.name!r} (servo {j.servo_id}) moved only "
                                 f"{hi - lo:.0f} ticks during the sweep; move every joint "
                                 "through its full range")
            multi, offset, delta = j.multi_turn, 0, 0.0
            if not multi:
                if hi - lo >= n - 1:
                    raise InputError(f"joint {j.name!r} travelled a full servo turn; it needs "
                                     "multi-turn mode (widen its limits past one turn in the "
                                     "config, Dynamixel only)")
                mid = (lo + hi) / 2
                shift = round(n / 2 - mid)
                shift = (shift + n // 2) % n - n // 2
                vendor = table_for(j.model).vendor
                if vendor.multi_turn_mode is None:  # no extended mode: clamp to what is stored
                    shift = max(-vendor.homing_limit, min(vendor.homing_limit, shift))
                else:  # Position mode honours only +-homing_limit; beyond it, extended mode
                    multi = abs(shift) > vendor.homing_limit
                offset = vendor.homing_sign * shift  # present = actual + sign * offset
                # the travel moves to the middle of 0..n-1, clear of the encoder wrap
                delta = shift + ((mid + shift) % n - (mid + shift))
            if multi and not j.multi_turn:
                mode = table_for(j.model).vendor.multi_turn_mode
                assert mode is not None  # only a family with extended mode gets here  # mypy.
                self.bus.write_eeprom(j.servo_id, [(Register.OPERATING_MODE, mode)])
            if offset:
                self.bus.write_eeprom(j.servo_id, [(Register.HOMING_OFFSET, offset)])
            if multi:  # extended mode counts turns from power-up: anchor on the present reading
                present = sb.read(j.servo_id, Register.PRESENT_POSITION)
                delta = offset + n * round((present - self._last[j.name] - offset) / n)
            joints[j.name] = JointCalibration(
                servo_id=j.servo_id, zero_tick=ref + delta, zero_value=self.reference[j.name],
                min_tick=lo + delta, max_tick=hi + delta, homing_offset=offset,
                multi_turn=multi, wrap_detected=self._wrapped[j.name])
        return Calibration(self.bus.arm_name, joints)
