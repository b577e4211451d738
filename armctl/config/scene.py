"""The world around an arm, and which of its link pairs are never checked for contact.

A :class:`SceneSpec` holds the table (a horizontal plane under the arm), the obstacles (boxes,
spheres, cylinders, capsules and meshes, each placed in the arm's base frame or in the world
frame) and the padding kept between the arm and all of them. It comes from the ``scene:``
section of an arm YAML file or from a separate scene file (``--scene FILE``); both are
documented in ``docs/config.md``.

A :class:`CollisionSpec` (the ``collision:`` section) lists the allowed-collision matrix: the
pairs of links (or a link and the table) that are not checked, each with its reason.
``armctl collisions CONFIG --generate`` finds them by sampling.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path

from armctl.config.geometry import Geometry, Origin
from armctl.errors import KeyPath

__all__ = [
    "TABLE",
    "AllowReason",
    "AllowedPair",
    "CollisionSpec",
    "Obstacle",
    "SceneFrame",
    "SceneSpec",
    "TableSpec",
]

#: The name of the table in contacts and in the allowed-collision matrix.
TABLE = "table"


class SceneFrame(Enum):
    """The frame an obstacle's ``origin`` is given in."""

    BASE = "base"  # the arm's base frame
    WORLD = "world"  # the world frame; the scene's ``base_in_world`` places the arm in it


@dataclass(frozen=True)
class Obstacle:
    """A fixed obstacle.

    Attributes:
        name: Its name (unique in the scene; used in contact reports).
        shape: Its shape; ``shape.origin`` places it in ``frame`` [m], [rad].
        frame: The frame the origin is given in.
        where: Where it was defined (file, line, key path).
    """

    name: str
    shape: Geometry
    frame: SceneFrame = SceneFrame.BASE
    where: KeyPath = field(default=KeyPath(), compare=False)


@dataclass(frozen=True)
class TableSpec:
    """The table: the half-space below a horizontal plane of the base frame.

    Attributes:
        height: Height of the table top in the base frame [m] (0: the base frame's xy plane).
        where: Where it was defined.
    """

    height: float = 0.0
    where: KeyPath = field(default=KeyPath(), compare=False)


@dataclass(frozen=True)
class SceneSpec:
    """What surrounds the arm.

    Attributes:
        table: The table, or ``None`` for none (an arm on a wall or a pedestal in free space).
        obstacles: The obstacles.
        padding: Distance kept between the arm and the table and every obstacle [m].
        base_in_world: The arm's base frame in the world frame (for obstacles given in the
            world frame).
        file: The file the scene was read from (``None``: the arm's file, or the default).
        exact: Measure the real shapes (boxes, cylinders, meshes) where their capsules say
            contact, with the collision library (the ``collision`` extra); ``False``: the
            capsules decide (conservative: they contain the shapes).
    """

    table: TableSpec | None = TableSpec()
    obstacles: tuple[Obstacle, ...] = ()
    padding: float = 0.005
    base_in_world: Origin = field(default_factory=Origin)
    file: Path | None = None
    exact: bool = False


class AllowReason(Enum):
    """Why a pair of links is not checked for contact."""

    ADJACENT = "adjacent"  # joined by a joint (or a link and the table it stands on)
    ALWAYS = "always"  # in contact in (nearly) every configuration: the shapes overlap by design
    NEVER = "never"  # never in contact in any sampled configuration
    DEFAULT = "default"  # in contact at a named pose of the arm (home, park): it rests so
    USER = "user"  # declared by hand (the ``note`` says why)


@dataclass(frozen=True)
class AllowedPair:
    """A pair of links (or a link and :data:`TABLE`) that is not checked.

    Attributes:
        a: A link name.
        b: Another link name, or :data:`TABLE`.
        reason: Why.
        note: Free text (what the sampling found, or the user's reason).
        where: Where it was defined.
    """

    a: str
    b: str
    reason: AllowReason
    note: str = ""
    where: KeyPath = field(default=KeyPath(), compare=False)

    @property
    def key(self) -> frozenset[str]:
        """The pair as an unordered key."""
        return frozenset((self.a, self.b))


@dataclass(frozen=True)
class CollisionSpec:
    """The ``collision:`` section: the allowed-collision matrix.

    Attributes:
        allowed: The pairs that are not checked.
        samples: How many random configurations the matrix was generated from (0: by hand).
        where: Where the section was defined.
    """

    allowed: tuple[AllowedPair, ...] = ()
    samples: int = 0
    where: KeyPath = field(default=KeyPath(), compare=False)
