"""Errors of the drawing code, all subclasses of the armctl exception tree."""

from __future__ import annotations

from pathlib import Path

from armctl.errors import ConfigError, InputError, KeyPath

__all__ = ["MeshLoadError", "MissingToolError", "OutputError"]


class OutputError(InputError):
    """An output file cannot be written (missing folder, no permission, unknown file type).

    Args:
        path: The file that was asked for.
        problem: What is wrong.
        fix: How to fix it.
    """

    def __init__(self, path: Path, problem: str, fix: str):
        self.path = path
        super().__init__(f"cannot write {path}: {problem}\n  fix: {fix}")


class MeshLoadError(ConfigError):
    """A mesh file named by a link's geometry is missing or cannot be read.

    Args:
        path: The mesh file.
        link: The link whose geometry names it.
        problem: What went wrong.
        config: The arm config that names the mesh, when known.
    """

    def __init__(self, path: Path, link: str, problem: str, config: Path | None = None):
        self.path = path
        self.link = link
        super().__init__(
            f"mesh {path} of link {link!r}: {problem}",
            KeyPath(config, ("links",), label=link),
            "check the mesh path (relative paths and package:// URLs resolve against the config's "
            "folder); STL, OBJ and DAE (DAE needs pycollada) are supported",
        )


class MissingToolError(InputError):
    """An optional program or package that a requested output needs is not installed."""
