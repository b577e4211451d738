"""The keyframe file: versioned YAML, read with clear errors and written atomically.

Example::

    armctl_keyframes: 1
    arm: so101
    units: {angle: deg, length: m}
    calibration: sha256:3f2a...        # optional: calibration the joint values were taught with
    joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]
    keyframes:
      - {name: start, q: [0, -30, 60, 20, 0], dwell: 0.5, gripper: 0.4}
      - {name: above_cup, pose: {xyz: [0.22, 0.0, 0.12], rpy: [0, 90, 0]}}
      - {q: [10, -20, 40, 10, 0], time: 1.25}

Joint values ``q`` follow ``joints`` and ``units.angle`` (prismatic joints always in metres);
``pose`` gives ``xyz`` [m] and ``rpy`` (in ``units.angle``) or ``quat`` ``[w, x, y, z]``
(with neither, only the position counts, the natural choice for 5-joint arms);
``gripper`` is in SI units ([rad] or [m]) or a string such as ``"30 deg"``; ``dwell`` and
``time`` are in seconds. Angles may also be written as strings with a unit (``"15 deg"``).
"""

from __future__ import annotations

import itertools
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from armctl.config.schema import JointType
from armctl.config.source import Section, load_yaml, parse_yaml
from armctl.errors import ConfigError, InputError, KeyPath
from armctl.kinematics.model import KinematicModel
from armctl.motion.keyframes import AngleUnit, Keyframe, KeyframeProgram
from armctl.spatial import make_transform, matrix_to_rpy, quat_to_matrix, rpy_to_matrix

__all__ = ["FORMAT_VERSION", "load_keyframes", "parse_keyframes", "save_keyframes",
           "write_atomic"]

FORMAT_VERSION = 1
_TOP_REQUIRED = ("armctl_keyframes", "arm", "joints", "keyframes")
_TOP_OPTIONAL = ("units", "calibration", "frame", "description")
_KF_KEYS = ("name", "q", "pose", "dwell", "gripper", "time")


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
    top.check_keys(_TOP_REQUIRED, _TOP_OPTIONAL)
    version = top.integer("armctl_keyframes", lo=1)
    if version > FORMAT_VERSION:
        raise top.error(f"keyframe format version {version} is newer than this armctl reads "
                        f"({FORMAT_VERSION})", "armctl_keyframes", fix="upgrade armctl")
    arm = top.string("arm")
    if arm != model.name:
        raise top.error(f"the keyframes were taught on arm {arm!r}, not {model.name!r}", "arm",
                        fix=f"play them on {arm!r}, or change 'arm:' if the arms are the same")
    unit = AngleUnit.RAD
    if top.has("units"):
        units = top.child("units").mapping()
        units.check_keys([], ["angle", "length"])
        unit = units.choice("angle", AngleUnit, [u.value for u in AngleUnit], AngleUnit.RAD)
        if units.has("length") and units.string("length") != "m":
            raise units.error("lengths must be in metres", "length", fix="write 'length: m'")
    joints = _joint_names(top, model)
    rotary = [model.joint_types[model.joint_index(j)] is not JointType.PRISMATIC for j in joints]
    frame = top.string("frame", required=False)
    if frame:
        try:
            model.frame_index(frame)
        except InputError as exc:
            raise top.error(str(exc), "frame") from None
    kfs = [_keyframe(sec.mapping(), len(joints), rotary, unit)
           for sec in top.list_of("keyframes")]
    times = [kf.time for kf in kfs if kf.time is not None]
    if any(b <= a for a, b in itertools.pairwise(times)):
        raise top.error("keyframe times must increase", "keyframes",
                        fix="sort the keyframes by 'time' or remove the times")
    return KeyframeProgram(
        arm=arm, joints=joints, keyframes=tuple(kfs),
        calibration=top.string("calibration", required=False) or None, frame=frame,
        angle_unit=unit, description=top.string("description", required=False),
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


def _keyframe(sec: Section, n: int, rotary: list[bool], unit: AngleUnit) -> Keyframe:
    sec.check_keys([], _KF_KEYS)
    if sec.has("q") == sec.has("pose"):
        raise sec.error("a keyframe needs exactly one of 'q' (joint values) or 'pose'",
                        fix="write 'q: [...]' with one value per joint, or 'pose: {xyz: ...}'")
    q = pose = None
    orientation = True
    if sec.has("q"):
        raw = sec.vector("q", n, angle=True)
        q = tuple(_to_si(x, raw_v, r, unit)
                  for x, raw_v, r in zip(raw, sec.value["q"], rotary, strict=False))
    else:
        psec = sec.child("pose").mapping()
        pose = _pose(psec, unit)
        orientation = psec.has("rpy") or psec.has("quat")
    time = sec.number("time", nonnegative=True) if sec.has("time") else None
    return Keyframe(
        q=q, pose=pose, orientation=orientation, name=sec.string("name", required=False),
        dwell=sec.number("dwell", 0.0, nonnegative=True),
        gripper=sec.number("gripper", angle=True) if sec.has("gripper") else None,
        time=time, where=sec.where(),
    )


def _to_si(parsed: float, raw: Any, rotary: bool, unit: AngleUnit) -> float:
    """A plain number in a degree file is degrees for rotary joints; strings carry their unit."""
    if unit is AngleUnit.DEG and rotary and not isinstance(raw, str):
        return math.radians(parsed)
    return parsed


def _pose(sec: Section, unit: AngleUnit) -> np.ndarray:
    sec.check_keys(["xyz"], ["rpy", "quat"])
    xyz = sec.vector("xyz", 3)
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
        raw = sec.vector("rpy", 3, (0.0, 0.0, 0.0), angle=True)
        vals = sec.value.get("rpy") or [0.0, 0.0, 0.0]
        rpy = [_to_si(x, r, True, unit) for x, r in zip(raw, vals, strict=False)]
        rot = rpy_to_matrix(rpy)
    return make_transform(rot, xyz)


# ---- writing ---------------------------------------------------------------------------------
def _num(x: float, digits: int = 7) -> float:
    v = round(float(x), digits)
    return 0.0 if v == 0 else v


def to_document(program: KeyframeProgram, model: KinematicModel) -> dict[str, Any]:
    """The program as plain YAML data (angles in the program's unit)."""
    deg = program.angle_unit is AngleUnit.DEG
    rotary = [model.joint_types[model.joint_index(j)] is not JointType.PRISMATIC
              for j in program.joints]

    def ang(x: float) -> float:
        return _num(math.degrees(x), 5) if deg else _num(x)

    doc: dict[str, Any] = {"armctl_keyframes": FORMAT_VERSION, "arm": program.arm,
                           "units": _Flow(angle=program.angle_unit.value, length="m")}
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
        if kf.q is not None:
            item["q"] = [ang(x) if r else _num(x) for x, r in zip(kf.q, rotary, strict=False)]
        elif kf.pose is not None:
            item["pose"] = _Flow(xyz=[_num(x) for x in kf.pose[:3, 3]])
            if kf.orientation:
                item["pose"]["rpy"] = [ang(x) for x in matrix_to_rpy(kf.pose[:3, :3])]
        if kf.dwell:
            item["dwell"] = _num(kf.dwell, 4)
        if kf.gripper is not None:
            item["gripper"] = _num(kf.gripper)
        if kf.time is not None:
            item["time"] = _num(kf.time, 4)
        items.append(item)
    doc["keyframes"] = items
    return doc


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


_FlowLists.add_representer(list, _flow_list)
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


def write_atomic(path: Path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file in the same folder and a rename.

    Raises:
        ConfigError: If the folder cannot be written.
    """
    folder = path.parent if str(path.parent) else Path(".")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
            os.replace(tmp, path)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        try:
            dfd = os.open(folder, os.O_RDONLY)
        except OSError:
            return path
        try:
            os.fsync(dfd)
        except OSError:
            pass
        finally:
            os.close(dfd)
    except OSError as exc:
        raise ConfigError(f"cannot write the file: {exc}", KeyPath(path),
                          "check that the folder exists and is writable") from exc
    return path
