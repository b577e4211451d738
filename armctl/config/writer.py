"""Writes an :class:`~armctl.config.schema.ArmSpec` as armctl YAML (used by ``armctl convert``).

:func:`merge_fixed` first folds every fixed joint into its moving parent: the child link becomes a
named frame, its shapes move to the parent link, and joints below it are re-anchored. Loading the
written file gives the same kinematics for every frame name of the original.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import yaml

from armctl.config.arm_yaml import SCHEMA_VERSION, origin_from_matrix
from armctl.config.scene import AllowedPair, CollisionSpec, SceneSpec
from armctl.config.schema import (
    ArmRole,
    ArmSpec,
    Box,
    Capsule,
    Cylinder,
    FrameSpec,
    Geometry,
    JointSpec,
    JointType,
    Limits,
    LinkSpec,
    Mesh,
    Origin,
    Sphere,
)
from armctl.config.source import _EXP_FLOAT

__all__ = ["collision_section", "dump_arm_yaml", "dump_scene_yaml", "merge_fixed",
           "scene_section"]


def merge_fixed(spec: ArmSpec) -> ArmSpec:
    """Fold fixed joints into their moving parents (see the module docstring).

    Args:
        spec: An arm description that may contain fixed joints.

    Returns:
        An equivalent description without fixed joints.
    """
    parent_joint = {j.child: j for j in spec.joints}
    anchor: dict[str, tuple[str, np.ndarray]] = {spec.base: (spec.base, np.eye(4))}
    for j in spec.joints:  # parents first
        if j.type is JointType.FIXED:
            a, t = anchor[j.parent]
            anchor[j.child] = (a, t @ j.origin.matrix())
        else:
            anchor[j.child] = (j.child, np.eye(4))
    joints = []
    for j in spec.joints:
        if j.type is JointType.FIXED:
            continue
        a, t = anchor[j.parent]
        origin = j.origin if a == j.parent else origin_from_matrix(t @ j.origin.matrix())
        joints.append(replace(j, parent=a, origin=origin))
    frames = [FrameSpec(link, a, origin_from_matrix(t))
              for link, (a, t) in anchor.items() if a != link]
    for f in spec.frames:
        a, t = anchor[f.parent]
        frames.append(replace(f, parent=a, origin=origin_from_matrix(t @ f.origin.matrix())))
    shapes: dict[str, tuple[list[Geometry], list[Geometry]]] = {}
    for link in spec.links:
        a, t = anchor[link.name]
        vis, col = shapes.setdefault(a, ([], []))
        vis.extend(_moved(g, t) for g in link.visual)
        col.extend(_moved(g, t) for g in link.collision)
    links = tuple(LinkSpec(lk.name, tuple(shapes[lk.name][0]), tuple(shapes[lk.name][1]))
                  for lk in spec.links if lk.name in shapes)
    del parent_joint
    collision = _merged_collision(spec.collision, {n: a for n, (a, _) in anchor.items()})
    return replace(spec, joints=tuple(joints), frames=tuple(frames), links=links,
                   collision=collision)


def _merged_collision(spec: CollisionSpec | None,
                      anchor: dict[str, str]) -> CollisionSpec | None:
    """The allowed pairs renamed to the links that fixed joints merge into.

    A merged pair stays allowed only if every pair of the links merged into its two links was
    allowed (otherwise shapes that were checked would no longer be); pairs inside one merged
    link disappear.
    """
    if spec is None or all(a == n for n, a in anchor.items()):
        return spec
    allowed = {p.key for p in spec.allowed}
    members: dict[str, list[str]] = {}
    for link, a in anchor.items():
        members.setdefault(a, []).append(link)
    out: dict[frozenset[str], AllowedPair] = {}
    for p in spec.allowed:
        a, b = anchor.get(p.a, p.a), anchor.get(p.b, p.b)
        if a == b or frozenset((a, b)) in out:
            continue
        if all(frozenset((u, v)) in allowed for u in members.get(a, [a])
               for v in members.get(b, [b]) if u != v):
            out[frozenset((a, b))] = replace(p, a=a, b=b)
    return replace(spec, allowed=tuple(out.values()))


def _moved(g: Geometry, t: np.ndarray) -> Geometry:
    if np.allclose(t, np.eye(4), atol=0.0):
        return g
    return replace(g, origin=origin_from_matrix(t @ g.origin.matrix()))


def _num(x: float) -> str:
    if math.isinf(x):
        return ".inf" if x > 0 else "-.inf"
    if x == 0.0:
        return "0"
    return repr(float(x))


def _text(s: str) -> str:
    """``s`` as a YAML scalar that reads back as the same string.

    It is quoted when it would read as a number, a boolean or null, or holds characters that
    YAML gives a meaning (``: # [ ,``).
    """
    out = yaml.safe_dump([s], default_flow_style=True, width=math.inf, allow_unicode=True)
    out = out.strip()[1:-1]
    return json.dumps(s) if _EXP_FLOAT.match(out) else out  # 1e5: a number to armctl


def _quoted(s: str) -> str:
    """``s`` double-quoted on one line, line breaks and control characters escaped."""
    return yaml.safe_dump(s, default_style='"', width=math.inf, allow_unicode=True).strip()


def _vec(v: tuple[float, ...]) -> str:
    return "[" + ", ".join(_num(x) for x in v) + "]"


def _origin(o: Origin) -> str | None:
    parts = []
    if any(o.xyz):
        parts.append(f"xyz: {_vec(o.xyz)}")
    if any(o.rpy):
        parts.append(f"rpy: {_vec(o.rpy)}")
    return "{" + ", ".join(parts) + "}" if parts else None


def _shape(g: Geometry, rel: Path | None) -> str:
    if isinstance(g, Box):
        body = f"shape: box, size: {_vec(g.size)}"
    elif isinstance(g, Sphere):
        body = f"shape: sphere, radius: {_num(g.radius)}"
    elif isinstance(g, (Cylinder, Capsule)):
        kind = "cylinder" if isinstance(g, Cylinder) else "capsule"
        body = f"shape: {kind}, radius: {_num(g.radius)}, length: {_num(g.length)}"
    else:
        assert isinstance(g, Mesh)  # mypy
        path = g.path
        if rel is not None:
            try:
                path = g.path.resolve().relative_to(rel.resolve())
            except ValueError:
                path = g.path
        body = f"shape: mesh, path: {_text(str(path))}"
        if g.scale != (1.0, 1.0, 1.0):
            body += f", scale: {_vec(g.scale)}"
    origin = _origin(g.origin)
    if origin:
        body += f", origin: {origin}"
    return "{" + body + "}"


def _joint(j: JointSpec) -> list[str]:
    lines = [f"  - name: {_text(j.name)}", f"    type: {j.type.value}",
             f"    parent: {_text(j.parent)}", f"    child: {_text(j.child)}"]
    origin = _origin(j.origin)
    if origin:
        lines.append(f"    origin: {origin}")
    if j.type is JointType.UNIVERSAL:
        lines.append(f"    axes: [{_vec(j.axes[0])}, {_vec(j.axes[1])}]")
        lines.append("    limits: [" + ", ".join(
            "{" + ", ".join(_limit_parts(lim, True)) + "}" for lim in j.axis_limits) + "]")
        if j.role.value != "arm":
            lines.append(f"    role: {j.role.value}")
        return lines
    lines.append(f"    axis: {_vec(j.axis)}")
    lim = j.limits
    parts = []
    if j.type is JointType.BALL:
        if j.swing < math.pi:
            parts.append(f"swing: {_num(j.swing)}")
        if math.isfinite(lim.lower):
            parts.append(f"twist: {{lower: {_num(lim.lower)}, upper: {_num(lim.upper)}}}")
        parts += _limit_parts(lim, False)
        if parts:
            lines.append("    limits: {" + ", ".join(parts) + "}")
        if j.role.value != "arm":
            lines.append(f"    role: {j.role.value}")
        return lines
    parts = _limit_parts(lim, j.type in (JointType.REVOLUTE, JointType.PRISMATIC))
    if parts:
        lines.append("    limits: {" + ", ".join(parts) + "}")
    if j.role.value != "arm":
        lines.append(f"    role: {j.role.value}")
    return lines


def _limit_parts(lim: Limits, position: bool) -> list[str]:
    """``lower``/``upper`` (when ``position``) and the rate limits that are known."""
    parts = [f"lower: {_num(lim.lower)}", f"upper: {_num(lim.upper)}"] if position else []
    for key in ("velocity", "acceleration", "jerk", "effort"):
        value = getattr(lim, key)
        if value is not None:
            parts.append(f"{key}: {_num(value)}")
    return parts


def dump_arm_yaml(spec: ArmSpec, out_file: Path | None = None, header: str = "") -> str:
    """The arm description as armctl YAML text.

    Args:
        spec: The description (fixed joints are merged first).
        out_file: Where the text will be written; mesh paths are made relative to its folder.
        header: Comment lines to put at the top (without ``#``).

    Returns:
        YAML text that :func:`~armctl.config.arm_yaml.load_arm_yaml` reads back.
    """
    spec = merge_fixed(spec)
    rel = out_file.parent if out_file is not None else None
    lines = [f"# {h}" if h else "#" for h in header.splitlines()]
    lines += [f"armctl: {SCHEMA_VERSION}", f"name: {_text(spec.name)}"]
    if spec.description:
        lines.append(f"description: {_text(spec.description)}")
    if spec.source:
        lines.append(f"source: {_text(spec.source)}")
    if spec.role is not ArmRole.ARM:
        lines.append(f"role: {spec.role.value}")
    lines.append(f"base: {_text(spec.base)}")
    lines.append(f"tool: {_text(spec.tool)}")
    if len(spec.end_effectors) > 1:
        lines.append(f"end_effectors: [{', '.join(_text(e) for e in spec.end_effectors)}]")
    lines.append("joints:")
    for j in spec.joints:
        lines += _joint(j)
    if spec.frames:
        lines.append("frames:")
        for f in spec.frames:
            origin = _origin(f.origin) or "{}"
            lines.append(f"  - {{name: {_text(f.name)}, parent: {_text(f.parent)}, "
                         f"origin: {origin}}}")
    shaped = [lk for lk in spec.links if lk.visual or lk.collision]
    if shaped:
        lines.append("links:")
        for lk in shaped:
            lines.append(f"  - name: {_text(lk.name)}")
            for key, shapes in (("visual", lk.visual), ("collision", lk.collision)):
                if shapes:
                    lines.append(f"    {key}:")
                    lines += [f"      - {_shape(g, rel)}" for g in shapes]
    if spec.poses:
        lines.append("poses:")
        for name, values in spec.poses.items():
            row: list[float] = []
            for j in spec.actuated_joints:
                value = values[j.name]
                row += list(value) if isinstance(value, tuple) else [value]
            lines.append(f"  {_text(name)}: {_vec(tuple(row))}")
    if spec.skin is not None:
        path = spec.skin.path
        if rel is not None:
            try:
                path = path.resolve().relative_to(rel.resolve())
            except ValueError:
                path = spec.skin.path.resolve()
        lines += ["skin:", f"  mesh: {_text(str(path))}"]
        if spec.skin.bind_pose is not None:
            lines.append(f"  bind_pose: {_text(spec.skin.bind_pose)}")
    if spec.scene is not None:
        lines += scene_section(spec.scene, rel)
    if spec.collision is not None:
        lines += collision_section(spec.collision)
    return "\n".join(lines) + "\n"


def _scene_body(scene: SceneSpec, rel: Path | None, indent: str) -> list[str]:
    if scene.table is None:
        lines = [f"{indent}table: false"]
    else:
        lines = [f"{indent}table: {{height: {_num(scene.table.height)}}}"]
    lines.append(f"{indent}padding: {_num(scene.padding)}")
    if scene.exact:
        lines.append(f"{indent}exact: true")
    placed = _origin(scene.base_in_world)
    if placed:
        lines.append(f"{indent}base_in_world: {placed}")
    if scene.obstacles:
        lines.append(f"{indent}obstacles:")
        for ob in scene.obstacles:
            shape = _shape(ob.shape, rel)[1:-1]
            lines.append(f"{indent}  - {{name: {_text(ob.name)}, {shape}, "
                         f"frame: {ob.frame.value}}}")
    else:
        lines.append(f"{indent}obstacles: []")
    return lines


def scene_section(scene: SceneSpec, rel: Path | None = None) -> list[str]:
    """The ``scene:`` section of an arm YAML file, as lines.

    Args:
        scene: The scene.
        rel: The folder of the file the lines go to: mesh paths are made relative to it.

    Returns:
        The lines (without line ends), starting with ``scene:``.
    """
    return ["scene:", *_scene_body(scene, rel, "  ")]


def collision_section(spec: CollisionSpec) -> list[str]:
    """The ``collision:`` section of an arm YAML file, as lines.

    Args:
        spec: The allowed-collision matrix.

    Returns:
        The lines (without line ends), starting with ``collision:``; one line per pair.
    """
    lines = ["collision:", f"  samples: {spec.samples}"]
    if not spec.allowed:
        return [*lines, "  allowed: []"]
    lines.append("  allowed:")
    for p in spec.allowed:
        row = f"links: [{_text(p.a)}, {_text(p.b)}], reason: {p.reason.value}"
        if p.note:
            note = _text(p.note) if p.note.isprintable() else _quoted(p.note)
            row += f", note: {note}"
        lines.append(f"    - {{{row}}}")
    return lines


def dump_scene_yaml(scene: SceneSpec, out_file: Path | None = None, header: str = "") -> str:
    """A scene as the text of a scene file (read by :func:`armctl.config.scene_yaml.load_scene`).

    Args:
        scene: The scene.
        out_file: Where the text will be written; mesh paths are made relative to its folder.
        header: Comment lines to put at the top (without ``#``).

    Returns:
        The YAML text.
    """
    rel = out_file.parent if out_file is not None else None
    lines = [f"# {h}" if h else "#" for h in header.splitlines()]
    lines += [f"armctl: {SCHEMA_VERSION}", *_scene_body(scene, rel, "")]
    return "\n".join(lines) + "\n"
