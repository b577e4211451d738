"""Errors of the drawing code, all subclasses of the armctl exception tree."""

from __future__ import annotations

from pathlib import Path

from armctl.errors import InputError
from armctl.kinematics.linkshapes import MeshLoadError

__all__ = ["MeshLoadError", "MissingToolError", "OutputError"]


class OutputError(InputError):
    """An output file cannot be written (missing folder, no permission, unknown file type).

    Args:
        path: The file that was asked for.
        problem: What is wrong.
        fix: How to fix it.

    ``details``: ``path``, ``problem`` and ``fix``.
    """

    def __init__(self, path: Path, problem: str, fix: str):
        self.path = path
        super().__init__(f"cannot write {path}: {problem}\n  fix: {fix}",
                         {"path": path, "problem": problem, "fix": fix})


class MissingToolError(InputError):
    """An optional program or package that a requested output needs is not installed."""
