"""Reads armctl's arm YAML format into an :class:`~armctl.config.schema.ArmSpec`.

The format is documented in ``docs/config.md``. Everything is validated here, with errors that
name the file, the key path, the line, what was found and what is expected.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from armctl.config.format_yaml import SCHEMA_VERSION, check_version, parse_origin, parse_shape
from armctl.config.schema import (
    ArmRole,
    ArmSpec,
    FrameSpec,
    JointRole,
    JointSpec,
    JointType,
    Limits,
    LinkSpec,
    Origin,
    unit_axis,
)
from armctl.config.source import Document, Section, load_yaml
from armctl.config.tree import check_arm_size, order_tree
from armctl.spatial import make_transform, matrix_to_rpy

__all__ = ["SCHEMA_VERSION", "load_arm_yaml", "parse_arm"]

_TOP_REQUIRED = ("name", "base", "joints")
_TOP_OPTIONAL = (
    "armctl", "description", "source", "dh_convention", "links", "frames", "tool",
    "end_effectors", "poses", "bus", "motion", "scene", "collision", "role",
)
_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "universal", "spherical")
_DEFAULT_AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def load_arm_yaml(path: str | Path) -> ArmSpec:
    """Read and validate an arm YAML file.

    Args:
        path: The file.

    Returns:
        The validated arm description.

    Raises:
        ConfigError: If the file is missing, is not YAML, or does not follow the schema.
    """
    return parse_arm(load_yaml(path))


def parse_arm(doc: Document) -> ArmSpec:
    """Validate a parsed arm YAML document.

    Args:
        doc: The document.

    Returns:
        The validated arm description.
    """
    top = doc.root()
    top.check_keys(_TOP_REQUIRED, _TOP_OPTIONAL)
    check_version(top)
    base = top.string("base")
    dh = top.choice("dh_convention", str, ["standard", "modified"], "none")
    joints: list[JointSpec] = []
    joint_secs = top.list_of("joints")
    check_arm_size(len(joint_secs), 0, top.where("joints"))  # before reading them one by one
    for sec in joint_secs:
        joints.extend(_parse_joint(sec.mapping(), dh))
    if not joints:
        raise top.error("the arm has no joints", "joints", fix="list at least one joint")
    frame_secs = top.list_of("frames")
    check_arm_size(len(joints), 0, top.where("joints"))  # multi-DOF joints count per axis
    check_arm_size(0, len(frame_secs), top.where("frames"))
    links = [_parse_link(sec.mapping(), doc.file) for sec in top.list_of("links")]
    frames = [_parse_frame(sec.mapping()) for sec in frame_secs]
    declared = [lk.name for lk in links]
    if len(set(declared)) != len(declared):
        dup = next(n for n in declared if declared.count(n) > 1)
        raise top.error(f"duplicate link name {dup!r}", "links")
    ordered, link_order = order_tree(base, joints, declared, frames, top.where())
    by_link = {lk.name: lk for lk in links}
    all_links = tuple(by_link.get(name, LinkSpec(name)) for name in link_order)
    frame_names = [*link_order, *(f.name for f in frames)]
    tool = _tool(top, frame_names, frames, ordered)
    end_effectors = _end_effectors(top, frame_names, tool)
    actuated = [j for j in ordered if j.type.actuated]
    poses = _parse_poses(top, actuated) if top.has("poses") else {}
    spec = ArmSpec(
        name=top.string("name"), base=base, links=all_links, joints=tuple(ordered),
        frames=tuple(frames), tool=tool, end_effectors=end_effectors, poses=poses,
        description=top.string("description", required=False),
        source=top.string("source", required=False), file=doc.file,
        role=top.choice("role", ArmRole, [r.value for r in ArmRole], ArmRole.ARM),
    )
    if top.has("bus"):
        from armctl.config.bus import parse_bus

        bus = parse_bus(top.child("bus").mapping())
        actuated_names = {j.name for j in actuated}
        for servo in bus.servos:
            if servo.joint not in actuated_names:
                raise top.error(
                    f"servo for unknown or fixed joint {servo.joint!r}", "bus", "servos",
                    servo.joint, fix=_nearest(servo.joint, [j.name for j in actuated]))
        spec = _replace(spec, bus=bus)
    if top.has("motion"):
        from armctl.config.motion import parse_motion

        spec = _replace(spec, motion=parse_motion(top.child("motion").mapping()))
    if top.has("scene") or top.has("collision"):
        from armctl.config.scene_yaml import parse_collision, parse_scene

        names = [lk.name for lk in all_links]
        if top.has("scene"):
            spec = _replace(spec, scene=parse_scene(top.child("scene"), names))
        if top.has("collision"):
            spec = _replace(spec, collision=parse_collision(top.child("collision"), names))
    return spec


def _replace(spec: ArmSpec, **changes: object) -> ArmSpec:
    from dataclasses import replace

    return replace(spec, **changes)  # type: ignore[arg-type]


def _nearest(name: str, valid: list[str]) -> str:
    import difflib

    close = difflib.get_close_matches(name, valid, n=1)
    return f"did you mean {close[0]!r}?" if close else f"valid joints: {', '.join(valid)}"


def origin_from_matrix(t: np.ndarray) -> Origin:
    """The :class:`Origin` of a rigid transform."""
    xyz = tuple(float(x) for x in t[:3, 3])
    rpy = tuple(float(x) for x in matrix_to_rpy(t[:3, :3]))
    return Origin(xyz, rpy)  # type: ignore[arg-type]


def _axis(sec: Section) -> tuple[float, float, float]:
    """A unit vector from a section whose value is a list of three numbers."""
    v = sec.as_vector(3)
    unit = unit_axis(v)
    if unit is None:
        shown = ", ".join(f"{x:g}" for x in v)
        raise sec.error(f"axis [{shown}] has zero length", fix="give a direction such as [0, 0, 1]")
    return unit


def _limits(sec: Section, jtype: JointType) -> Limits:
    if not sec.has("limits"):
        if jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
            raise sec.error(f"a {jtype.value} joint needs position limits", fix=(
                "add 'limits: {lower: ..., upper: ...}' (radians or metres), or use type "
                "'continuous' for a joint that turns without end"))
        return Limits()
    return _parse_limits(sec.child("limits").mapping(), jtype)


def _parse_limits(lim: Section, jtype: JointType) -> Limits:
    angle = jtype is not JointType.PRISMATIC
    lim.check_keys([], ["lower", "upper", "velocity", "acceleration", "jerk", "effort"])
    if jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
        lim.check_keys(["lower", "upper"], ["velocity", "acceleration", "jerk", "effort"])
        lower = lim.number("lower", angle=angle)
        upper = lim.number("upper", angle=angle)
        if lower > upper:
            raise lim.error(f"lower limit {lower:.6g} is greater than upper limit {upper:.6g}",
                            "lower", fix="swap the two values")
    elif lim.has("lower") or lim.has("upper"):
        raise lim.error(f"a {jtype.value} joint has no position limits", "lower",
                        fix="remove lower/upper, or make the joint 'revolute'")
    else:
        lower, upper = -math.inf, math.inf

    def opt(key: str) -> float | None:
        return lim.number(key, angle=angle, positive=True) if lim.has(key) else None

    return Limits(lower, upper, opt("velocity"), opt("acceleration"), opt("jerk"), opt("effort"))


def _joint_origin(sec: Section, dh: str) -> tuple[Origin, np.ndarray | None]:
    """The joint origin, and for standard DH the transform that follows the joint motion."""
    if sec.has("dh"):
        if sec.has("origin"):
            raise sec.error("give either 'origin' or 'dh', not both", "dh")
        if dh == "none":
            raise sec.error("'dh' parameters need 'dh_convention: standard' or 'modified' at "
                            "the top of the file", "dh")
        p = sec.child("dh").mapping()
        p.check_keys(["a", "alpha", "d"], ["theta"])
        a, d = p.number("a"), p.number("d")
        alpha, theta = p.number("alpha", angle=True), p.number("theta", 0.0, angle=True)
        rz = make_transform(_rot(2, theta))
        tz = make_transform(pos=(0, 0, d))
        tx = make_transform(pos=(a, 0, 0))
        rx = make_transform(_rot(0, alpha))
        if dh == "modified":  # Craig: Rx(alpha) Tx(a) Rz(theta) Tz(d), then the joint motion
            return origin_from_matrix(rx @ tx @ rz @ tz), None
        return Origin(), rz @ tz @ tx @ rx  # standard: the motion, then Rz Tz Tx Rx
    return parse_origin(sec), None


def _rot(axis: int, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    if axis == 0:
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _parse_joint(sec: Section, dh: str) -> list[JointSpec]:
    keys = ["name", "type", "parent", "child"]
    optional = ["origin", "dh", "axis", "axes", "limits", "role"]
    sec.check_keys(keys, optional)
    name = sec.string("name")
    kind = sec.choice("type", str, _JOINT_TYPES)
    parent, child = sec.string("parent"), sec.string("child")
    role = sec.choice("role", JointRole, [r.value for r in JointRole], JointRole.ARM)
    origin, post = _joint_origin(sec, dh)
    where = sec.where()
    if kind in ("universal", "spherical"):
        if post is not None:
            raise sec.error("DH parameters describe 1-DOF joints only", "dh",
                            fix="use 'origin' for a universal or spherical joint")
        return _expand_multi(sec, name, kind, parent, child, origin, role)
    jtype = JointType(kind)
    if sec.has("axes"):
        raise sec.error(f"'axes' is for universal and spherical joints; a {kind} joint has "
                        "one 'axis'", "axes")
    axis = _axis(sec.child("axis")) if sec.has("axis") else (0.0, 0.0, 1.0)
    if sec.has("dh") and sec.has("axis"):
        raise sec.error("a DH joint moves about (or along) its z axis", "axis",
                        fix="remove 'axis'")
    limits = _limits(sec, jtype) if jtype is not JointType.FIXED else Limits()
    if jtype is JointType.FIXED and sec.has("limits"):
        raise sec.error("a fixed joint has no limits", "limits", fix="remove 'limits'")
    if post is None:
        return [JointSpec(name, jtype, parent, child, origin, axis, limits, role, where)]
    mid = f"{child}__dh"
    return [
        JointSpec(name, jtype, parent, mid, origin, axis, limits, role, where),
        JointSpec(f"{name}__dh", JointType.FIXED, mid, child, origin_from_matrix(post),
                  where=where),
    ]


def _expand_multi(sec: Section, name: str, kind: str, parent: str, child: str, origin: Origin,
                  role: JointRole) -> list[JointSpec]:
    n = 2 if kind == "universal" else 3
    if sec.has("axis"):
        raise sec.error(f"a {kind} joint takes 'axes' (a list of {n}), not 'axis'", "axis")
    if sec.has("axes"):
        axes_secs = sec.list_of("axes", None)
        if len(axes_secs) != n:
            raise sec.error(f"a {kind} joint needs {n} axes, found {len(axes_secs)}", "axes")
        axes = [_axis(a) for a in axes_secs]
    else:
        axes = list(_DEFAULT_AXES[:n])
    lims = sec.list_of("limits", None)
    if len(lims) != n:
        raise sec.error(f"a {kind} joint needs a list of {n} limits, one per axis", "limits",
                        fix="write 'limits: [{lower: ..., upper: ...}, ...]'")
    limits = [_parse_limits(lim.mapping(), JointType.REVOLUTE) for lim in lims]
    out = []
    links = [parent, *(f"{name}__{i}" for i in range(1, n)), child]
    for i in range(n):
        out.append(JointSpec(
            f"{name}_{i + 1}", JointType.REVOLUTE, links[i], links[i + 1],
            origin if i == 0 else Origin(), axes[i], limits[i], role, sec.where()))
    return out


def _parse_frame(sec: Section) -> FrameSpec:
    sec.check_keys(["name", "parent"], ["origin"])
    return FrameSpec(sec.string("name"), sec.string("parent"), parse_origin(sec), sec.where())


def _parse_link(sec: Section, file: Path | None) -> LinkSpec:
    sec.check_keys(["name"], ["visual", "collision"])
    visual = tuple(parse_shape(s.mapping(), file) for s in sec.list_of("visual", None))
    collision = tuple(parse_shape(s.mapping(), file) for s in sec.list_of("collision", None))
    return LinkSpec(sec.string("name"), visual, collision)


def _tool(top: Section, frame_names: list[str], frames: list[FrameSpec],
          joints: list[JointSpec]) -> str:
    if top.has("tool"):
        tool = top.string("tool")
        if tool not in frame_names:
            raise top.error(f"tool frame {tool!r} is neither a link nor a frame", "tool",
                            fix=_nearest(tool, frame_names).replace("valid joints", "frames"))
        return tool
    if frames:
        return frames[-1].name
    parents = {j.parent for j in joints}
    leaves = [j.child for j in joints if j.child not in parents]
    return leaves[-1]


def _end_effectors(top: Section, frame_names: list[str], tool: str) -> tuple[str, ...]:
    if not top.has("end_effectors"):
        return (tool,)
    out = []
    for i, sec in enumerate(top.list_of("end_effectors", None)):
        if not isinstance(sec.value, str) or sec.value not in frame_names:
            raise top.error(f"end effector {sec.value!r} is neither a link nor a frame",
                            "end_effectors", i)
        out.append(sec.value)
    return tuple(out) if tool in out else (tool, *out)


def _parse_poses(top: Section, actuated: list[JointSpec]) -> dict[str, dict[str, float]]:
    names = [j.name for j in actuated]
    out: dict[str, dict[str, float]] = {}
    for pose_name, sec in top.child("poses").items():
        values: dict[str, float] = {}
        if isinstance(sec.value, list):
            if len(sec.value) != len(names):
                raise sec.error(f"pose {pose_name!r} has {len(sec.value)} values but the arm has "
                                f"{len(names)} joints ({', '.join(names)})")
            for i, j in enumerate(actuated):
                values[j.name] = sec._as_number(sec.value[i], i, angle=True)
        else:
            sec.mapping().check_keys(names)
            for j in actuated:
                values[j.name] = sec.number(j.name, angle=True)
        for j in actuated:
            v = values[j.name]
            if not j.limits.lower - 1e-12 <= v <= j.limits.upper + 1e-12:
                raise sec.error(f"pose {pose_name!r}: joint {j.name!r} value {v:.6g} is outside "
                                f"its limits [{j.limits.lower:.6g}, {j.limits.upper:.6g}]")
        out[pose_name] = values
    return out
