"""Reads a URDF file into an :class:`~armctl.config.schema.ArmSpec`.

Kept: links with their visual and collision shapes, revolute, continuous, prismatic and fixed
joints with origins, axes and limits. Mimic joints (finger couplings) become fixed joints at their
offset and are reported in :attr:`UrdfImport.notes`. Floating and planar joints are rejected.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from xml.parsers import expat

from armctl.config.schema import (
    ArmSpec,
    Box,
    Cylinder,
    Geometry,
    JointRole,
    JointSpec,
    JointType,
    Limits,
    LinkSpec,
    Mesh,
    Origin,
    Sphere,
    unit_axis,
)
from armctl.config.source import read_text
from armctl.config.tree import check_arm_size, order_tree
from armctl.errors import ConfigError, KeyPath, UnknownNameError

__all__ = ["UrdfImport", "load_urdf", "parse_urdf"]


@dataclass(frozen=True)
class UrdfImport:
    """The result of reading a URDF.

    Attributes:
        spec: The arm description.
        notes: What was changed on the way in (mimic joints fixed, branches dropped for a tip).
    """

    spec: ArmSpec
    notes: tuple[str, ...]


def load_urdf(path: str | Path, tip: str | None = None) -> UrdfImport:
    """Read a URDF file.

    Args:
        path: The ``.urdf`` file.
        tip: A link name; when given, only the chain from the root to this link is kept and it
            becomes the tool frame.

    Returns:
        The arm description and import notes.

    Raises:
        ConfigError: If the file is missing, is not XML, or is not a valid tree.
    """
    p = Path(path)
    return parse_urdf(read_text(p), p, tip)


#: The attribute under which :func:`_parse_xml` keeps each element's line (a name XML
#: cannot contain, so it never meets a real attribute).
_LINE = " line"


def _parse_xml(text: str) -> ET.Element:
    """Parse XML into an element tree, keeping each element's 1-based line.

    Raises:
        expat.ExpatError: If the text is not well-formed XML (expat bounds entity expansion).
    """
    builder = ET.TreeBuilder()
    parser = expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        attrs[_LINE] = str(parser.CurrentLineNumber)
        builder.start(tag, attrs)

    parser.StartElementHandler = start
    parser.EndElementHandler = builder.end
    parser.CharacterDataHandler = builder.data
    parser.Parse(text, True)
    return builder.close()


def _line(el: ET.Element) -> int | None:
    """The line of an element read by :func:`_parse_xml`."""
    line = el.get(_LINE)
    return int(line) if line else None


def _at(where: KeyPath, el: ET.Element, attr: str | None = None) -> KeyPath:
    """The location of child element ``el`` of ``where`` (and of its attribute ``attr``)."""
    keys = (*where.keys, el.tag) if attr is None else (*where.keys, el.tag, attr)
    return KeyPath(where.file, keys, _line(el) or where.line, where.label)


def _floats(text: str | None, n: int, default: tuple[float, ...], where: KeyPath,
            attr: str) -> tuple[float, ...]:
    if text is None:
        return default
    try:
        vals = tuple(float(x) for x in text.split())
    except ValueError:
        vals = ()
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise ConfigError(f"attribute {attr}={text!r} must be {n} finite numbers", where)
    return vals


def _origin(el: ET.Element | None, where: KeyPath) -> Origin:
    if el is None:
        return Origin()
    xyz = _floats(el.get("xyz"), 3, (0.0, 0.0, 0.0), _at(where, el, "xyz"), "xyz")
    rpy = _floats(el.get("rpy"), 3, (0.0, 0.0, 0.0), _at(where, el, "rpy"), "rpy")
    return Origin(xyz, rpy)  # type: ignore[arg-type]


def _number(el: ET.Element, attr: str, where: KeyPath, default: float | None = None) -> float:
    raw = el.get(attr)
    if raw is None:
        if default is None:
            raise ConfigError(f"<{el.tag}> is missing attribute {attr!r}", _at(where, el))
        return default
    try:
        value = float(raw)
    except ValueError:
        raise ConfigError(f"attribute {attr}={raw!r} of <{el.tag}> is not a number",
                          _at(where, el, attr)) from None
    if not math.isfinite(value):
        fix = ("a joint that turns without end is type 'continuous'; leave out velocity or "
               "effort when unknown" if el.tag == "limit" else "write a finite number")
        raise ConfigError(f"attribute {attr}={raw!r} of <{el.tag}> must be a finite number",
                          _at(where, el, attr), fix)
    return value


def _geometry(parent: ET.Element, file: Path | None, where: KeyPath) -> Geometry | None:
    geo = parent.find("geometry")
    if geo is None or len(geo) == 0:
        return None
    origin = _origin(parent.find("origin"), where)
    shape = geo[0]
    if shape.tag == "box":
        size = _floats(shape.get("size"), 3, (0.0, 0.0, 0.0), where, "size")
        return Box(size, origin)  # type: ignore[arg-type]
    if shape.tag == "cylinder":
        return Cylinder(_number(shape, "radius", where), _number(shape, "length", where), origin)
    if shape.tag == "sphere":
        return Sphere(_number(shape, "radius", where), origin)
    if shape.tag == "mesh":
        name = shape.get("filename", "")
        scale = _floats(shape.get("scale"), 3, (1.0, 1.0, 1.0), where, "scale")
        return Mesh(_resolve_mesh(name, file), scale, origin)  # type: ignore[arg-type]
    return None


def _resolve_mesh(name: str, file: Path | None) -> Path:
    """Resolve ``package://pkg/x.stl`` and relative paths against the URDF's folder."""
    base = file.parent if file is not None else Path()
    if name.startswith("package://"):
        rest = Path(name[len("package://"):])
        parts = rest.parts[1:]  # drop the package name
        for folder in (base, *base.parents):
            candidate = folder.joinpath(*parts)
            if candidate.exists():
                return candidate
        return base.joinpath(*parts)
    if name.startswith("file://"):
        return Path(name[len("file://"):])
    p = Path(name)
    return p if p.is_absolute() else base / p


def parse_urdf(text: str, file: Path | None = None, tip: str | None = None) -> UrdfImport:
    """Parse URDF text (see :func:`load_urdf`)."""
    doc = KeyPath(file)
    try:
        root = _parse_xml(text)
    except expat.ExpatError as exc:
        raise ConfigError(f"not a valid URDF: not well-formed XML ({exc})",
                          KeyPath(file, (), exc.lineno),
                          "check that the file is a URDF (XML), not xacro or YAML") from None
    if root.tag != "robot":
        raise ConfigError(f"not a URDF: the root element is <{root.tag}>, expected <robot>", doc)
    notes: list[str] = []
    links: list[LinkSpec] = []
    for i, el in enumerate(root.findall("link")):
        where = KeyPath(file, ("link", i), _line(el), el.get("name"))
        name = el.get("name")
        if not name:
            raise ConfigError("<link> without a name", where)
        vis = tuple(g for v in el.findall("visual") if (g := _geometry(v, file, where)))
        col = tuple(g for c in el.findall("collision") if (g := _geometry(c, file, where)))
        links.append(LinkSpec(name, vis, col))
    joints = [_joint(el, i, file, notes) for i, el in enumerate(root.findall("joint"))]
    names = [lk.name for lk in links]
    known = set(names)
    for j in joints:
        for link in (j.parent, j.child):
            if link not in known:
                raise ConfigError(f"joint {j.name!r} names link {link!r}, which is not defined",
                                  j.where, "add a <link name=...> element or fix the name")
    children = {j.child for j in joints}
    roots = [n for n in names if n not in children]
    if not roots:
        raise ConfigError("no root link: every link is the child of a joint (a cycle?)", doc)
    if len(roots) > 1:
        raise ConfigError(f"the URDF has {len(roots)} roots: {', '.join(map(repr, roots))}", doc,
                          "connect every link to one tree with joints")
    base = roots[0]
    ordered, _ = order_tree(base, joints, names, (), doc)
    tool = _choose_tip(ordered, base, names, tip)
    if tip is not None:
        keep = _path_links(ordered, base, tip)
        dropped = [j.name for j in ordered if j.child not in keep]
        if dropped:
            notes.append(f"kept the chain to {tip!r}; dropped joints: {', '.join(dropped)}")
        ordered = [j for j in ordered if j.child in keep]
        links = [lk for lk in links if lk.name in keep]
    check_arm_size(len(ordered), 0, doc)
    ordered, link_order = order_tree(base, ordered, [lk.name for lk in links], (), doc)
    by_name = {lk.name: lk for lk in links}
    leaves = _leaves(ordered, base)
    end_effectors = (tool, *(lf for lf in leaves if lf != tool))
    spec = ArmSpec(
        name=root.get("name") or (file.stem if file else "robot"), base=base,
        links=tuple(by_name[n] for n in link_order), joints=tuple(ordered), frames=(),
        tool=tool, end_effectors=end_effectors if tip is None else (tool,),
        source=f"URDF {file.name}" if file else "URDF", file=file,
    )
    return UrdfImport(spec, tuple(notes))


def _joint(el: ET.Element, i: int, file: Path | None, notes: list[str]) -> JointSpec:
    name = el.get("name") or ""
    where = KeyPath(file, ("joint", i), _line(el), name or None)
    if not name:
        raise ConfigError("<joint> without a name", where)
    kind = el.get("type", "")
    valid = ["revolute", "continuous", "prismatic", "fixed"]
    if kind in ("floating", "planar"):
        raise ConfigError(f"joint {name!r} is {kind}; armctl models fixed-base arms", where,
                          "remove the joint, or make it fixed")
    if kind in ("ball", "spherical", "universal"):
        raise ConfigError(f"joint {name!r} is {kind}, which URDF does not define (URDF joints "
                          "are revolute, continuous, prismatic, fixed, floating, planar)", where,
                          f"write the arm in armctl YAML, where 'type: {kind}' is a joint of "
                          "its own (docs/config.md)")
    if kind not in valid:
        raise UnknownNameError("joint type", kind, valid, f"joint {name!r}")
    parent_el, child_el = el.find("parent"), el.find("child")
    if parent_el is None or child_el is None:
        raise ConfigError(f"joint {name!r} needs <parent link=...> and <child link=...>", where)
    parent, child = parent_el.get("link", ""), child_el.get("link", "")
    origin = _origin(el.find("origin"), where)
    axis_el = el.find("axis")
    axis_where = where if axis_el is None else _at(where, axis_el, "xyz")
    axis = _floats(axis_el.get("xyz") if axis_el is not None else None, 3, (1.0, 0.0, 0.0),
                   axis_where, "axis xyz")
    found = unit_axis(axis)
    if kind != "fixed" and found is None:
        shown = " ".join(f"{a:g}" for a in axis)
        raise ConfigError(f"joint {name!r} has a zero-length axis ({shown})", axis_where,
                          "give <axis xyz='0 0 1'/> or another direction")
    unit = found or (0.0, 0.0, 1.0)
    jtype = JointType(kind)
    mimic = el.find("mimic")
    if mimic is not None and jtype.actuated:
        offset = _number(mimic, "offset", where, 0.0)
        notes.append(f"mimic joint {name!r} (follows {mimic.get('joint')!r}) was fixed at "
                     f"offset {offset:g}")
        if offset != 0.0:
            from armctl.config.arm_yaml import origin_from_matrix
            from armctl.spatial import axis_angle_to_matrix, make_transform

            moved = origin.matrix() @ (make_transform(axis_angle_to_matrix(unit, offset))
                                       if jtype is not JointType.PRISMATIC else
                                       make_transform(pos=[a * offset for a in unit]))
            origin = origin_from_matrix(moved)
        return JointSpec(name, JointType.FIXED, parent, child, origin, where=where)
    limits = Limits()
    lim = el.find("limit")
    if jtype in (JointType.REVOLUTE, JointType.PRISMATIC):
        if lim is None:
            raise ConfigError(f"{kind} joint {name!r} has no <limit>", where,
                              "add <limit lower=... upper=... velocity=... effort=.../>")
        lower, upper = _number(lim, "lower", where, 0.0), _number(lim, "upper", where, 0.0)
        if lower > upper:
            raise ConfigError(f"joint {name!r}: lower limit {lower:g} is greater than upper "
                              f"limit {upper:g}", where, "swap the two values")
        limits = Limits(lower, upper, _positive(lim, "velocity", where),
                        effort=_positive(lim, "effort", where))
    elif jtype is JointType.CONTINUOUS and lim is not None:
        limits = Limits(velocity=_positive(lim, "velocity", where),
                        effort=_positive(lim, "effort", where))
    role = JointRole.GRIPPER if "gripper" in name.lower() or "finger" in name.lower() else (
        JointRole.ARM)
    return JointSpec(name, jtype, parent, child, origin, unit, limits, role, where)


def _positive(el: ET.Element, attr: str, where: KeyPath) -> float | None:
    if el.get(attr) is None:
        return None
    v = _number(el, attr, where)
    return v if v > 0 else None


def _leaves(joints: list[JointSpec], base: str) -> list[str]:
    parents = {j.parent for j in joints}
    leaves = [j.child for j in joints if j.child not in parents]
    return leaves or [base]


def _depths(joints: list[JointSpec]) -> dict[str, int]:
    """The number of actuated joints between the root and each link (joints parents first)."""
    depth: dict[str, int] = {}
    for j in joints:
        depth[j.child] = depth.get(j.parent, 0) + j.type.actuated
    return depth


def _choose_tip(joints: list[JointSpec], base: str, names: list[str], tip: str | None) -> str:
    if tip is not None:
        if tip not in names:
            raise UnknownNameError("link", tip, names, "the URDF (tip)")
        return tip
    reached = {j.child for j in joints}
    depth = _depths(joints)
    for match in _TOOL_NAMES:
        found = [n for n in names if n in reached and match(n.lower())]
        if found:  # the deepest, the first in the file among equals
            return max(enumerate(found), key=lambda e: (depth.get(e[1], 0), -e[0]))[1]
    leaves = _leaves(joints, base)
    return max(enumerate(leaves), key=lambda e: (depth.get(e[1], 0), -e[0]))[1]


#: How a link is recognised as the tool frame, best first (names compared in lower case);
#: without any, the deepest leaf is the tool.
_TOOL_NAMES: tuple[Callable[[str], bool], ...] = (
    *(lambda n, exact=exact: n == exact
      for exact in ("tcp", "tool0", "tool", "ee", "end_effector")),
    lambda n: n.endswith("_tcp"),
    lambda n: "tcp" in n,
    lambda n: "gripper_frame" in n,
    lambda n: "ee_link" in n,
)


def _path_links(joints: list[JointSpec], base: str, tip: str) -> set[str]:
    parent = {j.child: j.parent for j in joints}
    keep = {tip}
    link = tip
    while link != base:
        link = parent[link]
        keep.add(link)
    return keep
