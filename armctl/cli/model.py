"""Commands about the arm model: ``arms``, ``info``, ``fk``, ``convert``."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from armctl.cli._common import add_config, add_json, emit, fmt, load_arm_arg, parse_angles, table
from armctl.cli._scene import add_scene_option

if TYPE_CHECKING:
    import numpy as np

    from armctl.arm import Arm

ORDER = 10


def register(sub: argparse._SubParsersAction) -> None:
    """Add the model commands."""
    p = sub.add_parser("arms", help="list the bundled arm configs")
    add_json(p)
    p.set_defaults(func=cmd_arms)

    p = sub.add_parser("info", help="show an arm's joints, limits, frames and tree")
    add_config(p)
    p.add_argument("--tip", help="URDF only: keep the chain to this link")
    p.add_argument("--deg", action="store_true", help="show angles in degrees")
    add_json(p)
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("fk", help="forward kinematics: the pose of a frame for joint values")
    add_config(p)
    p.add_argument("q", nargs="+", metavar="Q", help="joint values, radians/metres (see --deg)")
    p.add_argument("--frame", help="frame name (default: the tool frame)")
    p.add_argument("--deg", action="store_true", help="rotary joint values in degrees")
    p.add_argument("--tip", help="URDF only: keep the chain to this link")
    add_scene_option(p)  # --scene FILE: the clearance is measured in it
    add_json(p)
    p.set_defaults(func=cmd_fk)

    p = sub.add_parser("convert", help="convert a URDF to armctl YAML")
    p.add_argument("urdf", metavar="URDF", help="the .urdf file")
    p.add_argument("-o", "--output", required=True, help="the YAML file to write")
    p.add_argument("--tip", help="keep only the chain to this link (it becomes the tool)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output file")
    add_json(p)
    p.set_defaults(func=cmd_convert)


def cmd_arms(args: argparse.Namespace) -> int:
    """List the bundled arm configs."""
    from armctl.config import bundled_configs, load_spec

    rows, data = [], []
    for name, path in bundled_configs().items():
        spec = load_spec(path)
        dof = sum(j.type.nv for j in spec.actuated_joints)  # a ball joint counts 3
        port = spec.bus.port if spec.bus else "-"
        rows.append([name, str(dof), spec.tool, port, spec.description])
        data.append({"name": name, "path": str(path), "dof": dof, "tool": spec.tool,
                     "port": port, "description": spec.description})
    emit(args, {"arms": data}, table(["name", "dof", "tool", "port", "description"], rows, [1]))
    return 0


def _angle_unit(is_prismatic: bool, deg: bool) -> tuple[str, float]:
    if is_prismatic:
        return "m", 1.0
    return ("deg", 180.0 / math.pi) if deg else ("rad", 1.0)


def cmd_info(args: argparse.Namespace) -> int:
    """Show joints, limits, frames and the tree."""
    from armctl.config.schema import JointType
    from armctl.servo.calibration import load_calibration
    from armctl.servo.effective_limits import effective_limits

    arm = load_arm_arg(args)
    spec = arm.spec
    cal = load_calibration(spec)
    eff = effective_limits(spec, cal) if cal is not None else None
    rows = []
    joints: list[dict[str, Any]] = []
    by_name = {j.name: j for j in spec.joints}
    for i, name in enumerate(arm.joint_names):
        js = by_name[name]
        unit, k = _angle_unit(js.type is JointType.PRISMATIC, args.deg)
        qs, vs = arm.q_index(i), arm.v_index(i)  # a multi-DOF joint has several entries
        lower, upper = arm.lower[qs].tolist(), arm.upper[qs].tolist()
        vels = arm.velocity_limits[vs].tolist()
        vel = vels[0]
        lim = eff.joint(name) if eff is not None and js.type.nq == 1 else None
        calibrated = lim.calibration if lim is not None else None
        shown_cal = ([fmt(calibrated[0] * k, 3), fmt(calibrated[1] * k, 3)] if calibrated
                     else ["-", "-"]) if eff is not None else []
        if js.type is JointType.BALL:  # a cone about the twist axis and a twist range
            lo_text = f"swing {fmt(js.swing * k, 3)}"
            hi_text = f"twist {fmt(js.limits.lower * k, 3)}..{fmt(js.limits.upper * k, 3)}"
        else:
            lo_text = ", ".join(fmt(v * k, 3) for v in lower)
            hi_text = ", ".join(fmt(v * k, 3) for v in upper)
        axes = js.axes if js.type is JointType.UNIVERSAL and js.axes else (js.axis,)
        per_axis = vels if js.type is JointType.UNIVERSAL else [vel]
        vel_text = ", ".join("-" if math.isnan(v) else f"{fmt(v * k, 2)} {unit}/s"
                             for v in per_axis)
        rows.append([str(i), name, js.type.value, js.role.value, lo_text, hi_text, *shown_cal,
                     unit, vel_text, "; ".join(" ".join(fmt(a, 3) for a in ax) for ax in axes)])
        one = js.type.nq == 1
        joints.append({"index": i, "name": name, "type": js.type.value, "role": js.role.value,
                       "parent": js.parent, "child": js.child, "axis": list(js.axis),
                       "lower": lower[0] if one else lower, "upper": upper[0] if one else upper,
                       "velocity": vel if one else vels,
                       "acceleration": (arm.acceleration_limits[vs].tolist()[0] if one
                                        else arm.acceleration_limits[vs].tolist()),
                       "jerk": (arm.jerk_limits[vs].tolist()[0] if one
                                else arm.jerk_limits[vs].tolist())})
        if js.type is JointType.BALL:
            joints[-1].update({"swing": js.swing,
                               "twist": [js.limits.lower, js.limits.upper]})
        if lim is not None:
            joints[-1].update({
                "calibrated": list(calibrated) if calibrated else None,
                "effective": [lim.lower.value, lim.upper.value],
                "lower_source": lim.lower.source.value, "upper_source": lim.upper.source.value})
    lines = [f"arm {spec.name!r}: {arm.dof} DOF, base {spec.base!r}, tool {spec.tool!r}"]
    if spec.description:
        lines.append(spec.description)
    if spec.source:
        lines.append(f"source: {spec.source}")
    if spec.file:
        lines.append(f"file: {spec.file}")
    lines.append("")
    heads = ["#", "joint", "type", "role", "lower", "upper"]
    heads += ["cal. lower", "cal. upper"] if eff is not None else []
    lines.append(table([*heads, "unit", "velocity", "axis"], rows,
                       right=list(range(4, len(heads)))))
    if cal is not None and eff is not None:
        lines.append(f"lower/upper: the config's limits; cal.: the range swept during "
                     f"calibration ({cal.file}, hash {cal.hash}).\nMoves stay inside both "
                     f"({eff.margin_ticks} servo ticks inside the calibrated range) and inside "
                     "the servos' position limit registers; 'armctl status' shows the effective "
                     "limits.")
    lines.append("")
    lines.append("end effectors: " + ", ".join(spec.end_effectors))
    from armctl.ik.analytic.classify import describe

    ik_family = describe(arm)
    lines.append(f"analytic IK family: {ik_family}")
    if spec.poses:
        lines.append("named poses: " + ", ".join(spec.poses))
    lines.append("")
    lines.append("tree:")
    lines += _tree_lines(spec)
    data: dict[str, Any] = {
        "name": spec.name, "dof": arm.dof, "base": spec.base, "tool": spec.tool,
        "end_effectors": list(spec.end_effectors), "joints": joints,
        "frames": list(arm.frame_names), "poses": spec.poses, "source": spec.source,
        "file": str(spec.file) if spec.file else None, "ik_family": ik_family,
        "calibration": {"file": str(cal.file), "hash": cal.hash} if cal is not None else None,
    }
    if spec.bus is not None:
        bus = spec.bus
        data["bus"] = {"port": bus.port, "protocol": bus.protocol.value, "baudrate": bus.baudrate,
                       "servos": {s.joint: {"id": s.id, "model": s.model} for s in bus.servos}}
        lines.append("")
        lines.append(f"bus: {bus.protocol.value} on {bus.port} at {bus.baudrate} bit/s, "
                     f"{len(bus.servos)} servo{'' if len(bus.servos) == 1 else 's'}")
    emit(args, data, "\n".join(lines))
    return 0


def _tree_lines(spec: Any) -> list[str]:
    children: dict[str, list[Any]] = {}
    for j in spec.joints:
        children.setdefault(j.parent, []).append(j)
    frames: dict[str, list[str]] = {}
    for f in spec.frames:
        frames.setdefault(f.parent, []).append(f.name)

    def below(link: str, prefix: str) -> list[tuple[str, Any, str, bool]]:
        items: list[tuple[str, Any]] = [("frame", f) for f in frames.get(link, [])]
        items += [("joint", j) for j in children.get(link, [])]
        return [(kind, item, prefix, k == len(items) - 1) for k, (kind, item) in enumerate(items)]

    out: list[str] = [spec.base]
    stack = below(spec.base, "")[::-1]  # depth first without recursion: chains can be long
    while stack:
        kind, item, prefix, last = stack.pop()
        branch = "└─ " if last else "├─ "
        if kind == "frame":
            out.append(f"{prefix}{branch}[frame] {item}")
        else:
            out.append(f"{prefix}{branch}{item.name} ({item.type.value}) -> {item.child}")
            stack += below(item.child, prefix + ("   " if last else "│  "))[::-1]
    return out


def cmd_fk(args: argparse.Namespace) -> int:
    """Print the pose of a frame and the least clearance of the arm in its scene."""
    from armctl.cli._scene import (
        clearance_data,
        clearance_text,
        scene_arg,
        scene_clearance,
        self_checked,
    )
    from armctl.spatial import matrix_to_quat, matrix_to_rpy

    arm = load_arm_arg(args)
    scene = scene_arg(args, arm)
    q = parse_angles(args.q, args.deg, arm)
    frame = args.frame or arm.tool
    pose = arm.fk(q, frame) + 0.0  # + 0.0 turns -0.0 into 0.0
    rpy = matrix_to_rpy(pose[:3, :3]) + 0.0
    quat = matrix_to_quat(pose[:3, :3]) + 0.0
    outside = {} if arm.multi_dof_joints else _outside_limits(arm, q, args.deg)
    lines = [
        f"frame {frame!r} of arm {arm.name!r}",
        f"position [m]      x {fmt(pose[0, 3], 6)}  y {fmt(pose[1, 3], 6)}  z {fmt(pose[2, 3], 6)}",
        f"rpy [rad]         {'  '.join(fmt(a, 6) for a in rpy)}",
        f"rpy [deg]         {'  '.join(fmt(math.degrees(a), 3) for a in rpy)}",
        f"quat [w x y z]    {'  '.join(fmt(a, 6) for a in quat)}",
        "matrix:",
    ]
    lines += ["  " + "  ".join(fmt(v, 6).rjust(10) for v in row) for row in pose]
    # without a collision matrix only the scene: sampling one would load the compiler
    clearance = scene_clearance(arm, q, scene, sample=False)
    links = self_checked(arm)
    lines.append(clearance_text(clearance, links))
    if arm.multi_dof_joints:
        return _fk_multi(args, (frame, q, pose, rpy, quat), arm, lines,
                         clearance_data(clearance), links)
    for text in outside.values():
        lines.append(f"note: {text}")
    emit(args, {"frame": frame, "q": q, "position": pose[:3, 3], "rpy": rpy, "quaternion": quat,
                "matrix": pose, "within_limits": not outside,
                "clearance": clearance_data(clearance), "link_pairs_checked": links,
                "outside_limits": [{"joint": n, "value": float(q[arm.joint_index(n)]),
                                    "lower": float(arm.lower[arm.joint_index(n)]),
                                    "upper": float(arm.upper[arm.joint_index(n)])}
                                   for n in outside]}, "\n".join(lines))
    return 0


def _fk_multi(args: argparse.Namespace, answer: tuple[str, np.ndarray, np.ndarray, np.ndarray,
                                                      np.ndarray],
              arm: Arm, lines: list[str], clearance: Any, links: bool) -> int:
    """The rest of ``fk`` for an arm with universal or ball joints.

    Its limits (a ball joint's swing and twist); the clearance is already in ``lines``.
    """
    from armctl.errors import JointLimitError

    frame, q, pose, rpy, quat = answer
    outside: list[dict[str, Any]] = []
    try:
        arm.check_limits(q)
    except JointLimitError as exc:
        outside.append({"joint": exc.joint, "value": exc.value, "lower": exc.lower,
                        "upper": exc.upper})
        lines.append("note: " + str(exc).split("; nothing was sent")[0])
    emit(args, {"frame": frame, "q": q, "position": pose[:3, 3], "rpy": rpy, "quaternion": quat,
                "matrix": pose, "within_limits": not outside, "clearance": clearance,
                "link_pairs_checked": links, "outside_limits": outside}, "\n".join(lines))
    return 0


def _outside_limits(arm: Arm, q: np.ndarray, deg: bool) -> dict[str, str]:
    """Joint name -> a sentence, for every joint of ``q`` outside its limits."""
    from armctl.config.schema import JointType

    out = {}
    for i, name in enumerate(arm.joint_names):
        v, lo, hi = float(q[i]), float(arm.lower[i]), float(arm.upper[i])
        if lo - 1e-9 <= v <= hi + 1e-9:
            continue
        if arm.joint_types[i] is JointType.PRISMATIC:
            unit, k = "m", 1.0
        else:
            unit, k = ("deg", 180.0 / math.pi) if deg else ("rad", 1.0)
        out[name] = (f"joint {name!r} = {fmt(v * k, 4)} {unit} is outside its limits "
                     f"[{fmt(lo * k, 4)}, {fmt(hi * k, 4)}] {unit}")
    return out


def _refuse_bundled_folder(out: Path) -> None:
    """Refuse an output inside the folder of armctl's own arm configs (even with --force).

    Raises:
        ConfigError: Saying where to write instead.
    """
    from armctl.config import bundled_configs
    from armctl.errors import ConfigError, KeyPath

    folders = {p.parent.resolve() for p in bundled_configs().values()}
    if out.resolve().parent in folders:
        raise ConfigError("the output is in the folder of armctl's own bundled arm configs, "
                          "which belong to the installed package", KeyPath(out),
                          f"write it elsewhere, e.g. ./{out.name}, and give that file as CONFIG")


def cmd_convert(args: argparse.Namespace) -> int:
    """Convert a URDF to armctl YAML."""
    from armctl.atomic_write import write_atomic
    from armctl.config.urdf import load_urdf
    from armctl.config.writer import dump_arm_yaml
    from armctl.errors import ConfigError, KeyPath

    out = Path(args.output)
    if out.is_dir():
        raise ConfigError("the output is a folder", KeyPath(out),
                          f"give the YAML file to write, e.g. {out / 'arm.yaml'}")
    if out.suffix.lower() not in (".yaml", ".yml"):
        what = ("a URDF name, but convert writes armctl YAML"
                if out.suffix.lower() in (".urdf", ".xml") else "not a YAML file name")
        raise ConfigError(f"the output {out.name!r} is {what}", KeyPath(out),
                          f"give a .yaml file name, e.g. {out.with_suffix('.yaml')}")
    _refuse_bundled_folder(out)
    if out.exists() and not args.force:
        raise ConfigError("the output file exists already", KeyPath(out),
                          "choose another name or pass --force to overwrite it")
    folder = out.parent if str(out.parent) else Path()
    if not folder.is_dir():
        raise ConfigError(f"the folder {folder} does not exist", KeyPath(out),
                          "create it first or choose another location")
    imported = load_urdf(args.urdf, args.tip)
    header = f"Converted from {Path(args.urdf).name} by armctl convert."
    for note in imported.notes:
        header += f"\nNote: {note}"
    text = dump_arm_yaml(imported.spec, out, header)
    write_atomic(out, text)  # a failed write leaves no partial file
    spec = imported.spec
    emit(args, {"output": str(out), "dof": len(spec.actuated_joints), "tool": spec.tool,
                "notes": list(imported.notes)},
         f"wrote {out} ({len(spec.actuated_joints)} DOF)\n"
         + (f"tool: {spec.tool} (from --tip)" if args.tip else
            f"tool: {spec.tool} (override with --tip LINK)")
         + "".join(f"\nnote: {n}" for n in imported.notes))
    return 0

