"""Calibration data: zero offsets and ranges measured on the arm, kept in a file beside the config.

This module holds the data and its file only; the procedure that measures it on an open bus
is :class:`armctl.servo.calibrate.Calibrator`.

The file (YAML, read with :mod:`armctl.config.source`) records a format version and a hash of
its content that keyframe files can store to tell which calibration their joint values assume.
"""

from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import yaml

from armctl.atomic_write import write_atomic
from armctl.config import bundled_configs_dir
from armctl.config.schema import ArmSpec
from armctl.config.source import load_yaml
from armctl.errors import ConfigError, KeyPath

__all__ = ["Calibration", "JointCalibration", "calibration_path", "check_against",
           "load_calibration", "user_calibration_dir"]

VERSION = 1


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
        drive_mode: The servo's drive mode the ticks were measured in, or ``None`` when not
            recorded (a calibration measured by armctl). Bit 0 set means reversed: on a servo
            with a Drive Mode register (Dynamixel) the servo reverses itself and the bus sets
            the bit when it opens; on one without (Feetech) the joint counts against the
            config's direction. Set when a LeRobot calibration is imported
            (:mod:`armctl.servo.lerobot_calibration`).
    """

    servo_id: int
    zero_tick: float
    zero_value: float
    min_tick: float
    max_tick: float
    homing_offset: int = 0
    multi_turn: bool = False
    wrap_detected: bool = False
    drive_mode: int | None = None

    def record(self) -> dict[str, object]:
        """The joint's entry in the calibration file (``drive_mode`` only when recorded)."""
        out = asdict(self)
        if out["drive_mode"] is None:
            del out["drive_mode"]
        return out


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
                "joints": {k: v.record() for k, v in sorted(self.joints.items())}}
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
               "joints": {k: v.record() for k, v in self.joints.items()}}
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
                           ["homing_offset", "multi_turn", "wrap_detected", "drive_mode"])
            joints[name] = JointCalibration(
                servo_id=sec.integer("servo_id", lo=0, hi=252),
                zero_tick=sec.number("zero_tick"), zero_value=sec.number("zero_value"),
                min_tick=sec.number("min_tick"), max_tick=sec.number("max_tick"),
                homing_offset=sec.integer("homing_offset", 0),
                multi_turn=sec.boolean("multi_turn", False),
                wrap_detected=sec.boolean("wrap_detected", False),
                drive_mode=sec.integer("drive_mode", lo=0, hi=255) if sec.has("drive_mode")
                else None)
        cal = cls(root.string("arm"), joints, version, Path(path))
        if root.has("hash") and root.string("hash") != cal.hash:
            raise root.error(f"hash {root.string('hash')} does not match the content "
                             f"({cal.hash}): the file was edited", "hash",
                             fix="re-run 'armctl calibrate' or restore the file")
        return cal


def user_calibration_dir() -> Path:
    """Where the calibrations of the bundled arms are kept: never inside the installed package.

    ``$ARMCTL_HOME/calibration`` when ``ARMCTL_HOME`` is set, else
    ``$XDG_CONFIG_HOME/armctl/calibration`` (``~/.config/armctl/calibration``).
    """
    home = os.environ.get("ARMCTL_HOME")
    if home:
        return Path(home).expanduser() / "calibration"
    xdg = os.environ.get("XDG_CONFIG_HOME")
    base = Path(xdg).expanduser() if xdg else Path.home() / ".config"
    return base / "armctl" / "calibration"


def calibration_path(spec: ArmSpec) -> Path:
    """Where an arm's calibration file lives.

    That is ``bus.calibration`` relative to the config, else ``<config name>.calibration.yaml``
    beside it; for a bundled arm (whose config is part of the installed package, rewritten by
    every upgrade) it is in :func:`user_calibration_dir`.

    Raises:
        ConfigError: For an arm without a file or bus section.
    """
    if spec.bus is None or spec.file is None:
        raise ConfigError(f"arm {spec.name!r} has no bus section or no config file", None,
                          "calibrate an arm loaded from a YAML file with a bus section")
    if spec.bus.calibration:
        return (spec.file.parent / spec.bus.calibration).resolve()
    name = f"{spec.file.stem}.calibration.yaml"
    if spec.file.resolve().parent == bundled_configs_dir():
        return user_calibration_dir() / name
    return spec.file.with_name(name)


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
