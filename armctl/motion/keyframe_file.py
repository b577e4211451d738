"""The keyframe file: versioned YAML, read with clear errors and written atomically.

Example::

    armctl_keyframes: 1
    arm: so101
    units: {angle: deg, length: m}
    calibration: sha256:3f2a...        # optional: calibration the joint values were taught with
    joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]
    keyframes:
      - {name: start, q: [0, -30, 60, 20, 0], dwell: 0.5, gripper: 23}   # gripper: 23 deg
      - {name: above_cup, pose: {xyz: [0.22, 0.0, 0.12], rpy: [0, 90, 0]}}
      - {q: [10, -20, 40, 10, 0], time: 1.25}

The units apply to every value: joint values ``q`` follow ``joints``, in ``units.angle`` for
rotary joints and ``units.length`` (``m`` or ``mm``) for prismatic ones; ``gripper`` is in the
unit of the arm's gripper joint (an angle for a rotary gripper, a length for a prismatic one);
``pose`` gives ``xyz`` (in ``units.length``) and ``rpy`` (in ``units.angle``) or ``quat``
``[w, x, y, z]`` (with neither, only the position counts, the natural choice for 5-joint arms);
``dwell`` and ``time`` are in seconds. An optional ``interpolation`` (``linear``, ``cubic`` or
``min-jerk``) sets how the segment arriving at that keyframe is joined (without it: the
playback's interpolation). Any angle or length may also be written as a string with
its unit (``"15 deg"``, ``"0.3 rad"``, ``"12 mm"``, ``"0.012 m"``).

On an arm with universal or ball joints, a universal joint's value in ``q`` is a list of its two
angles (``[10, -5]``, in ``units.angle``) and a ball joint's a unit quaternion ``[w, x, y, z]``
(no unit applies to it), or ``{rpy: [r, p, y]}`` / ``{rotvec: [x, y, z]}`` (angles in
``units.angle``), e.g. ``q: [[1, 0, 0, 0], 30, [10, -5]]``. Files are written with quaternions.
"""

from __future__ import annotations

import itertools
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from armctl.atomic_write import write_atomic
from armctl.config.schema import JointRole, JointType
from armctl.config.source import Section, load_yaml, parse_yaml
from armctl.errors import InputError
from armctl.kinematics.model import KinematicModel
from armctl.motion.interpolate import Interpolation
from armctl.motion.keyframes import AngleUnit, Keyframe, KeyframeProgram, LengthUnit
from armctl.spatial import (
    make_transform,
    matrix_to_quat,
    matrix_to_rpy,
    quat_to_matrix,
    rotvec_to_matrix,
    rpy_to_matrix,
)

__all__ = ["FORMAT_VERSION", "load_keyframes", "parse_keyframes", "save_keyframes",
           "write_atomic"]

FORMAT_VERSION = 1
_TOP_REQUIRED = ("armctl_keyframes", "arm", "joints", "keyframes")
_TOP_OPTIONAL = ("units", "calibration", "frame", "description")
_KF_KEYS = ("name", "q", "pose", "dwell", "gripper", "time", "interpolation")
_NUMBER = r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
_ANGLE_TEXT = re.compile(rf"^\s*{_NUMBER}\s*(deg|rad)\s*$")
_LENGTH_TEXT = re.compile(rf"^\s*{_NUMBER}\s*(mm|m)\s*$")


class _Units:
    """The units of one file: how plain numbers are read and written."""

    def __init__(self, angle: AngleUnit, length: LengthUnit):
        self.angle = angle
        self.length = length

    def to_si(self, sec: Section, raw: Any, rotary: bool, *keys: str | int) -> float:
        """A value of the file in SI units ([rad] or [m]).

        Plain numbers are in the file's unit; strings carry their own (``"15 deg"``,
        ``"12 mm"``).

        Raises:
            ConfigError: For anything else, naming the key and the expected unit.
        """
        unit = self.angle.value if rotary else self.length.value
        example = "'15 deg'" if rotary else "'12 mm'"
        if isinstance(raw, (int, float)) and not isinstance(raw, bool):
            if not math.isfinite(raw):
                raise sec.error(f"expected a finite number, found {raw}", *keys)
            if rotary:
                return math.radians(raw) if self.angle is AngleUnit.DEG else float(raw)
            return float(raw) * self.length.metres
        if isinstance(raw, str):
            m = (_ANGLE_TEXT if rotary else _LENGTH_TEXT).match(raw)
            if m:
                x = float(m.group(1))
                if rotary:
                    return math.radians(x) if m.group(2) == "deg" else x
                return x * (0.001 if m.group(2) == "mm" else 1.0)
            if (_LENGTH_TEXT if rotary else _ANGLE_TEXT).match(raw):
                kind = "an angle (rotary joint)" if rotary else "a length (prismatic joint)"
                raise sec.error(f"{raw!r} has the wrong unit: this value is {kind}", *keys,
                                fix=f"write a number in {unit} or a string like {example}")
        found = "a boolean" if isinstance(raw, bool) else (
            "nothing (null)" if raw is None else f"{type(raw).__name__} {raw!r}")
        raise sec.error(f"expected a number (in {unit}, the file's unit) or a string like "
                        f"{example}, found {found}", *keys)

    def angle_out(self, x: float) -> float:
        """An angle [rad] as written in the file."""
        return _num(math.degrees(x), 5) if self.angle is AngleUnit.DEG else _num(x)

    def length_out(self, x: float) -> float:
        """A length [m] as written in the file."""
        return _num(x / self.length.metres, 7 if self.length is LengthUnit.M else 4)

    def out(self, x: float, rotary: bool) -> float:
        """A joint value [rad]/[m] as written in the file."""
        return self.angle_out(x) if rotary else self.length_out(x)


def _gripper_rotary(model: KinematicModel) -> bool:
    """Whether gripper values are angles: the arm's (first) gripper joint is rotary."""
    for i, role in enumerate(model.joint_roles):
        if role is JointRole.GRIPPER:
            return model.joint_types[i] is not JointType.PRISMATIC
    return True


def load_keyframes(path: str | Path, model: KinematicModel) -> KeyframeProgram:
    """Read a keyframe file for an arm.

    Args:
        path: The file.
        model: The arm the program is for (joint names and types are checked against it).

    Returns:
        The program, in SI units.

    Raises:
        ConfigError: Naming the file, key path and line, what was found and how to fix it.
    """
    return _parse(load_yaml(path).root(), model)


def parse_keyframes(text: str, model: KinematicModel, file: Path | None = None
                    ) -> KeyframeProgram:
    """Parse keyframe YAML text (see :func:`load_keyframes`)."""
    return _parse(parse_yaml(text, file).root(), model)


def _parse(top: Section, model: KinematicModel) -> KeyframeProgram:
    if "armctl_keyframes" not in top.value and "armctl" in top.value:
        raise top.error("this is an arm config (armctl YAML), not a keyframe file",
                        fix="give a keyframe file (written by 'armctl teach', see "
                            "docs/motion.md); the arm config goes in the CONFIG argument")
    top.check_keys(_TOP_REQUIRED, _TOP_OPTIONAL)
    version = top.integer("armctl_keyframes", lo=1)
    if version > FORMAT_VERSION:
        raise top.error(f"keyframe format version {version} is newer than this armctl reads "
                        f"({FORMAT_VERSION})", "armctl_keyframes", fix="upgrade armctl")
    arm = top.string("arm")
    if arm != model.name:
        raise top.error(f"the keyframes were taught on arm {arm!r}, not {model.name!r}", "arm",
                        fix=f"play them on {arm!r}, or change 'arm:' if the arms are the same")
    unit, length = AngleUnit.RAD, LengthUnit.M
    if top.has("units"):
        units = top.child("units").mapping()
        units.check_keys([], ["angle", "length"])
        unit = units.choice("angle", AngleUnit, [u.value for u in AngleUnit], AngleUnit.RAD)
        length = units.choice("length", LengthUnit, [u.value for u in LengthUnit], LengthUnit.M)
    file_units = _Units(unit, length)
    joints = _joint_names(top, model)
    rotary = [model.joint_types[model.joint_index(j)] is not JointType.PRISMATIC for j in joints]
    types = tuple(model.joint_types[model.joint_index(j)] for j in joints)
    multi = bool(model.multi_dof_joints)
    frame = top.string("frame", required=False)
    if frame:
        try:
            model.frame_index(frame)
        except InputError as exc:
            raise top.error(str(exc), "frame") from None
    grip_rotary = _gripper_rotary(model)
    kfs = [_keyframe(sec.mapping(), rotary, grip_rotary, file_units,
                     (joints, types) if multi else None)
           for sec in top.list_of("keyframes")]
    times = [kf.time for kf in kfs if kf.time is not None]
    if any(b <= a for a, b in itertools.pairwise(times)):
        raise top.error("keyframe times must increase", "keyframes",
                        fix="sort the keyframes by 'time' or remove the times")
    return KeyframeProgram(
        arm=arm, joints=joints, keyframes=tuple(kfs),
        calibration=top.string("calibration", required=False) or None, frame=frame,
        angle_unit=unit, description=top.string("description", required=False),
        length_unit=length, widths=tuple(t.nq for t in types) if multi else (),
    )


def _joint_names(top: Section, model: KinematicModel) -> tuple[str, ...]:
    value = top.value["joints"]
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise top.error("expected a list of joint names", "joints",
                        fix=f"for example [{', '.join(model.joint_names)}]")
    for i, name in enumerate(value):
        if name not in model.joint_names:
            import difflib

            close = difflib.get_close_matches(name, model.joint_names, n=1)
            fix = f"did you mean {close[0]!r}?" if close else (
                f"joints of {model.name!r}: {', '.join(model.joint_names)}")
            raise top.error(f"unknown joint {name!r}", "joints", i, fix=fix)
        if value.count(name) > 1:
            raise top.error(f"joint {name!r} is listed twice", "joints", i)
    return tuple(value)


def _values(sec: Section, key: str, rotary: list[bool], units: _Units) -> tuple[float, ...]:
    """A list with one value per entry of ``rotary``, in SI units."""
    raw = sec.value[key]
    n = len(rotary)
    if not isinstance(raw, list) or len(raw) != n:
        found = f"a list of {len(raw)} items" if isinstance(raw, list) else type(raw).__name__
        raise sec.error(f"expected a list of {n} numbers, found {found}", key,
                        fix=f"write it as [{', '.join(['0'] * n)}]")
    return tuple(units.to_si(sec, x, r, key, i)
                 for i, (x, r) in enumerate(zip(raw, rotary, strict=True)))


#: How far a ball joint's quaternion in a keyframe file may be from unit norm (it is then
#: normalised): four decimals written by hand, e.g. [0.7071, 0.7071, 0, 0].
_UNIT_NORM_TOLERANCE = 1e-3


def _multi_values(sec: Section, key: str, joints: tuple[str, ...],
                  types: tuple[JointType, ...], units: _Units) -> tuple[float, ...]:
    """Joint values of an arm with universal or ball joints, flattened, in SI units.

    A 1-DOF joint's value is a number, a universal joint's a list of two angles, a ball joint's
    a unit quaternion ``[w, x, y, z]``, ``{rpy: [...]}`` or ``{rotvec: [...]}``.
    """
    raw = sec.value[key]
    n = len(joints)
    example = ", ".join("[1, 0, 0, 0]" if t is JointType.BALL else
                        "[0, 0]" if t is JointType.UNIVERSAL else "0" for t in types)
    if not isinstance(raw, list) or len(raw) != n:
        found = f"a list of {len(raw)} items" if isinstance(raw, list) else type(raw).__name__
        raise sec.error(f"expected a list of {n} joint values (one per joint in 'joints': "
                        f"{', '.join(joints)}), found {found}", key,
                        fix=f"write it as [{example}]: a ball joint's value is a quaternion "
                            "[w, x, y, z], a universal joint's its two angles")
    out: list[float] = []
    for i, (x, name, jtype) in enumerate(zip(raw, joints, types, strict=True)):
        if jtype is JointType.BALL:
            out += _ball_value(sec, x, name, units, key, i)
        elif jtype is JointType.UNIVERSAL:
            if not isinstance(x, list) or len(x) != 2:
                raise sec.error(f"universal joint {name!r} takes a list of its 2 angles, found "
                                f"{x!r}", key, i, fix="write it as [a1, a2] (in the file's "
                                f"angle unit, {units.angle.value})")
            out += [units.to_si(sec, a, True, key, i, k) for k, a in enumerate(x)]
        else:
            if isinstance(x, (list, dict)):
                raise sec.error(f"joint {name!r} ({jtype.value}) takes one value, found {x!r}",
                                key, i, fix="write a number")
            out.append(units.to_si(sec, x, jtype is not JointType.PRISMATIC, key, i))
    return tuple(out)


def _ball_value(sec: Section, raw: object, joint: str, units: _Units, *keys: str | int
                ) -> list[float]:
    """A ball joint's value in a keyframe: a unit quaternion ``[w, x, y, z]`` (``w >= 0``)."""
    forms = ("write a unit quaternion [w, x, y, z], or {rpy: [roll, pitch, yaw]} or "
             f"{{rotvec: [x, y, z]}} in the file's angle unit ({units.angle.value})")
    if isinstance(raw, dict):
        if len(raw) != 1 or next(iter(raw)) not in ("rpy", "rotvec"):
            raise sec.error(f"ball joint {joint!r}: expected {{rpy: [...]}} or "
                            f"{{rotvec: [...]}}, found keys {sorted(map(str, raw))}", *keys,
                            fix=forms)
        form, vec = next(iter(raw.items()))
        if not isinstance(vec, list) or len(vec) != 3:
            raise sec.error(f"ball joint {joint!r}: '{form}' takes 3 angles, found {vec!r}",
                            *keys, form, fix=forms)
        angles = np.array([units.to_si(sec, a, True, *keys, form, k) for k, a in
                           enumerate(vec)])
        if units.angle is AngleUnit.RAD and float(np.abs(angles).max()) > 2.0 * math.pi:
            raise sec.error(f"ball joint {joint!r}: '{form}' {vec} is more than a full turn "
                            "(2 pi rad): the file's angle unit is rad, "
                            "so these can only be degrees", *keys, form,
                            fix="add 'units: {angle: deg}' at the top of the file, or "
                            "write each angle with its unit ('30 deg')")
        rot = rpy_to_matrix(angles) if form == "rpy" else rotvec_to_matrix(angles)
        quat = matrix_to_quat(rot)
    else:
        if not isinstance(raw, list) or len(raw) != 4:
            found = (f"a list of {len(raw)} numbers" if isinstance(raw, list) else repr(raw))
            raise sec.error(f"ball joint {joint!r} takes a unit quaternion [w, x, y, z], found "
                            f"{found}", *keys, fix=forms)
        for k, x in enumerate(raw):
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise sec.error(f"ball joint {joint!r}: quaternion entry {k} is {x!r}, not a "
                                "finite number (a quaternion has no unit)", *keys, k,
                                fix=forms)
        quat = np.array(raw, dtype=float)
        norm = float(np.linalg.norm(quat))
        if abs(norm - 1.0) > _UNIT_NORM_TOLERANCE:
            hint = (f"; normalised it is {np.round(quat / norm, 6).tolist()}" if norm > 0
                    else "")
            raise sec.error(f"ball joint {joint!r}: the quaternion {raw} has norm {norm:.6g}, "
                            f"not 1{hint}", *keys, fix=forms)
        quat = quat / norm
    return (quat if quat[0] >= 0 else -quat).tolist()


def _keyframe(sec: Section, rotary: list[bool], grip_rotary: bool, units: _Units,
              multi: tuple[tuple[str, ...], tuple[JointType, ...]] | None = None) -> Keyframe:
    sec.check_keys([], _KF_KEYS)
    if sec.has("q") == sec.has("pose"):
        raise sec.error("a keyframe needs exactly one of 'q' (joint values) or 'pose'",
                        fix="write 'q: [...]' with one value per joint, or 'pose: {xyz: ...}'")
    q = pose = None
    orientation = True
    if sec.has("q"):
        q = (_values(sec, "q", rotary, units) if multi is None
             else _multi_values(sec, "q", *multi, units))
    else:
        psec = sec.child("pose").mapping()
        pose = _pose(psec, units)
        orientation = psec.has("rpy") or psec.has("quat")
    time = sec.number("time", nonnegative=True) if sec.has("time") else None
    interpolation = None
    if sec.has("interpolation"):
        raw = sec.value["interpolation"]
        kinds = [k.value for k in Interpolation]
        if raw not in kinds:
            raise sec.error(f"unknown interpolation {raw!r}", "interpolation",
                            fix=f"write one of {', '.join(kinds)}, or leave the key out (the "
                                "playback's interpolation)")
        interpolation = Interpolation(raw)
    return Keyframe(
        q=q, pose=pose, orientation=orientation, name=sec.string("name", required=False),
        dwell=sec.number("dwell", 0.0, nonnegative=True),
        gripper=(units.to_si(sec, sec.value["gripper"], grip_rotary, "gripper")
                 if sec.has("gripper") else None),
        time=time, interpolation=interpolation, where=sec.where(),
    )


def _pose(sec: Section, units: _Units) -> np.ndarray:
    sec.check_keys(["xyz"], ["rpy", "quat"])
    xyz = _values(sec, "xyz", [False] * 3, units)
    if sec.has("rpy") and sec.has("quat"):
        raise sec.error("give either 'rpy' or 'quat', not both")
    if sec.has("quat"):
        quat = np.array(sec.vector("quat", 4))
        norm = float(np.linalg.norm(quat))
        if not 0.9 < norm < 1.1:
            raise sec.error(f"quaternion norm is {norm:.3g}, expected 1", "quat",
                            fix="write a unit quaternion [w, x, y, z]")
        rot = quat_to_matrix(quat / norm)
    else:
        rpy = _values(sec, "rpy", [True] * 3, units) if sec.has("rpy") else (0.0, 0.0, 0.0)
        rot = rpy_to_matrix(np.array(rpy))
    return make_transform(rot, xyz)


# ---- writing ---------------------------------------------------------------------------------
def _num(x: float, digits: int = 7) -> float:
    v = round(float(x), digits)
    return 0.0 if v == 0 else v


def to_document(program: KeyframeProgram, model: KinematicModel) -> dict[str, Any]:
    """The program as plain YAML data (every value in the program's units)."""
    units = _Units(program.angle_unit, program.length_unit)
    rotary = [model.joint_types[model.joint_index(j)] is not JointType.PRISMATIC
              for j in program.joints]
    grip_rotary = _gripper_rotary(model)
    doc: dict[str, Any] = {"armctl_keyframes": FORMAT_VERSION, "arm": program.arm,
                           "units": _Flow(angle=program.angle_unit.value,
                                          length=program.length_unit.value)}
    if program.description:
        doc["description"] = program.description
    if program.calibration:
        doc["calibration"] = program.calibration
    if program.frame:
        doc["frame"] = program.frame
    doc["joints"] = list(program.joints)
    items = []
    for kf in program.keyframes:
        item: dict[str, Any] = _Flow()
        if kf.name:
            item["name"] = kf.name
        if kf.q is not None and program.widths:
            item["q"] = _multi_out(kf.q, program, model, units)
        elif kf.q is not None:
            item["q"] = [units.out(x, r) for x, r in zip(kf.q, rotary, strict=False)]
        elif kf.pose is not None:
            item["pose"] = _Flow(xyz=[units.length_out(x) for x in kf.pose[:3, 3]])
            if kf.orientation:
                item["pose"]["rpy"] = [units.angle_out(x)
                                       for x in matrix_to_rpy(kf.pose[:3, :3])]
        if kf.dwell:
            item["dwell"] = _num(kf.dwell, 4)
        if kf.gripper is not None:
            item["gripper"] = units.out(kf.gripper, grip_rotary)
        if kf.time is not None:
            item["time"] = _num(kf.time, 4)
        if kf.interpolation is not None:
            item["interpolation"] = kf.interpolation.value
        items.append(item)
    doc["keyframes"] = items
    return doc


def _multi_out(q: tuple[float, ...], program: KeyframeProgram, model: KinematicModel,
               units: _Units) -> list[Any]:
    """Joint values of an arm with universal or ball joints as written: nested per joint."""
    out: list[Any] = []
    at = 0
    for name, width in zip(program.joints, program.widths, strict=True):
        jtype = model.joint_types[model.joint_index(name)]
        vals = q[at:at + width]
        at += width
        if jtype is JointType.BALL:
            out.append(_FlowList(_num(x, 9) for x in vals))
        elif jtype is JointType.UNIVERSAL:
            out.append(_FlowList(units.angle_out(x) for x in vals))
        else:
            out.append(units.out(vals[0], jtype is not JointType.PRISMATIC))
    return _FlowList(out)


class _FlowList(list[Any]):
    """A list written on one line, nested lists included (a keyframe's joint values)."""


_Dumper: type[yaml.SafeDumper] = getattr(yaml, "CSafeDumper", yaml.SafeDumper)


class _FlowLists(_Dumper):  # type: ignore[valid-type,misc]
    pass


class _Flow(dict[str, Any]):
    """A mapping written on one line (each keyframe, the units)."""


def _flow_dict(dumper: yaml.SafeDumper, data: _Flow) -> yaml.Node:
    return dumper.represent_mapping("tag:yaml.org,2002:map", data.items(), flow_style=True)


def _flow_list(dumper: yaml.SafeDumper, data: list[Any]) -> yaml.Node:
    flow = all(not isinstance(x, (dict, list)) for x in data)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)


def _flow_nested(dumper: yaml.SafeDumper, data: _FlowList) -> yaml.Node:
    return dumper.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=True)


_FlowLists.add_representer(list, _flow_list)
_FlowLists.add_representer(_FlowList, _flow_nested)
_FlowLists.add_representer(_Flow, _flow_dict)


def save_keyframes(program: KeyframeProgram, path: str | Path, model: KinematicModel) -> Path:
    """Write a keyframe file atomically (a crash leaves the old or the new file, never half).

    Args:
        program: The program.
        path: Destination file.
        model: The arm (for joint types).

    Returns:
        The path written.
    """
    text = "# armctl keyframe program (see docs/motion.md)\n" + yaml.dump(
        to_document(program, model), Dumper=_FlowLists, sort_keys=False, width=100)
    return write_atomic(Path(path), text)
