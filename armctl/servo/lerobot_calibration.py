"""LeRobot calibration files: import one as an armctl calibration, export an armctl one.

LeRobot (Hugging Face) keeps one JSON file per arm, written by its ``calibrate`` step: a mapping
from motor name to ``{"id", "drive_mode", "homing_offset", "range_min", "range_max"}`` (its
``MotorCalibration``, ``lerobot/motors/motors_bus.py``), all integers:

- ``homing_offset``: the value of the servo's Homing Offset register [tick], in the family's own
  convention (Dynamixel: present = actual + offset; Feetech: present = actual - offset). It is
  the same number as armctl's ``homing_offset``: both are what is written to the register.
- ``range_min``, ``range_max``: the lowest and highest present position [tick] (homing offset
  applied) swept during calibration; armctl's ``min_tick`` and ``max_tick``.
- ``drive_mode``: 1 = reversed. On Dynamixel it is the servo's Drive Mode register (the servo
  reverses itself; LeRobot does not touch its readings); on Feetech LeRobot reverses its
  normalised values in software. armctl records it (``JointCalibration.drive_mode``): the bus
  sets the register's reverse bit when it opens (Dynamixel), or the joint counts against the
  config's direction (Feetech).

LeRobot normalises a present position ``p`` per motor (``MotorsBus._normalize``):

- ``RANGE_M100_100`` (body joints): ``200 (p - min) / (max - min) - 100``, clamped to the range;
- ``RANGE_0_100`` (the gripper): ``100 (p - min) / (max - min)``, clamped;
- ``DEGREES`` (body joints, ``use_degrees``): ``(p - mid) 360 / (N - 1)`` with
  ``mid = (min + max) / 2``, not clamped;

negated (``100 - x`` for ``RANGE_0_100``) when a Feetech motor's drive mode is 1, in the two range
modes only. So LeRobot's zero of a body joint is the middle of its range, and the gripper's 0 %
is one end of its range. The import gives armctl the same zero: a body joint's value is 0 at the
middle of the LeRobot range, and the gripper (the joint with role ``gripper``) is at the config's
lower limit at LeRobot's 0 %. For every tick, LeRobot's value and armctl's joint value then
describe the same physical angle: ``x / 100`` of half the range (``RANGE_M100_100``), ``x / 100``
of the range from the lower limit (``RANGE_0_100``), and ``(N - 1) / N`` of LeRobot's degrees
(``DEGREES``: LeRobot divides a turn into ``N - 1 = 4095`` steps where the encoder has 4096).

The export writes the same five numbers back. Import then export gives the same values; export
then import gives the same calibration when its zero follows LeRobot's convention (any imported
calibration does). A calibration measured by ``armctl calibrate`` puts a joint's zero at the
reference pose instead: the export reports, per joint, by how much LeRobot's zero differs
(:attr:`LeRobotExport.shifts`).
"""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import Any

from armctl.atomic_write import write_atomic
from armctl.config.schema import ArmSpec, JointRole, JointSpec
from armctl.errors import ConfigError, KeyPath
from armctl.servo.calibration import Calibration, JointCalibration, check_against
from armctl.servo.mapping import JointMapping
from armctl.servo_tables import Register, table_for

__all__ = ["KEYS", "LeRobotExport", "MotorRecord", "NormMode", "ZeroShift", "export_lerobot",
           "from_lerobot", "import_lerobot", "lerobot_text", "norm_mode", "parse_lerobot",
           "read_lerobot", "to_lerobot"]

log = logging.getLogger(__name__)

#: The keys of one motor's entry, in the order LeRobot writes them.
KEYS = ("id", "drive_mode", "homing_offset", "range_min", "range_max")
_EXTENDED_TURNS = 256  # Dynamixel extended position mode counts +-256 turns (e-Manual)
_FIX_KEYS = ("each motor needs the integers " + ", ".join(KEYS)
             + " as LeRobot's calibrate step writes them")


class NormMode(Enum):
    """LeRobot's normalisation of a motor's position (its ``MotorNormMode``)."""

    RANGE_M100_100 = "range_m100_100"
    RANGE_0_100 = "range_0_100"
    DEGREES = "degrees"


def norm_mode(joint: JointSpec, degrees: bool = False) -> NormMode:
    """The normalisation LeRobot's SO-101 and Koch classes give a joint.

    Args:
        joint: The joint.
        degrees: Whether the body joints use degrees (LeRobot's ``use_degrees``).
    """
    if joint.role is JointRole.GRIPPER:
        return NormMode.RANGE_0_100
    return NormMode.DEGREES if degrees else NormMode.RANGE_M100_100


@dataclass(frozen=True)
class MotorRecord:
    """One motor's entry of a LeRobot calibration file.

    Attributes:
        id: Servo id.
        drive_mode: 0, or 1 for reversed (Dynamixel: the Drive Mode register value).
        homing_offset: Homing Offset register value [tick], the family's sign convention.
        range_min: Lowest present position of the calibrated range [tick].
        range_max: Highest present position [tick].
    """

    id: int
    drive_mode: int
    homing_offset: int
    range_min: int
    range_max: int

    def as_dict(self) -> dict[str, int]:
        """The entry as LeRobot writes it (keys in LeRobot's order)."""
        return {k: getattr(self, k) for k in KEYS}


@dataclass(frozen=True)
class ZeroShift:
    """A joint whose armctl zero is not where LeRobot puts it.

    Attributes:
        joint: Joint name.
        value: armctl's joint value [rad] or [m] at LeRobot's zero (the middle of the range,
            or the range's end at 0 % for the gripper) minus the value LeRobot's convention
            gives there; LeRobot's positions of this joint read ``value`` lower than armctl's.
    """

    joint: str
    value: float


@dataclass(frozen=True)
class LeRobotExport:
    """What :func:`to_lerobot` produced.

    Attributes:
        records: Per motor name, its entry.
        shifts: Joints whose zero moves (see :class:`ZeroShift`); empty when none.
        file: The file written, or ``None``.
    """

    records: dict[str, MotorRecord]
    shifts: tuple[ZeroShift, ...] = ()
    file: Path | None = None

    def text(self) -> str:
        """The JSON text of the file."""
        return lerobot_text(self.records)


# ---- reading ------------------------------------------------------------------------------------
def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise ValueError(f"the key {k!r} appears twice")
        out[k] = v
    return out


def parse_lerobot(text: str, file: Path | None = None) -> dict[str, MotorRecord]:
    """Parse the text of a LeRobot calibration file (types and keys only, no arm).

    Raises:
        ConfigError: Not JSON, not an object of objects, a missing or unknown key, or a value
            that is not an integer (naming the file, the motor and the key).
    """
    where = KeyPath(file)
    try:
        doc = json.loads(text, object_pairs_hook=_no_duplicates)
    except ValueError as exc:
        raise ConfigError(f"not a LeRobot calibration file (JSON): {exc}", where,
                          "give the .json file LeRobot's calibrate step wrote (under "
                          "~/.cache/huggingface/lerobot/calibration/)") from None
    if not isinstance(doc, dict) or not doc:
        raise ConfigError("a LeRobot calibration file is a JSON object of motors, e.g. "
                          '{"shoulder_pan": {"id": 1, ...}, ...}', where, _FIX_KEYS)
    out = {}
    for name, entry in doc.items():
        at = KeyPath(file, (name,))
        if not isinstance(entry, dict):
            raise ConfigError(f"motor {name!r}: expected an object, got "
                              f"{type(entry).__name__}", at, _FIX_KEYS)
        for key in KEYS:
            if key not in entry:
                raise ConfigError(f"motor {name!r} has no {key!r}", KeyPath(file, (name, key)),
                                  _FIX_KEYS)
        for key, value in entry.items():
            if key not in KEYS:
                raise ConfigError(f"motor {name!r}: unknown key {key!r} (LeRobot would refuse "
                                  "it)", KeyPath(file, (name, key)),
                                  f"remove it; the keys are {', '.join(KEYS)}")
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigError(f"motor {name!r}: {key} = {value!r} is not an integer",
                                  KeyPath(file, (name, key)),
                                  "write a whole number of ticks (no quotes, no decimals)")
        out[name] = MotorRecord(**{k: entry[k] for k in KEYS})
    return out


def read_lerobot(path: str | Path) -> dict[str, MotorRecord]:
    """Read a LeRobot calibration file (types and keys only).

    Raises:
        ConfigError: Unreadable, or as :func:`parse_lerobot`.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the LeRobot calibration file: {exc}", KeyPath(path),
                          "check the path (LeRobot keeps them under "
                          "~/.cache/huggingface/lerobot/calibration/)") from None
    return parse_lerobot(text, path)


def lerobot_text(records: Mapping[str, MotorRecord]) -> str:
    """The JSON text LeRobot writes for ``records``.

    As LeRobot's ``draccus.dump(..., indent=4)``: 4-space indent, keys in LeRobot's order, no
    newline at the end.
    """
    return json.dumps({n: r.as_dict() for n, r in records.items()}, indent=4)


# ---- checks against the arm -------------------------------------------------------------------
@dataclass(frozen=True)
class _Servo:
    joint: JointSpec
    servo_id: int
    model: str
    direction: int  # the config's direction


def _servos(spec: ArmSpec) -> dict[str, _Servo]:
    if spec.bus is None:
        raise ConfigError(f"arm {spec.name!r} has no 'bus:' section", KeyPath(spec.file),
                          "give the arm config with the servos the calibration is for")
    joints = {j.name: j for j in spec.actuated_joints}
    return {s.joint: _Servo(joints[s.joint], s.id, s.model, s.direction)
            for s in spec.bus.servos if s.joint in joints}


def _check_record(name: str, rec: MotorRecord, servo: _Servo, where: KeyPath, what: str) -> None:
    """Refuse values the servo or LeRobot cannot take.

    Args:
        name: Motor (joint) name.
        rec: Its entry.
        servo: The config's servo of that joint.
        where: The entry's location, for the error.
        what: How to name the source in the fix ("the file", "the calibration").
    """
    table = table_for(servo.model)
    vendor = table.vendor
    n = table.ticks_per_rev

    def fail(key: str, problem: str, fix: str) -> ConfigError:
        return ConfigError(f"motor {name!r}: {problem}", KeyPath(where.file, (*where.keys, key)),
                           fix)

    if rec.id != servo.servo_id:
        raise fail("id", f"id {rec.id}, but the arm config drives joint {name!r} with servo "
                   f"{servo.servo_id}", f"use {what} of this arm, or fix the id in the config's "
                   "bus section")
    spec = table.registers.get(Register.DRIVE_MODE)
    lo, hi = (spec.lo, spec.hi) if spec is not None else (0, 1)
    if not lo <= rec.drive_mode <= hi:
        raise fail("drive_mode", f"drive_mode {rec.drive_mode} is outside {lo}..{hi} for a "
                   f"{servo.model}", "use 0 (normal) or 1 (reversed)")
    h = table.registers[Register.HOMING_OFFSET]
    if not h.lo <= rec.homing_offset <= h.hi:
        raise fail("homing_offset", f"homing_offset {rec.homing_offset} is outside what a "
                   f"{servo.model} stores ({h.lo}..{h.hi})", f"recalibrate; {what} does not "
                   "belong to this servo model")
    if vendor.multi_turn_mode is None:
        top_lo, top_hi = 0, n - 1
    else:
        top_lo, top_hi = -_EXTENDED_TURNS * n, _EXTENDED_TURNS * n
    for key in ("range_min", "range_max"):
        v = getattr(rec, key)
        if not top_lo <= v <= top_hi:
            raise fail(key, f"{key} {v} is outside the positions a {servo.model} reports "
                       f"({top_lo}..{top_hi})", "recalibrate the joint")
    if rec.range_min >= rec.range_max:
        raise fail("range_max", f"range_min {rec.range_min} is not below range_max "
                   f"{rec.range_max} (LeRobot refuses an empty range)",
                   "recalibrate the joint and move it through its range")


def _reversed_by_mapping(servo: _Servo, drive_mode: int) -> bool:
    """Whether LeRobot reverses this motor in software (a servo without Drive Mode register)."""
    return bool(drive_mode & 1) and Register.DRIVE_MODE not in table_for(servo.model).registers


def _joint_calibration(servo: _Servo, rec: MotorRecord) -> JointCalibration:
    """The armctl calibration of one joint that a LeRobot entry describes."""
    table = table_for(servo.model)
    vendor = table.vendor
    n = table.ticks_per_rev
    if norm_mode(servo.joint) is NormMode.RANGE_0_100:  # 0 % is the config's lower limit
        direction = -servo.direction if _reversed_by_mapping(servo, rec.drive_mode) \
            else servo.direction
        zero_tick = float(rec.range_min if direction > 0 else rec.range_max)
        zero_value = servo.joint.limits.lower
        if not math.isfinite(zero_value):
            zero_tick, zero_value = (rec.range_min + rec.range_max) / 2.0, 0.0
    else:  # LeRobot's zero is the middle of the range
        zero_tick, zero_value = (rec.range_min + rec.range_max) / 2.0, 0.0
    multi = vendor.multi_turn_mode is not None and (
        abs(rec.homing_offset) > vendor.homing_limit or rec.range_min < 0
        or rec.range_max > n - 1)
    return JointCalibration(servo_id=rec.id, zero_tick=zero_tick, zero_value=zero_value,
                            min_tick=float(rec.range_min), max_tick=float(rec.range_max),
                            homing_offset=rec.homing_offset, multi_turn=multi,
                            wrap_detected=False, drive_mode=rec.drive_mode)


# ---- import -----------------------------------------------------------------------------------
def from_lerobot(spec: ArmSpec, records: Mapping[str, MotorRecord],
                 file: Path | None = None) -> Calibration:
    """The armctl calibration of ``spec`` that a LeRobot calibration describes.

    Args:
        spec: The arm (its ``bus:`` section names the motors: LeRobot's motor names are the
            joint names of the bundled SO-101 and Koch configs).
        records: Per motor name, its entry (:func:`read_lerobot`).
        file: Where the entries came from, for error messages.

    Raises:
        ConfigError: A motor the config lacks, a servo of the config missing from the file,
            an id that differs from the config's, a value the servo cannot take, or a range
            that lies outside the config's joint limits (naming file, motor, key and fix).
    """
    servos = _servos(spec)
    where = KeyPath(file)
    for name in records:
        if name not in servos:
            raise ConfigError(f"motor {name!r} is not a servo joint of arm {spec.name!r} "
                              f"({', '.join(servos)})", KeyPath(file, (name,)),
                              "use the calibration file of this arm (LeRobot names the motors "
                              "as the bundled configs name the joints), or give the matching "
                              "arm config")
    missing = [n for n in servos if n not in records]
    if missing:
        raise ConfigError(f"no entry for {', '.join(repr(n) for n in missing)} (arm "
                          f"{spec.name!r} drives {len(servos)} servos)", where,
                          "use the calibration file of this arm (robot or teleoperator type "
                          "and id), or give the matching arm config")
    joints = {}
    for name, servo in servos.items():
        rec = records[name]
        _check_record(name, rec, servo, KeyPath(file, (name,)), "the calibration file")
        joints[name] = _joint_calibration(servo, rec)
    cal = Calibration(spec.name, joints)
    _check_overlap(spec, cal, file)
    return cal


def _check_overlap(spec: ArmSpec, cal: Calibration, file: Path | None) -> None:
    """Refuse a calibrated range that leaves no travel inside the config's joint limits."""
    mapping = JointMapping.from_spec(spec, cal)
    for j in mapping.joints:
        if j.lower >= j.upper:
            jc = cal.joints[j.name]
            a, b = sorted((j.to_joint_raw(jc.min_tick), j.to_joint_raw(jc.max_tick)))
            joint = next(x for x in spec.actuated_joints if x.name == j.name)
            raise ConfigError(
                f"motor {j.name!r}: the calibrated range is {a:.4g}..{b:.4g} in joint units, "
                f"outside the config's limits {joint.limits.lower:.4g}..{joint.limits.upper:.4g}"
                , KeyPath(file, (j.name,)),
                "check that the file belongs to this arm; the joint's zero must be the middle "
                "of its LeRobot range, as LeRobot calibrates the SO-101 and Koch arms")


def import_lerobot(spec: ArmSpec, path: str | Path) -> Calibration:
    """Read a LeRobot calibration file as the armctl calibration of ``spec``.

    Raises:
        ConfigError: As :func:`read_lerobot` and :func:`from_lerobot`.
    """
    path = Path(path)
    cal = from_lerobot(spec, read_lerobot(path), path)
    log.info("imported LeRobot calibration %s for arm %s", path, spec.name)
    return cal


# ---- export -----------------------------------------------------------------------------------
def to_lerobot(spec: ArmSpec, cal: Calibration) -> LeRobotExport:
    """The LeRobot calibration entries of an armctl calibration.

    Raises:
        ConfigError: A calibration of another arm or other servos, a joint of the config that
            it lacks, or values LeRobot or the servo cannot take.
    """
    check_against(cal, spec)
    servos = _servos(spec)
    where = KeyPath(cal.file, ("joints",))
    records, shifts = {}, []
    mapping = JointMapping.from_spec(spec, cal)
    for name, servo in servos.items():
        jc = cal.joints.get(name)
        if jc is None:
            raise ConfigError(f"the calibration has no joint {name!r}", where,
                              "re-run 'armctl calibrate CONFIG'")
        rec = MotorRecord(id=jc.servo_id, drive_mode=jc.drive_mode or 0,
                          homing_offset=jc.homing_offset, range_min=round(jc.min_tick),
                          range_max=round(jc.max_tick))
        _check_record(name, rec, servo, KeyPath(cal.file, ("joints", name)), "the calibration")
        records[name] = rec
        implied = _joint_calibration(servo, rec)
        j = mapping.joint(name)
        shift = j.to_joint_raw(implied.zero_tick) - implied.zero_value
        if abs(shift) > 0.5 * abs(1.0 / (j.gear_ratio * j.ticks_per_rev / (2 * math.pi))):
            shifts.append(ZeroShift(name, shift))
    return LeRobotExport(records, tuple(shifts))


def export_lerobot(spec: ArmSpec, cal: Calibration, path: str | Path, *,
                   overwrite: bool = False) -> LeRobotExport:
    """Write an armctl calibration as a LeRobot calibration file (atomically).

    Args:
        spec: The arm.
        cal: Its calibration.
        path: The JSON file to write (LeRobot reads ``<calibration dir>/<id>.json``).
        overwrite: Replace an existing file (else it is refused).

    Raises:
        ConfigError: As :func:`to_lerobot`; an existing file without ``overwrite``; a file
            that cannot be written (the previous one is intact).
    """
    path = Path(path)
    if path.is_dir():
        raise ConfigError("the output is a folder", KeyPath(path),
                          f"give the JSON file to write, e.g. {path / 'my_arm.json'}")
    if path.exists() and not overwrite:
        raise ConfigError("the output file exists already; nothing was written", KeyPath(path),
                          "choose another name or pass --force to overwrite it")
    out = to_lerobot(spec, cal)
    write_atomic(path, out.text())
    for s in out.shifts:
        log.warning("LeRobot's zero of joint %s differs from armctl's by %.6g", s.joint, s.value)
    return LeRobotExport(out.records, out.shifts, path)
