"""Keyframe programs in memory: joint-vector or Cartesian keyframes with dwell and gripper values.

The file format is read and written by :mod:`armctl.motion.keyframe_file`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum

from armctl.errors import InputError, KeyPath
from armctl.motion.interpolate import Interpolation
from armctl.typing import Array

__all__ = ["AngleUnit", "Keyframe", "KeyframeProgram", "LengthUnit"]


class AngleUnit(Enum):
    """The unit of every angle in a keyframe file: rotary joints (gripper included) and rpy."""

    RAD = "rad"
    DEG = "deg"


class LengthUnit(Enum):
    """The unit of every length in a keyframe file: prismatic joints (gripper included), xyz."""

    M = "m"
    MM = "mm"

    @property
    def metres(self) -> float:
        """One unit in metres."""
        return 1.0 if self is LengthUnit.M else 0.001


@dataclass(frozen=True)
class Keyframe:
    """One keyframe: either joint values or a tool pose.

    Attributes:
        q: Joint values [rad]/[m] in the order of :attr:`KeyframeProgram.joints`, or ``None``
            for a Cartesian keyframe. A universal joint takes its two angles in place, a ball
            joint its unit quaternion ``w, x, y, z`` (see :attr:`KeyframeProgram.widths`).
        pose: ``(4, 4)`` tool pose in the base frame [m], solved by IK at play time, or ``None``.
        orientation: Whether a pose keyframe constrains the orientation too (``False``: only
            the position counts, as for 5-joint arms).
        name: Optional name.
        dwell: Time to stay at this keyframe [s]; > 0 makes the motion stop here.
        gripper: Gripper position to command at this keyframe [rad]/[m] (``None``: unchanged).
        time: Recording time stamp [s] (continuous recordings), or ``None``.
        interpolation: How the segment that arrives at this keyframe is interpolated
            (``None``: the program's playback option). Where it changes the arm rests at the
            keyframe between the two kinds.
        where: Where the keyframe was read from, for error messages.
    """

    q: tuple[float, ...] | None = None
    pose: Array | None = field(default=None, compare=False)
    orientation: bool = True
    name: str = ""
    dwell: float = 0.0
    gripper: float | None = None
    time: float | None = None
    interpolation: Interpolation | None = None
    where: KeyPath = field(default=KeyPath(), compare=False)

    def __post_init__(self) -> None:
        if (self.q is None) == (self.pose is None):
            raise InputError("a keyframe needs exactly one of joint values (q) or a pose")
        if self.dwell < 0:
            raise InputError(f"keyframe dwell must not be negative, got {self.dwell}")

    @property
    def label(self) -> str:
        """The name, or ``"#i"`` style placeholder when unnamed."""
        return self.name or "(unnamed)"


@dataclass(frozen=True)
class KeyframeProgram:
    """A sequence of keyframes for one arm.

    Attributes:
        arm: The arm's name.
        joints: Names of the joints whose values joint keyframes give, in order.
        keyframes: The keyframes, in play order.
        calibration: Hash of the calibration the joint values were recorded with, if known.
        frame: The frame Cartesian keyframes place (the tool when empty).
        angle_unit: Unit of angles in the file (values in memory are always SI).
        description: Free text.
        length_unit: Unit of lengths in the file.
        widths: How many values of ``q`` each listed joint takes (2 for a universal joint, 4
            for a ball joint's quaternion); empty: one each (an arm of 1-DOF joints).
    """

    arm: str
    joints: tuple[str, ...]
    keyframes: tuple[Keyframe, ...] = ()
    calibration: str | None = None
    frame: str = ""
    angle_unit: AngleUnit = AngleUnit.RAD
    description: str = ""
    length_unit: LengthUnit = LengthUnit.M
    widths: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        if self.widths and len(self.widths) != len(self.joints):
            raise InputError(f"the program lists {len(self.joints)} joints but "
                             f"{len(self.widths)} widths")
        n = sum(self.widths) if self.widths else len(self.joints)
        for k, kf in enumerate(self.keyframes):
            if kf.q is not None and len(kf.q) != n:
                what = (f"{n} values for its joints" if self.widths else f"{n} joints")
                raise InputError(f"keyframe {k} ({kf.label}) has {len(kf.q)} joint values; the "
                                 f"program lists {what}")

    def append(self, keyframe: Keyframe) -> KeyframeProgram:
        """A copy with one more keyframe at the end."""
        return replace(self, keyframes=(*self.keyframes, keyframe))

    @property
    def timed(self) -> bool:
        """Whether every keyframe has a time stamp (a continuous recording)."""
        return bool(self.keyframes) and all(kf.time is not None for kf in self.keyframes)
