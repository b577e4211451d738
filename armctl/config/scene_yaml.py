"""Reads the ``scene:`` and ``collision:`` sections of an arm YAML file, and scene files.

A scene file (``--scene FILE``) holds the keys of the ``scene:`` section at its top level, plus
an optional ``armctl: 1`` schema version. Both formats are documented in ``docs/config.md``
("Scene" and "Collision matrix"). As everywhere in the config format, lengths are metres and
angles radians (or strings such as ``"90 deg"``); every error names the file, the line and the
key path, what was found and how to fix it.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from armctl.config.format_yaml import check_version, parse_origin, parse_shape
from armctl.config.geometry import Geometry, Mesh
from armctl.config.scene import (
    TABLE,
    AllowedPair,
    AllowReason,
    CollisionSpec,
    Obstacle,
    SceneFrame,
    SceneSpec,
    TableSpec,
)
from armctl.config.source import Section, load_yaml
from armctl.errors import ConfigError

__all__ = [
    "MAX_PADDING",
    "MAX_SAMPLES",
    "MAX_TABLE_HEIGHT",
    "check_collision",
    "check_scene",
    "load_scene",
    "parse_collision",
    "parse_scene",
]

#: Largest padding [m]: a safety margin is millimetres to centimetres; more is a unit mistake.
MAX_PADDING = 0.2
#: Largest distance of the table top from the base frame's xy plane [m].
MAX_TABLE_HEIGHT = 10.0
#: Largest ``samples`` count of a ``collision:`` section.
MAX_SAMPLES = 1_000_000_000

_SCENE_KEYS = ("table", "padding", "base_in_world", "obstacles", "exact")
_REASONS = [r.value for r in AllowReason]
_FRAMES = [f.value for f in SceneFrame]


def load_scene(path: str | Path, links: Sequence[str] = ()) -> SceneSpec:
    """Read and validate a scene file.

    Args:
        path: The file: the keys of a ``scene:`` section at the top level, and optionally
            ``armctl: 1``. Relative mesh paths are relative to its folder.
        links: The link names of the arm the scene is for; obstacles may not take one of
            these names (empty: not checked).

    Returns:
        The scene, with ``file`` set to ``path``.

    Raises:
        ConfigError: If the file is missing, not YAML, or does not follow the format.
    """
    doc = load_yaml(path)
    top = doc.root()
    top.check_keys([], ["armctl", *_SCENE_KEYS])
    check_version(top)
    return replace(_scene(top, links), file=Path(path))


def parse_scene(sec: Section, links: Sequence[str] = ()) -> SceneSpec:
    """Validate a ``scene:`` section.

    Args:
        sec: The section (a mapping).
        links: The arm's link names; obstacles may not take one of these names.

    Returns:
        The scene (``file`` is ``None``: it belongs to the arm's file).
    """
    sec.mapping().check_keys([], _SCENE_KEYS)
    return _scene(sec, links)


def _scene(sec: Section, links: Sequence[str]) -> SceneSpec:
    padding = sec.number("padding", 0.005, nonnegative=True)
    if padding > MAX_PADDING:
        hint = (f"; did you mean {padding / 1000:g} m ({padding:g} mm)?"
                if padding / 1000 <= MAX_PADDING else "")
        raise sec.error(f"padding {padding:g} m is more than {MAX_PADDING:g} m", "padding",
                        fix=f"padding is in metres, e.g. 0.005 for 5 mm{hint}")
    scene = SceneSpec(table=_table(sec), obstacles=_obstacles(sec), padding=padding,
                      base_in_world=parse_origin(sec, "base_in_world"),
                      exact=sec.boolean("exact", False))
    check_scene(scene, links)
    return scene


def _table(sec: Section) -> TableSpec | None:
    if "table" not in sec.value:
        return TableSpec()
    value = sec.value["table"]
    if value is None:
        raise sec.error("key 'table' has no value", "table",
                        fix="write 'table: false' for no table, or 'table: {height: 0.0}'")
    if value is False or value == "none":
        return None
    if value is True:
        return TableSpec(0.0, sec.where("table"))
    if not isinstance(value, dict):
        raise sec.error(f"expected false, none or a mapping like {{height: 0.0}}, found "
                        f"{_shown(value)}", "table",
                        fix="write 'table: false' for no table, or 'table: {height: 0.0}' "
                        "(metres, in the base frame)")
    t = sec.child("table")
    t.check_keys([], ["height"])
    height = t.number("height", 0.0)
    if abs(height) > MAX_TABLE_HEIGHT:
        raise t.error(f"table height {height:g} m is more than {MAX_TABLE_HEIGHT:g} m from the "
                      "base", "height", fix="the height is in metres in the base frame, e.g. "
                      "0.0 for a table at the base, -0.02 for a base on a 2 cm plate")
    return TableSpec(height, t.where())


def _shown(value: object) -> str:
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, list):
        return f"a list of {len(value)} items"
    return f"{value!r}"


def _obstacles(sec: Section) -> tuple[Obstacle, ...]:
    out: list[Obstacle] = []
    seen: dict[str, Obstacle] = {}
    for item in sec.list_of("obstacles"):
        item.mapping()
        name = item.string("name")
        frame = item.choice("frame", SceneFrame, _FRAMES, SceneFrame.BASE)
        if "shape" not in item.value:
            raise item.error("missing required key 'shape'",
                             fix="add 'shape: box' (or cylinder, sphere, capsule, mesh) and "
                             "its sizes")
        shape = parse_shape(item, item.doc.file, ("name", "frame"))
        if isinstance(shape, Mesh) and not shape.path.is_file():
            raise item.error(f"mesh file {str(shape.path)!r} not found", "path",
                             fix="a relative path is relative to the folder of this file")
        _check_units(item, shape)
        if name == TABLE:
            raise item.error(f"an obstacle may not be called {TABLE!r}: that is the table's "
                             "name", "name", fix="rename it")
        if name in seen:
            first = seen[name].where
            raise item.error(f"duplicate obstacle name {name!r} (also at line {first.line}, "
                             f"{first.dotted()})", "name", fix="give each obstacle its own name")
        obstacle = Obstacle(name, shape, frame, item.where())
        seen[name] = obstacle
        out.append(obstacle)
    return tuple(out)


#: Largest obstacle size or distance from the base accepted [m]: more is a unit mistake.
MAX_OBSTACLE_EXTENT = 20.0


def _check_units(item: Section, shape: Geometry) -> None:
    """Refuse values that can only be degrees or millimetres where radians and metres go."""
    for i, v in enumerate(shape.origin.rpy):
        if abs(v) > 2.0 * math.pi + 1e-9:
            raise item.error(f"origin rpy[{i}] is {v:g} rad, more than a full turn", "origin",
                             fix=f"angles are in radians: write {v:g} deg as \"{v:g} deg\" "
                             f"or {math.radians(v):.4g}")
    sizes = [abs(x) for x in shape.origin.xyz]
    what = "origin xyz"
    for key in ("size", "radius", "length"):
        value = getattr(shape, key, None)
        if value is not None:
            sizes += [abs(float(x)) for x in (value if isinstance(value, tuple) else (value,))]
            what += f", {key}"
    if max(sizes, default=0.0) > MAX_OBSTACLE_EXTENT:
        big = max(sizes)
        raise item.error(f"{what}: {big:g} m is more than {MAX_OBSTACLE_EXTENT:g} m",
                         fix=f"lengths are in metres: {big:g} mm is {big / 1000:g} m")


def check_scene(scene: SceneSpec, links: Sequence[str]) -> None:
    """Refuse obstacles named like a link of the arm (contacts name both).

    Args:
        scene: The scene.
        links: The arm's link names.

    Raises:
        ConfigError: At the first obstacle whose name is a link name.
    """
    names = set(links)
    for obstacle in scene.obstacles:
        if obstacle.name in names:
            where = replace(obstacle.where, keys=(*obstacle.where.keys, "name"))
            raise ConfigError(f"obstacle {obstacle.name!r} has the name of a link of the arm",
                              where, "rename the obstacle: contacts name links and obstacles "
                              "alike")


def parse_collision(sec: Section, links: Sequence[str]) -> CollisionSpec:
    """Validate a ``collision:`` section (the allowed-collision matrix).

    Args:
        sec: The section (a mapping).
        links: The arm's link names; pairs may name these and :data:`TABLE`.

    Returns:
        The matrix.
    """
    sec.mapping().check_keys([], ["samples", "allowed"])
    samples = sec.integer("samples", 0, lo=0, hi=MAX_SAMPLES)
    valid = [*links, TABLE]
    pairs: list[AllowedPair] = []
    for item in sec.list_of("allowed", None):
        names = item.mapping().value.get("links")
        if isinstance(names, list) and names and all(isinstance(n, str) for n in names):
            item = replace(item, label=" / ".join(names))
        item.check_keys(["links", "reason"], ["note"])
        a, b = _pair(item, valid)
        reason = item.choice("reason", AllowReason, _REASONS)
        note = item.string("note", required=False) if item.has("note") else ""
        pairs.append(AllowedPair(a, b, reason, note, item.where()))
    spec = CollisionSpec(tuple(pairs), samples, sec.where())
    check_collision(spec, links)
    return spec


def _pair(item: Section, valid: list[str]) -> tuple[str, str]:
    value = item.value.get("links")
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, str) and v for v in value)):
        raise item.error(f"expected a list of two link names, found {_shown(value)}", "links",
                         fix="write 'links: [link_a, link_b]' (a link may be 'table')")
    for i, name in enumerate(value):
        if name not in valid:
            raise item.error(f"unknown link {name!r}", "links", i, fix=_links_fix(name, valid))
    return value[0], value[1]


def _links_fix(name: str, valid: list[str]) -> str:
    close = difflib.get_close_matches(name, valid, n=1)
    head = f"did you mean {close[0]!r}? " if close else ""
    return f"{head}the arm's links: {', '.join(valid[:-1])}; and {TABLE!r}"


def check_collision(spec: CollisionSpec, links: Sequence[str]) -> None:
    """Check a matrix against an arm: known links, two different links, no pair twice.

    Args:
        spec: The matrix.
        links: The arm's link names (:data:`TABLE` is valid too).

    Raises:
        ConfigError: At the first bad pair (its ``where``).
    """
    if TABLE in links:
        raise ConfigError(f"the arm has a link called {TABLE!r}, the name the matrix gives the "
                          "table", spec.where, f"rename the link (for example '{TABLE}_link')")
    valid = [*links, TABLE]
    seen: dict[frozenset[str], AllowedPair] = {}
    for pair in spec.allowed:
        for i, name in enumerate((pair.a, pair.b)):
            if name not in valid:
                where = replace(pair.where, keys=(*pair.where.keys, "links", i))
                raise ConfigError(f"unknown link {name!r}", where, _links_fix(name, valid))
        if pair.a == pair.b:
            where = replace(pair.where, keys=(*pair.where.keys, "links"))
            raise ConfigError(f"the pair names {pair.a!r} twice; a link is never checked "
                              "against itself", where, "name two different links")
        if pair.key in seen:
            first = seen[pair.key].where
            at = f" (also at line {first.line}, {first.dotted()})" if first.keys else ""
            raise ConfigError(f"the pair {pair.a} / {pair.b} is listed twice{at}", pair.where,
                              "remove one of them")
        seen[pair.key] = pair
