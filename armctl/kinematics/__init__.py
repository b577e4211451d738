"""Forward kinematics and geometric Jacobians of a compiled kinematic tree."""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from armctl.kinematics.compiled_tree import CompiledTree, compile_tree
    from armctl.kinematics.model import KinematicModel

__all__ = ["CompiledTree", "KinematicModel", "compile_tree"]

#: Imported on first use, so that a light module of this package (compile_progress) stays light.
_LAZY = {"CompiledTree": "compiled_tree", "compile_tree": "compiled_tree",
         "KinematicModel": "model"}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value
