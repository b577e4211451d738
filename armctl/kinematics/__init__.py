"""Forward kinematics and geometric Jacobians of a compiled kinematic tree."""

from armctl.kinematics.model import KinematicModel

__all__ = ["KinematicModel"]
