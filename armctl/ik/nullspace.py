"""Secondary criteria for redundant arms, applied in the null space of the task Jacobian.

The redundancy step of the lecture (L. Kavan, *Metody skeletální animace*, 2002),
``dq = J^+ dx + (I - J^+ J) dz``, moves the joints along ``dz`` only as far as the end effector
does not move. ``dz = -gain * grad h(q)`` descends the weighted sum ``h`` of the criteria below;
``pinv`` and ``dls`` use it when :attr:`IKOptions.nullspace` is set, and keep improving ``h`` for
:attr:`NullSpace.iterations` iterations once the goals are met. The result is only returned as a
success when every goal is still met (checked by FK).
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from armctl.errors import InputError
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["KeepOut", "NullSpace", "ns_arrays"]


@dataclass(frozen=True)
class KeepOut:
    """A sphere that the origins of the named frames should stay out of.

    Attributes:
        center: Centre in the base frame [m].
        radius: Radius [m] (include any safety margin).
        frames: Frames (links or extra frames) whose origins are kept out.
    """

    center: tuple[float, float, float]
    radius: float
    frames: tuple[str, ...]

    def __post_init__(self) -> None:
        c = tuple(float(x) for x in np.asarray(self.center, dtype=float).reshape(-1))
        if len(c) != 3 or not all(np.isfinite(c)):
            raise InputError(f"a keep-out sphere's centre must be 3 finite numbers, got {c}")
        object.__setattr__(self, "center", c)
        if not self.radius > 0:
            raise InputError(f"a keep-out sphere's radius must be positive [m], got {self.radius}")
        object.__setattr__(self, "frames", tuple(self.frames))
        if not self.frames:
            raise InputError("a keep-out sphere needs at least one frame to keep out")


@dataclass(frozen=True)
class NullSpace:
    """Weights of the secondary criteria (0 switches one off).

    Attributes:
        posture: Comfortable posture: ``|q - preferred|^2 / 2`` [1/rad^2].
        preferred: The comfortable posture ``(dof,)``; the middle of the ranges when ``None``.
        joint_limits: Joint-limit avoidance: ``sum(((q - mid) / half_range)^2) / 2``.
        keep_out: Keep-out spheres for link points.
        keep_out_weight: Weight of ``sum(max(0, r - distance)^2) / 2`` [1/m^2].
        manipulability: Weight of ``-sqrt(det(J J^T))`` of the first goal's frame (maximises the
            manipulability).
        gain: Step gain on the gradient.
        iterations: Iterations spent improving ``h`` once the goals are met.
    """

    posture: float = 0.0
    preferred: tuple[float, ...] | None = None
    joint_limits: float = 0.0
    keep_out: tuple[KeepOut, ...] = ()
    keep_out_weight: float = 100.0
    manipulability: float = 0.0
    gain: float = 0.5
    iterations: int = 100

    def __post_init__(self) -> None:
        for name in ("posture", "joint_limits", "keep_out_weight", "manipulability"):
            if getattr(self, name) < 0:
                raise InputError(f"null-space weight {name} must not be negative")
        if not self.gain > 0:
            raise InputError(f"null-space gain must be positive, got {self.gain}")
        if self.iterations < 0:
            raise InputError(f"null-space iterations must not be negative, got {self.iterations}")
        object.__setattr__(self, "keep_out", tuple(self.keep_out))
        if self.preferred is not None:
            object.__setattr__(self, "preferred", tuple(float(x) for x in self.preferred))

    @property
    def active(self) -> bool:
        """Whether any criterion has a non-zero weight."""
        return bool(self.posture or self.joint_limits or self.manipulability
                    or (self.keep_out and self.keep_out_weight))


_NONE: weakref.WeakKeyDictionary[KinematicModel, tuple[Array, Array, Array]] = (
    weakref.WeakKeyDictionary())


def ns_arrays(model: KinematicModel, ns: NullSpace | None) -> tuple[Array, Array, Array]:
    """Weights ``(4,)``, preferred posture ``(dof,)`` and spheres ``(S, 5)`` for the engine."""
    if ns is None or not ns.active:
        return _NONE.get(model) or _NONE.setdefault(
            model, (np.zeros(4), np.ascontiguousarray(model.middle()), np.zeros((0, 5))))
    nsw = np.zeros(4)
    pref = model.middle()
    spheres = np.zeros((0, 5))
    nsw[:] = (ns.posture, ns.joint_limits, ns.keep_out_weight if ns.keep_out else 0.0,
              ns.manipulability)
    if ns.preferred is not None:
        pref = model.as_q(ns.preferred, "null-space preferred posture")
    rows: list[Sequence[float]] = []
    for k in ns.keep_out:
        for f in k.frames:
            rows.append((float(model.frame_index(f)), *k.center, k.radius))
    if rows:
        spheres = np.array(rows, dtype=float)
    return nsw, np.ascontiguousarray(pref, dtype=float), spheres
