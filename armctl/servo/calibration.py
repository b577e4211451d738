"""Calibration: zero offsets and ranges measured on the arm, kept in a file beside the config.

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
   to the servo and the :class:`Calibration` returned. A Dynamixel offset beyond the +-1024 that
   Position mode honours puts the joint in extended position mode instead.

The file (YAML, read with :mod:`armctl.config.source`) records a format version and a hash of
its content that keyframe files can store to tell which calibration their joint values assume.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from armctl.atomic_write import write_atomic
from armctl.config.schema import ArmSpec
from armctl.config.source import load_yaml
from armctl.errors import ConfigError, InputError, KeyPath
from armctl.servo.tables import Family, Register, table_for

if TYPE_CHECKING:
    from armctl.servo.arm_bus import ArmBus

__all__ = ["Calibration", "Calibrator", "JointCalibration", "calibration_path",
           "load_calibration"]

VERSION = 1
_MIN_SWEEP = 40  # [tick] a joint that moved less than this was not swept


@dataclass(frozen=True)
class JointCalibration:
    """Calibration of one joint.

    Attributes:
        servo_id: The servo.
        zero_tick: Present position [tick] (with the homing offset applied) at the reference.
        zero_value: Joint value [rad] or [m] in the reference pose.
        min_tick: Lowest present position seen in the sweep [tick].
        max_tick: Highest present position seen in the sweep [tick].
        homing_offset: Homing offset written to the servo [tick].
        multi_turn: Whether the joint runs in multi-turn (extended position) mode.
        wrap_detected: Whether the raw encoder wrapped inside the joint's travel.
    """

    servo_id: int
    zero_tick: float
    zero_value: float
    min_tick: float
    max_tick: float
    homing_offset: int = 0
    multi_turn: bool = False
    wrap_detected: bool = False


@dataclass(frozen=True)
class Calibration:
    """An arm's calibration.

    Attributes:
        arm: Arm name.
        joints: Per joint.
        version: File format version.
        file: Where it was read from or written to.
    """

    arm: str
    joints: dict[str, JointCalibration]
    version: int = VERSION
    file: Path | None = field(default=None, compare=False)

    @property
    def hash(self) -> str:
        """A short SHA-256 of the content (arm and joints), stable across saves."""
        body = {"arm": self.arm, "version": self.version,
                "joints": {k: asdict(v) for k, v in sorted(self.joints.items())}}
        text = json.dumps(body, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def save(self, path: str | Path) -> Path:
        """Write the calibration file atomically (a failed write keeps the previous file).

        Returns:
            The path written.

        Raises:
            ConfigError: If the file cannot be written; the previous calibration is intact.
        """
        doc = {"armctl_calibration": self.version, "arm": self.arm, "hash": self.hash,
               "joints": {k: asdict(v) for k, v in self.joints.items()}}
        return write_atomic(Path(path), "# armctl calibration: written by 'armctl calibrate'; "
                            "do not edit by hand\n" + yaml.safe_dump(doc, sort_keys=False))

    @classmethod
    def load(cls, path: str | Path) -> Calibration:
        """Read a calibration file.

        Raises:
            ConfigError: Unreadable, wrong version, missing keys, or a hash that does not match
                the content (the file was edited).
        """
        doc = load_yaml(path)
        root = doc.root()
        root.check_keys(["armctl_calibration", "arm", "joints"], ["hash"])
        version = root.integer("armctl_calibration")
        if version != VERSION:
            raise root.error(f"calibration format version {version} is not supported "
                             f"(expected {VERSION})", "armctl_calibration",
                             fix="re-run 'armctl calibrate'")
        joints = {}
        for name, sec in root.child("joints").mapping().items():
            sec.check_keys(["servo_id", "zero_tick", "zero_value", "min_tick", "max_tick"],
                           ["homing_offset", "multi_turn", "wrap_detected"])
            joints[name] = JointCalibration(
                servo_id=sec.integer("servo_id", lo=0, hi=252),
                zero_tick=sec.number("zero_tick"), zero_value=sec.number("zero_value"),
                min_tick=sec.number("min_tick"), max_tick=sec.number("max_tick"),
                homing_offset=sec.integer("homing_offset", 0),
                multi_turn=sec.boolean("multi_turn", False),
                wrap_detected=sec.boolean("wrap_detected", False))
        cal = cls(root.string("arm"), joints, version, Path(path))
        if root.has("hash") and root.string("hash") != cal.hash:
            raise root.error(f"hash {root.string('hash')} does not match the content "
                             f"({cal.hash}): the file was edited", "hash",
                             fix="re-run 'armctl calibrate' or restore the file")
        return cal


def calibration_path(spec: ArmSpec) -> Path:
    """Where an arm's calibration file lives.

    That is ``bus.calibration`` relative to the config, else ``<config name>.calibration.yaml``
    beside it.

    Raises:
        ConfigError: For an arm without a file or bus section.
    """
    if spec.bus is None or spec.file is None:
        raise ConfigError(f"arm {spec.name!r} has no bus section or no config file", None,
                          "calibrate an arm loaded from a YAML file with a bus section")
    if spec.bus.calibration:
        return (spec.file.parent / spec.bus.calibration).resolve()
    return spec.file.with_name(f"{spec.file.stem}.calibration.yaml")


def load_calibration(spec: ArmSpec) -> Calibration | None:
    """The calibration of an arm when its file exists, checked against the config.

    Returns:
        The calibration, or ``None`` for an arm without a bus section, without a config file,
        or not calibrated yet (then the config's offsets and limits are used).

    Raises:
        ConfigError: An unreadable or edited file, or one for another arm or other servos.
    """
    if spec.bus is None or spec.file is None:
        return None
    path = calibration_path(spec)
    if not path.exists():
        return None
    cal = Calibration.load(path)
    check_against(cal, spec)
    return cal


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
                if table_for(j.model).family is Family.FEETECH:
                    shift = max(-2047, min(2047, shift))
                    offset = -shift  # Feetech: present = actual - offset
                else:
                    multi = abs(shift) > 1024  # Position mode honours only +-1024
                    offset = shift  # Dynamixel: present = actual + offset
                # the travel moves to the middle of 0..n-1, clear of the encoder wrap
                delta = shift + ((mid + shift) % n - (mid + shift))
            if multi and not j.multi_turn:
                self.bus.write_eeprom(j.servo_id, [(Register.OPERATING_MODE, 4)])
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


def check_against(cal: Calibration, spec: ArmSpec) -> None:
    """Check that a calibration belongs to ``spec`` (same arm, same servos).

    Raises:
        ConfigError: On a mismatch.
    """
    where = KeyPath(cal.file)
    if cal.arm != spec.name:
        raise ConfigError(f"calibration is for arm {cal.arm!r}, not {spec.name!r}", where,
                          "use the calibration file of this arm, or re-run 'armctl calibrate'")
    ids = {s.joint: s.id for s in spec.bus.servos} if spec.bus else {}
    for name, jc in cal.joints.items():
        if ids.get(name) != jc.servo_id:
            raise ConfigError(f"calibration joint {name!r} is servo {jc.servo_id}, the config "
                              f"says {ids.get(name)}", where, "re-run 'armctl calibrate'")
