"""What a collision check finds: the closest pair, or the pair in contact and where."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from armctl.typing import Array

__all__ = ["Clearance", "Contact", "ContactKind"]


class ContactKind(Enum):
    """Which kind of pair."""

    SELF = "self"  # two links of the arm
    SCENE = "scene"  # a link and the table or an obstacle


@dataclass(frozen=True)
class Clearance:
    """The checked pair with the least room at one configuration.

    Attributes:
        distance: Distance between the pair's shapes [m]; negative: they overlap by that much.
        padding: Distance the pair must keep [m] (the scene's padding for a link and an
            obstacle, 0 between links).
        a: The link.
        b: The other link, the obstacle's name, or ``"table"``.
        kind: Link-link or link-obstacle.
    """

    distance: float
    padding: float
    a: str
    b: str
    kind: ContactKind

    @property
    def margin(self) -> float:
        """Room left before the pair counts as in contact [m] (``distance - padding``)."""
        return self.distance - self.padding

    @property
    def pair(self) -> str:
        """The pair as text, e.g. ``'gripper_link' and 'table'``."""
        return f"{self.a!r} and {self.b!r}"


@dataclass(frozen=True)
class Contact:
    """A pair closer than it may be (in contact, or inside the padding).

    Attributes:
        kind: Link-link or link-obstacle.
        a: The link.
        b: The other link, the obstacle's name, or ``"table"``.
        distance: Distance between the shapes [m]; negative: they overlap by that much.
        padding: Distance the pair must keep [m].
        q: The joint configuration [rad]/[m].
        time: When along the motion [s] (``None`` for a single configuration).
        pair_index: Index of the pair in the collision model (-1: unknown).
        deepest: Along a motion: the pair's least distance anywhere on it [m] (``None``: not
            computed).
        deepest_time: When that is [s].
    """

    kind: ContactKind
    a: str
    b: str
    distance: float
    padding: float
    q: Array = field(compare=False)
    time: float | None = None
    pair_index: int = field(default=-1, compare=False)
    deepest: float | None = None
    deepest_time: float | None = None

    @property
    def depth(self) -> float:
        """How far the pair is inside the distance it must keep [m] (>= 0)."""
        return max(self.padding - self.distance, 0.0)

    @property
    def pair(self) -> str:
        """The pair as text."""
        return f"{self.a!r} and {self.b!r}"

    def describe(self, joint_names: tuple[str, ...] = ()) -> str:
        """One sentence: the pair, how deep, when and at which joints."""
        if self.distance < 0.0:
            how = f"overlap by {-self.distance * 1000:.1f} mm"
        elif self.padding > 0.0 and self.distance > self.padding - 1e-4:
            how = f"reach the {self.padding * 1000:.1f} mm padding between them"
        elif self.padding > 0.0:
            how = (f"come within {max(self.distance, 0.0) * 1000:.1f} mm, inside the "
                   f"{self.padding * 1000:.1f} mm padding")
        else:
            how = "touch"
        text = f"{self.pair} {how}"
        if self.time is not None:
            text += f" at t={self.time:.3f} s"
        q = np.asarray(self.q, dtype=float)
        if joint_names and q.shape == (len(joint_names),):
            text += " with " + ", ".join(f"{n}={v:.4g}"
                                         for n, v in zip(joint_names, q, strict=True))
            text += " (rad; m for prismatic joints)"
        if self.deepest is not None and self.deepest < self.distance - 1e-4:
            where = "" if self.deepest_time is None else f" at t={self.deepest_time:.3f} s"
            if self.deepest < 0.0:
                text += f"; they overlap by up to {-self.deepest * 1000:.1f} mm{where}"
            else:
                text += f"; they come within {self.deepest * 1000:.1f} mm{where}"
        return text
