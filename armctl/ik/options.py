"""Options shared by the IK solvers."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from armctl.errors import InputError
from armctl.ik.nullspace import NullSpace

if TYPE_CHECKING:
    from armctl.collision.model import CollisionModel

__all__ = ["IKOptions"]


@dataclass(frozen=True)
class IKOptions:
    """Budgets and randomness of an IK solve.

    Attributes:
        max_iterations: Iterations per attempt.
        time_limit: Wall-time budget for the whole solve, restarts included [s].
        restarts: Largest number of random restarts after the first attempt.
        seed: Seed of the random generator used for restarts (``None``: fresh entropy); the
            same seed gives the same answer.
        nullspace: Secondary criteria for ``pinv`` and ``dls`` (comfortable posture, joint-limit
            avoidance, keep-out spheres, manipulability); ``None`` for none.
        avoid: A collision checker (:class:`armctl.collision.CollisionModel`): an answer
            succeeds only when it is free of contact; a solver that converges to one in contact
            discards it and restarts, and reports ``IKStatus.COLLIDES`` with the contact when
            every answer it found collides. ``None``: collisions are not checked.
    """

    max_iterations: int = 100
    time_limit: float = 0.2
    restarts: int = 50
    seed: int | None = 0
    nullspace: NullSpace | None = None
    avoid: CollisionModel | None = None

    def __post_init__(self) -> None:
        if self.max_iterations < 1:
            raise InputError(f"max_iterations must be at least 1, got {self.max_iterations}")
        if not self.time_limit > 0:
            raise InputError(f"time_limit must be positive [s], got {self.time_limit}")
        if self.restarts < 0:
            raise InputError(f"restarts must not be negative, got {self.restarts}")
