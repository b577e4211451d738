"""Arm descriptions: the YAML format, URDF import, validation and writing."""

from __future__ import annotations

from pathlib import Path

from armctl.config.arm_yaml import load_arm_yaml
from armctl.config.schema import ArmSpec
from armctl.config.urdf import load_urdf
from armctl.errors import ConfigError, KeyPath

__all__ = ["ArmSpec", "bundled_configs", "bundled_configs_dir", "load_spec", "resolve_config"]

_URDF_SUFFIXES = (".urdf", ".xml")
_YAML_SUFFIXES = (".yaml", ".yml")


def bundled_configs_dir() -> Path:
    """The folder of the arm configs shipped with armctl (part of the installed package)."""
    return (Path(__file__).resolve().parent.parent / "configs").resolve()


def bundled_configs() -> dict[str, Path]:
    """The arm configs shipped with armctl, by name (``so101``, ``ur5e``, ...)."""
    root = bundled_configs_dir()
    return {p.stem: p for p in sorted(root.glob("*.yaml")) if not p.name.startswith("_")}


def resolve_config(name_or_path: str | Path) -> Path:
    """A config file path from a path or the name of a bundled arm.

    Args:
        name_or_path: A file path, or a bundled name such as ``"so101"``.

    Returns:
        The path of the file.

    Raises:
        ConfigError: If it is neither an existing file nor a bundled name.
    """
    p = Path(name_or_path)
    if p.exists():
        return p
    bundled = bundled_configs()
    if str(name_or_path) in bundled:
        return bundled[str(name_or_path)]
    import difflib

    close = difflib.get_close_matches(str(name_or_path), list(bundled), n=1)
    fix = (f"did you mean the bundled arm {close[0]!r}?" if close else
           f"give a file path, or a bundled arm: {', '.join(bundled)}")
    raise ConfigError("file not found, and not the name of a bundled arm", KeyPath(p), fix)


def load_spec(path: str | Path, tip: str | None = None) -> ArmSpec:
    """Read an arm description from armctl YAML or URDF (chosen by the file suffix).

    Args:
        path: A file path or a bundled arm name.
        tip: URDF only: keep the chain to this link and make it the tool frame.

    Returns:
        The validated description.

    Raises:
        ConfigError: If the file cannot be read or is invalid.
    """
    p = resolve_config(path)
    suffix = p.suffix.lower()
    if suffix in _URDF_SUFFIXES:
        return load_urdf(p, tip).spec
    if tip is not None:
        raise ConfigError("'tip' applies to URDF files; in armctl YAML set 'tool:'", KeyPath(p))
    if suffix in _YAML_SUFFIXES:
        return load_arm_yaml(p)
    raise ConfigError(f"unknown file type {suffix!r}", KeyPath(p),
                      "use .yaml/.yml for armctl configs or .urdf for URDF")
