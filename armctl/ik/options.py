"""Options shared by the IK solvers."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from armctl.errors import InputError
from armctl.ik.nullspace import NullSpace

if TYPE_CHECKING:
    from armctl.collision.model import CollisionModel

__all__ = ["CCDWeights", "IKOptions"]


def _weight(value: float | None, what: str) -> None:
    if value is None:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{what} must be a number, got {value!r}")
    if not math.isfinite(value) or value < 0.0:
        raise InputError(f"{what} must be a finite number >= 0, got {value}")


@dataclass(frozen=True)
class CCDWeights:
    """The weights of CCD's objective ``g = w1 g1 + w2 g2`` (the lecture's form).

    ``g1`` is the dot product of the joint-to-goal and the rotated joint-to-effector vectors
    [m^2]; ``g2`` the sum of the dot products of the goal's and the rotated effector's axes
    [-]. Only their ratio changes the closed-form angle of a joint; ``position = 0`` turns the
    joints for the orientation alone, ``orientation = 0`` for the position alone.

    Attributes:
        position: ``w1`` [-].
        orientation: ``w2`` [m^2]; ``None``: ``(reach / 4)^2``, the arm's reach (the largest
            distance any of its frames can have from the base) making both terms alike in size.

    Raises:
        InputError: For a negative, infinite or non-numeric weight, or both weights zero.
    """

    position: float = 1.0
    orientation: float | None = None

    def __post_init__(self) -> None:
        _weight(self.position, "CCDWeights.position")
        _weight(self.orientation, "CCDWeights.orientation [m^2]")
        if self.position == 0.0 and self.orientation == 0.0:
            raise InputError("CCDWeights: position and orientation are both 0, so no joint "
                             "would ever turn; give one of them a positive weight")


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
        ccd_weights: The weights of the position and orientation terms of the ``ccd`` and
            ``ccd-jt`` sweeps (:class:`CCDWeights`); ``None``: the defaults.
        jt_gain: The J^T step of ``jt`` and ``ccd-jt``: ``None`` takes armctl's step (the
            length that minimises the linearised error, kept only when the error falls);
            a number ``alpha`` [rad/m^2] takes the lecture's fixed-gain step
            ``dq = alpha J^T e`` as it is (capped at the methods' largest joint step).
    """

    max_iterations: int = 100
    time_limit: float = 0.2
    restarts: int = 50
    seed: int | None = 0
    nullspace: NullSpace | None = None
    avoid: CollisionModel | None = None
    ccd_weights: CCDWeights | None = None
    jt_gain: float | None = None

    def __post_init__(self) -> None:
        if self.max_iterations < 1:
            raise InputError(f"max_iterations must be at least 1, got {self.max_iterations}")
        if not self.time_limit > 0:
            raise InputError(f"time_limit must be positive [s], got {self.time_limit}")
        if self.restarts < 0:
            raise InputError(f"restarts must not be negative, got {self.restarts}")
        if self.ccd_weights is not None and not isinstance(self.ccd_weights, CCDWeights):
            raise InputError(f"ccd_weights must be a CCDWeights, got {self.ccd_weights!r}")
        _weight(self.jt_gain, "jt_gain [rad/m^2]")
        if self.jt_gain == 0.0:
            raise InputError("jt_gain 0 would never move a joint; give a positive gain, or "
                             "None for armctl's optimal J^T step")
