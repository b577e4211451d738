"""Parts of armctl's YAML format that arm files and scene files share.

The schema version (``armctl: 1`` at the top of a file), placements (``origin: {xyz, rpy}``) and
shapes (``shape: box`` and its sizes), documented in ``docs/config.md``. Lengths are metres,
angles radians or strings such as ``"90 deg"``.
"""

from __future__ import annotations

from pathlib import Path

from armctl.config.geometry import Box, Capsule, Cylinder, Geometry, Mesh, Origin, Sphere
from armctl.config.source import Section

__all__ = ["SCHEMA_VERSION", "SHAPES", "check_version", "parse_origin", "parse_shape"]

#: The version of the format this armctl reads and writes.
SCHEMA_VERSION = 1
#: The ``shape`` names.
SHAPES = ("box", "cylinder", "sphere", "capsule", "mesh")


def check_version(top: Section) -> None:
    """Refuse a file whose ``armctl:`` schema version is newer than :data:`SCHEMA_VERSION`.

    Args:
        top: The file's top-level mapping (``armctl`` is optional).

    Raises:
        ConfigError: If the version is not a whole number >= 1 or is too new.
    """
    if top.has("armctl"):
        version = top.integer("armctl", lo=1)
        if version > SCHEMA_VERSION:
            raise top.error(f"schema version {version} is newer than this armctl understands "
                            f"({SCHEMA_VERSION})", "armctl", fix="upgrade armctl")


def parse_origin(sec: Section, key: str = "origin") -> Origin:
    """The placement ``{xyz: [m], rpy: [rad]}`` at ``key`` of a mapping (identity if absent).

    Args:
        sec: The mapping.
        key: The key of the placement.

    Returns:
        The placement; ``rpy`` items may be angle strings (``"90 deg"``).
    """
    if not sec.has(key):
        return Origin()
    o = sec.child(key).mapping()
    o.check_keys([], ["xyz", "rpy"])
    return Origin(o.vector("xyz", 3, (0.0, 0.0, 0.0)),  # type: ignore[arg-type]
                  o.vector("rpy", 3, (0.0, 0.0, 0.0), angle=True))  # type: ignore[arg-type]


def parse_shape(sec: Section, file: Path | None, extra: tuple[str, ...] = ()) -> Geometry:
    """A shape mapping (``shape`` and its sizes, optional ``origin``), see ``docs/config.md``.

    Args:
        sec: The mapping.
        file: The file it came from: a relative mesh ``path`` is relative to its folder.
        extra: Further keys the mapping may hold (read by the caller).

    Returns:
        The shape, placed by its ``origin`` [m], [rad].
    """
    shape = sec.choice("shape", str, SHAPES)
    origin = parse_origin(sec)
    if shape == "box":
        sec.check_keys(["shape", "size"], ["origin", *extra])
        size = sec.vector("size", 3)
        if min(size) <= 0:
            raise sec.error(f"box sizes must be positive, found {list(size)}", "size")
        return Box(size, origin)  # type: ignore[arg-type]
    if shape == "sphere":
        sec.check_keys(["shape", "radius"], ["origin", *extra])
        return Sphere(sec.number("radius", positive=True), origin)
    if shape in ("cylinder", "capsule"):
        sec.check_keys(["shape", "radius", "length"], ["origin", *extra])
        cls = Cylinder if shape == "cylinder" else Capsule
        return cls(sec.number("radius", positive=True), sec.number("length", nonnegative=True),
                   origin)
    sec.check_keys(["shape", "path"], ["origin", "scale", *extra])
    raw = Path(sec.string("path"))
    path = raw if raw.is_absolute() or file is None else file.parent / raw
    scale = sec.vector("scale", 3, (1.0, 1.0, 1.0))
    return Mesh(path, scale, origin)  # type: ignore[arg-type]
