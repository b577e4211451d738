"""Forward kinematics and geometric Jacobians of a compiled kinematic tree."""

from armctl.kinematics.compiled_tree import CompiledTree, compile_tree
from armctl.kinematics.model import KinematicModel

__all__ = ["CompiledTree", "KinematicModel", "compile_tree"]
