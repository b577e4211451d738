"""Placements and shapes: where a thing sits in a frame, and the primitive and mesh shapes.

Links carry these shapes (``links:`` of an arm YAML file, ``<visual>``/``<collision>`` of a
URDF), and so do the obstacles of a scene (:mod:`armctl.config.scene`). Sizes are in [m],
angles in [rad]. :mod:`armctl.config.schema` re-exports every name.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from armctl.spatial import make_transform, rpy_to_matrix

__all__ = ["Box", "Capsule", "Cylinder", "Geometry", "Mesh", "Origin", "Sphere"]


@dataclass(frozen=True)
class Origin:
    """A fixed placement: translation then URDF roll-pitch-yaw rotation.

    Attributes:
        xyz: Translation in [m].
        rpy: Roll, pitch, yaw in [rad].
    """

    xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def matrix(self) -> npt.NDArray[np.float64]:
        """The ``(4, 4)`` homogeneous transform."""
        return make_transform(rpy_to_matrix(self.rpy), self.xyz)


@dataclass(frozen=True)
class Box:
    """A box centred on its origin. ``size``: edge lengths along x, y, z in [m]."""

    size: tuple[float, float, float]
    origin: Origin = Origin()


@dataclass(frozen=True)
class Cylinder:
    """A cylinder along its local z axis, centred on its origin; sizes in [m]."""

    radius: float
    length: float
    origin: Origin = Origin()


@dataclass(frozen=True)
class Sphere:
    """A sphere centred on its origin; radius in [m]."""

    radius: float
    origin: Origin = Origin()


@dataclass(frozen=True)
class Capsule:
    """A cylinder with hemispherical ends along local z, centred on its origin; sizes in [m].

    ``length`` is the distance between the two hemisphere centres.
    """

    radius: float
    length: float
    origin: Origin = Origin()


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh file (STL, OBJ, DAE) scaled per axis and placed by its origin."""

    path: Path
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)
    origin: Origin = Origin()


Geometry = Box | Cylinder | Sphere | Capsule | Mesh
