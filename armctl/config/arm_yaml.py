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
    PoseValue,
    unit_axis,
)
from armctl.config.source import Document, Section, load_yaml
from armctl.config.tree import check_arm_size, order_tree
from armctl.spatial import make_transform, matrix_to_rpy

__all__ = ["SCHEMA_VERSION", "load_arm_yaml", "parse_arm"]

_TOP_REQUIRED = ("name", "base", "joints")
_TOP_OPTIONAL = (
    "armctl", "description", "source", "dh_convention", "links", "frames", "tool",
    "end_effectors", "poses", "bus", "motion", "scene", "collision", "role", "skin",
)
_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "universal", "ball", "spherical")
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
    check_arm_size(len(joints), 0, top.where("joints"))
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
        multi = {j.name: j.type.value for j in actuated if j.type.nq != 1}
        for servo in bus.servos:
            if servo.joint in multi:
                raise top.error(
                    f"servo {servo.id} drives joint {servo.joint!r}, a {multi[servo.joint]} "
                    "joint: a servo turns one axis, so it cannot drive a multi-DOF joint",
                    "bus", "servos", servo.joint,
                    fix="drive 1-DOF joints with servos (write a powered wrist as revolute "
                    "joints), or remove this servo")
            if servo.joint not in actuated_names:
                raise top.error(
                    f"servo for unknown or fixed joint {servo.joint!r}", "bus", "servos",
                    servo.joint, fix=_nearest(servo.joint, [j.name for j in actuated]))
        spec = _replace(spec, bus=bus)
    if top.has("motion"):
        from armctl.config.motion import parse_motion

        spec = _replace(spec, motion=parse_motion(top.child("motion").mapping()))
    if top.has("skin"):
        from armctl.config.skin import parse_skin

        spec = _replace(spec, skin=parse_skin(top.child("skin").mapping(), doc.file,
                                              frame_names, list(poses)))
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
    if kind in ("universal", "ball", "spherical"):
        if post is not None:
            raise sec.error("DH parameters describe 1-DOF joints only", "dh",
                            fix=f"use 'origin' for a {kind} joint")
        if kind == "universal":
            return [_parse_universal(sec, name, parent, child, origin, role)]
        return [_parse_ball(sec, name, kind, parent, child, origin, role)]
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


_BALL_LIMITS_FORM = ("limits: {swing: 60 deg, twist: {lower: -90 deg, upper: 90 deg}, "
                     "velocity: ...} (swing: the largest angle of the twist axis from its rest "
                     "direction; twist: the turn about that axis)")


def _parse_universal(sec: Section, name: str, parent: str, child: str, origin: Origin,
                     role: JointRole) -> JointSpec:
    """A universal joint: one joint of two coordinates, about ``axes[0]``, then ``axes[1]``."""
    if sec.has("axis"):
        raise sec.error("a universal joint takes 'axes' (a list of 2), not 'axis'", "axis",
                        fix="write 'axes: [[1, 0, 0], [0, 1, 0]]'")
    if sec.has("axes"):
        axes_secs = sec.list_of("axes", None)
        if len(axes_secs) != 2:
            raise sec.error(f"a universal joint needs 2 axes, found {len(axes_secs)}", "axes")
        axes = (_axis(axes_secs[0]), _axis(axes_secs[1]))
    else:
        axes = (_DEFAULT_AXES[0], _DEFAULT_AXES[1])
    if abs(float(np.dot(axes[0], axes[1]))) > 1.0 - 1e-9:
        raise sec.error("the two axes of a universal joint are parallel", "axes",
                        fix="give two different directions, such as [1, 0, 0] and [0, 1, 0]")
    if not sec.has("limits") or not isinstance(sec.value["limits"], list):
        raise sec.error("a universal joint needs a list of 2 limits, one per axis", "limits",
                        fix="write 'limits: [{lower: ..., upper: ...}, {lower: ..., upper: ...}]'")
    lims = sec.list_of("limits", None)
    if len(lims) != 2:
        raise sec.error(f"a universal joint needs a list of 2 limits, found {len(lims)}",
                        "limits",
                        fix="write 'limits: [{lower: ..., upper: ...}, {lower: ..., upper: ...}]'")
    limits = tuple(_parse_limits(lim.mapping(), JointType.REVOLUTE) for lim in lims)
    return JointSpec(name, JointType.UNIVERSAL, parent, child, origin, axes[0], limits[0], role,
                     sec.where(), axes=axes, axis_limits=limits)


def _parse_ball(sec: Section, name: str, kind: str, parent: str, child: str, origin: Origin,
                role: JointRole) -> JointSpec:
    """A ball joint (``spherical`` is the same type): a unit quaternion, cone and twist limits."""
    if sec.has("axes"):
        raise sec.error(f"a {kind} joint is one 3-DOF joint and takes no 'axes'", "axes",
                        fix="remove 'axes'; 'axis' (default [0, 0, 1]) sets its twist axis, "
                        "the centre of its swing cone; its limits are written "
                        + _BALL_LIMITS_FORM)
    axis = _axis(sec.child("axis")) if sec.has("axis") else (0.0, 0.0, 1.0)
    if not sec.has("limits"):
        return JointSpec(name, JointType.BALL, parent, child, origin, axis, Limits(), role,
                         sec.where())
    if isinstance(sec.value["limits"], list):
        raise sec.error(f"a {kind} joint's limits are a swing cone and a twist range, not a "
                        "list per axis", "limits", fix="write " + _BALL_LIMITS_FORM)
    lim = sec.child("limits").mapping()
    lim.check_keys([], ["swing", "twist", "velocity", "acceleration", "jerk", "effort"])
    if lim.has("lower") or lim.has("upper"):  # pragma: no cover - check_keys refuses them
        raise lim.error("use swing and twist", fix="write " + _BALL_LIMITS_FORM)
    swing = math.pi
    if lim.has("swing"):
        swing = lim.number("swing", angle=True, positive=True)
        if swing > math.pi + 1e-12:
            raise lim.error(f"swing {swing:.6g} rad is more than pi (180 deg)", "swing",
                            fix="give the largest angle of the twist axis from its rest "
                            "direction, at most 180 deg (180 deg: no cone limit)")
        swing = min(swing, math.pi)
    lower, upper = -math.inf, math.inf
    if lim.has("twist"):
        if not isinstance(lim.value["twist"], dict):
            raise lim.error("twist takes a range, not one angle", "twist",
                            fix="write twist: {lower: -45 deg, upper: 45 deg}")
        tw = lim.child("twist").mapping()
        tw.check_keys(["lower", "upper"])
        lower, upper = tw.number("lower", angle=True), tw.number("upper", angle=True)
        for key, v in (("lower", lower), ("upper", upper)):
            if abs(v) > math.pi + 1e-12:
                raise tw.error(f"twist {key} {v:.6g} rad is outside [-pi, pi]", key,
                               fix="give twist limits within -180 deg .. 180 deg")
        if lower > upper:
            raise tw.error(f"lower twist {lower:.6g} is greater than upper twist {upper:.6g}",
                           "lower", fix="swap the two values")
        lower, upper = max(lower, -math.pi), min(upper, math.pi)

    def opt(key: str) -> float | None:
        return lim.number(key, angle=True, positive=True) if lim.has(key) else None

    limits = Limits(lower, upper, opt("velocity"), opt("acceleration"), opt("jerk"),
                    opt("effort"))
    return JointSpec(name, JointType.BALL, parent, child, origin, axis, limits, role,
                     sec.where(), swing=swing)


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


def _parse_poses(top: Section, actuated: list[JointSpec]) -> dict[str, dict[str, PoseValue]]:
    names = [j.name for j in actuated]
    nq = sum(j.type.nq for j in actuated)
    out: dict[str, dict[str, PoseValue]] = {}
    for pose_name, sec in top.child("poses").items():
        values: dict[str, PoseValue] = {}
        if isinstance(sec.value, list):  # the flattened joint vector q, in joint order
            if len(sec.value) != nq:
                raise sec.error(f"pose {pose_name!r} has {len(sec.value)} values but the arm's "
                                f"joint vector has {nq} ({_q_layout(actuated)})",
                                fix="give one value per entry in that order, or write the pose "
                                "as a mapping {joint: value}")
            k = 0
            for j in actuated:
                if j.type.nq == 1:
                    values[j.name] = sec._as_number(sec.value[k], k, angle=True)
                elif j.type is JointType.UNIVERSAL:
                    values[j.name] = tuple(sec._as_number(sec.value[k + i], k + i, angle=True)
                                           for i in range(2))
                else:
                    quat = [sec._as_number(sec.value[k + i], k + i) for i in range(4)]
                    values[j.name] = _unit_quat(sec, quat, pose_name, j.name)
                k += j.type.nq
        else:
            sec.mapping().check_keys(names)
            for j in actuated:
                if j.type.nq == 1:
                    values[j.name] = sec.number(j.name, angle=True)
                elif j.type is JointType.UNIVERSAL:
                    values[j.name] = sec.child(j.name).as_vector(2, angle=True)
                else:
                    values[j.name] = _ball_value(sec.child(j.name), pose_name, j.name)
        for j in actuated:
            v = values[j.name]
            if isinstance(v, tuple):
                _check_multi_pose(sec, pose_name, j, v)
            elif not j.limits.lower - 1e-12 <= v <= j.limits.upper + 1e-12:
                raise sec.error(f"pose {pose_name!r}: joint {j.name!r} value {v:.6g} is outside "
                                f"its limits [{j.limits.lower:.6g}, {j.limits.upper:.6g}]",
                                fix="give a value inside the joint's limits, or widen them")
        out[pose_name] = values
    return out


def _q_layout(actuated: list[JointSpec]) -> str:
    parts = []
    for j in actuated:
        if j.type is JointType.BALL:
            parts.append(f"{j.name}: 4 (quaternion w, x, y, z)")
        elif j.type is JointType.UNIVERSAL:
            parts.append(f"{j.name}: 2")
        else:
            parts.append(j.name)
    return ", ".join(parts)


def _unit_quat(sec: Section, quat: list[float], pose: str, joint: str) -> tuple[float, ...]:
    norm = math.sqrt(sum(x * x for x in quat))
    if abs(norm - 1.0) > 1e-6:
        raise sec.error(f"pose {pose!r}: ball joint {joint!r} quaternion {quat} has norm "
                        f"{norm:.6g}, not 1", fix="give a unit quaternion [w, x, y, z], or "
                        "'{rpy: [roll, pitch, yaw]}' or '{rotvec: [x, y, z]}'")
    return tuple(x / norm for x in quat)


def _ball_value(sec: Section, pose: str, joint: str) -> tuple[float, ...]:
    """A ball joint's pose value: ``[w, x, y, z]``, ``{rpy: [...]}`` or ``{rotvec: [...]}``."""
    from armctl.spatial import matrix_to_quat, rotvec_to_matrix

    if isinstance(sec.value, dict):
        sec.check_keys([], ["rpy", "rotvec"])
        if sec.has("rpy") == sec.has("rotvec"):
            raise sec.error(f"pose {pose!r}: give ball joint {joint!r} either 'rpy' or 'rotvec'",
                            fix="write '{rpy: [roll, pitch, yaw]}' or '{rotvec: [x, y, z]}'")
        if sec.has("rpy"):
            from armctl.spatial import rpy_to_matrix

            rot = rpy_to_matrix(sec.vector("rpy", 3, angle=True))
        else:
            rot = rotvec_to_matrix(sec.vector("rotvec", 3))
        q = matrix_to_quat(rot)
        return tuple(float(x) for x in (q if q[0] >= 0 else -q))
    return _unit_quat(sec, list(sec.as_vector(4)), pose, joint)


def _check_multi_pose(sec: Section, pose: str, j: JointSpec, v: tuple[float, ...]) -> None:
    if j.type is JointType.UNIVERSAL:
        for i, (x, lim) in enumerate(zip(v, j.axis_limits, strict=True)):
            if not lim.lower - 1e-12 <= x <= lim.upper + 1e-12:
                raise sec.error(f"pose {pose!r}: joint {j.name!r} angle {i + 1} {x:.6g} is "
                                f"outside its limits [{lim.lower:.6g}, {lim.upper:.6g}]",
                                fix="give an angle inside the limits, or widen them")
        return
    from armctl.spatial import swing_twist

    swing, twist = swing_twist(v, j.axis)
    if swing > j.swing + 1e-9:
        raise sec.error(f"pose {pose!r}: ball joint {j.name!r} swings {swing:.6g} rad, more "
                        f"than its limit {j.swing:.6g} rad",
                        fix=f"give a rotation that turns its axis at most "
                        f"{math.degrees(j.swing):.4g} deg, or widen limits.swing")
    if not j.limits.lower - 1e-9 <= twist <= j.limits.upper + 1e-9:
        raise sec.error(f"pose {pose!r}: ball joint {j.name!r} twist {twist:.6g} rad is outside "
                        f"its limits [{j.limits.lower:.6g}, {j.limits.upper:.6g}]",
                        fix="give a rotation with less turn about the joint's axis, or widen "
                        "limits.twist")
