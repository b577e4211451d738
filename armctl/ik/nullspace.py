"""Secondary criteria for redundant arms, applied in the null space of the task Jacobian.

The redundancy step of the lecture (L. Kavan, *Metody skeletální animace*, 2002),
``dq = J^+ dx + (I - J^+ J) dz``, moves the joints along ``dz`` only as far as the end effector
does not move. ``dz = -gain * grad h(q)`` descends the weighted sum ``h`` of the criteria below;
``pinv`` and ``dls`` use it when :attr:`IKOptions.nullspace` is set, and keep improving ``h`` for
:attr:`NullSpace.iterations` iterations once the goals are met. The result is only returned as a
success when every goal is still met (checked by FK).
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from armctl.errors import InputError
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["KeepOut", "NullSpace", "TangentObjective", "ns_arrays"]


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


# ---- the tangent space of arms with universal and ball joints ----------------------------------

@dataclass(frozen=True)
class _BallTerms:
    """A ball joint's joint-limit term: entries in ``q`` and in tangent vectors, and its limits.

    ``swing_scale`` is ``sin^2(S / 2)`` of the cone's half angle ``S`` (0: no cone limit);
    ``twist_mid`` and ``twist_half`` the middle and half width of the twist range [rad]
    (``twist_half`` 0: no twist limit).
    """

    q: slice
    v: slice
    axis: Array
    swing_scale: float
    twist_mid: float
    twist_half: float


def _ball_terms(model: KinematicModel) -> tuple[_BallTerms, ...]:
    from armctl.config.schema import JointType

    out = []
    for i, j in enumerate(model.spec.actuated_joints):
        if j.type is not JointType.BALL:
            continue
        lo, hi = max(j.limits.lower, -math.pi), min(j.limits.upper, math.pi)
        twisted = lo > -math.pi or hi < math.pi
        out.append(_BallTerms(
            model.q_index(i), model.v_index(i), np.array(j.axis, dtype=float),
            math.sin(j.swing / 2) ** 2 if j.swing < math.pi else 0.0,
            (lo + hi) / 2 if twisted else 0.0, (hi - lo) / 2 if twisted else 0.0))
    return tuple(out)


class TangentObjective:
    """The null-space objective ``h`` of an arm with universal or ball joints, and its gradient.

    The gradient is taken in the tangent space (``nv`` entries): ``grad[k]`` is the derivative
    of ``h(model.integrate(q, t e_k))`` at ``t = 0``, so ``-grad`` is the steepest descent
    step that :meth:`KinematicModel.integrate` applies. The terms (weights of
    :class:`NullSpace`):

    * posture: ``|model.difference(q_pref, q)|^2 / 2`` (a ball joint's part the squared
      rotation angle of ``q_pref^-1 q``); its gradient is ``difference(q_pref, q)`` itself;
    * joint limits: ``((q - mid) / half_range)^2 / 2`` per limited 1-DOF or universal entry as
      for other arms; a ball joint adds ``(sin^2(s / 2) / sin^2(S / 2))^2 / 2`` for its swing
      ``s`` in a cone of half angle ``S`` (0 at the centre, 1/2 at the edge, like a 1-DOF
      entry at its limit) and ``((t - mid) / half)^2 / 2`` for its twist ``t`` in a limited
      twist range (the swing and twist of :func:`armctl.spatial.swing_twist`);
    * keep-out spheres: ``sum max(0, r - |p - c|)^2 / 2`` over the frames' origins, its
      gradient through the tangent Jacobian;
    * manipulability: ``-sqrt(det(J J^T))`` of the first goal's frame, its gradient by central
      differences through :meth:`KinematicModel.integrate`.

    Args:
        model: The arm.
        ns: The criteria.
        frame: The frame whose manipulability counts (the first goal's).

    Raises:
        InputError: For a preferred posture of the wrong length or with a ball joint's
            quaternion not of unit norm.
    """

    def __init__(self, model: KinematicModel, ns: NullSpace, frame: str | None = None):
        self.model = model
        self.ns = ns
        self.frame = frame
        self.pref = (model.neutral() if ns.preferred is None
                     else model.as_q(ns.preferred, "null-space preferred posture"))
        self.balls = _ball_terms(model)
        lo, hi = model.lower, model.upper
        #: (entry of q, entry of the tangent, middle, half range) of each limited 1-DOF entry
        self.ranges: list[tuple[int, int, float, float]] = []
        for j in range(len(model.joint_names)):
            qs, vs = model.q_index(j), model.v_index(j)
            if qs.stop - qs.start != vs.stop - vs.start:
                continue  # a ball joint: its own terms
            for i, k in zip(range(qs.start, qs.stop), range(vs.start, vs.stop), strict=True):
                if math.isfinite(lo[i]) and math.isfinite(hi[i]) and hi[i] > lo[i]:
                    self.ranges.append((i, k, (lo[i] + hi[i]) / 2, (hi[i] - lo[i]) / 2))
        self.spheres = [(np.array(s.center), s.radius, f) for s in ns.keep_out for f in s.frames]
        for _, _, f in self.spheres:
            model.frame_index(f)

    def __call__(self, q: Array) -> float:
        """``h(q)``."""
        ns, model = self.ns, self.model
        h = 0.0
        if ns.posture:
            d = model.difference(self.pref, q)
            h += ns.posture * 0.5 * float(d @ d)
        if ns.joint_limits:
            s = sum(((q[i] - mid) / half) ** 2 for i, _, mid, half in self.ranges)
            for b in self.balls:
                swing, twist = _swing_twist_terms(q[b.q], b)
                s += swing ** 2 + twist ** 2
            h += ns.joint_limits * 0.5 * s
        if ns.keep_out and ns.keep_out_weight:
            s = 0.0
            for c, r, f in self.spheres:
                dist = float(np.linalg.norm(model.fk(q, f)[:3, 3] - c))
                s += max(0.0, r - dist) ** 2
            h += ns.keep_out_weight * 0.5 * s
        if ns.manipulability:
            h -= ns.manipulability * _manipulability(model.jacobian(q, self.frame))
        return h

    def gradient(self, q: Array) -> Array:
        """The gradient of ``h`` in the tangent space at ``q`` ``(nv,)``."""
        ns, model = self.ns, self.model
        g = np.zeros(model.nv)
        if ns.posture:
            g += ns.posture * model.difference(self.pref, q)
        if ns.joint_limits:
            for i, k, mid, half in self.ranges:
                g[k] += ns.joint_limits * (q[i] - mid) / (half * half)
            for b in self.balls:
                g[b.v] += ns.joint_limits * _ball_limit_gradient(q[b.q], b)
        if ns.keep_out and ns.keep_out_weight:
            for c, r, f in self.spheres:
                pose, jac = model.fk_jacobian(q, f)
                d = pose[:3, 3] - c
                dist = float(np.linalg.norm(d))
                if 1e-12 < dist < r:
                    g -= ns.keep_out_weight * (r - dist) / dist * (jac[:3].T @ d)
        if ns.manipulability:
            step = 1e-6
            e = np.zeros(model.nv)
            for k in range(model.nv):
                e[k] = step
                up = _manipulability(model.jacobian(model.integrate(q, e), self.frame))
                e[k] = -step
                down = _manipulability(model.jacobian(model.integrate(q, e), self.frame))
                e[k] = 0.0
                g[k] -= ns.manipulability * (up - down) / (2 * step)
        return g


def _manipulability(jac: Array) -> float:
    """``sqrt(det(J J^T))`` (``J^T J`` when ``J`` has fewer columns than rows)."""
    a = jac @ jac.T if jac.shape[1] >= jac.shape[0] else jac.T @ jac
    return math.sqrt(max(float(np.linalg.det(a)), 0.0))


def _swing_twist_terms(quat: Array, b: _BallTerms) -> tuple[float, float]:
    """A ball joint's swing and twist terms (each squared and halved in ``h``)."""
    w, p = float(quat[0]), float(quat[1:] @ b.axis)
    if w < 0:
        w, p = -w, -p
    swing = (1.0 - (w * w + p * p) / float(quat @ quat)) / b.swing_scale if b.swing_scale else 0.0
    twist = ((2.0 * math.atan2(p, w) - b.twist_mid) / b.twist_half
             if b.twist_half and w * w + p * p > 1e-24 else 0.0)
    return swing, twist


def _ball_limit_gradient(quat: Array, b: _BallTerms) -> Array:
    """The tangent gradient ``(3,)`` of a ball joint's limit terms.

    The derivative by the quaternion's entries, times ``dq/dv = q ⊗ (0, e_k) / 2`` of the
    step ``q ⊗ exp(v / 2)``.
    """
    q = quat / np.linalg.norm(quat)
    if q[0] < 0:
        q = -q
    w, v = float(q[0]), q[1:]
    a = b.axis
    p = float(v @ a)
    dq = np.zeros(4)  # d(h_swing + h_twist) / d(w, x, y, z) on the unit sphere
    swing, twist = _swing_twist_terms(q, b)
    if b.swing_scale:  # h = swing^2 / 2, swing = (1 - w^2 - p^2) / scale
        dq[0] += swing * (-2.0 * w) / b.swing_scale
        dq[1:] += swing * (-2.0 * p) / b.swing_scale * a
    r2 = w * w + p * p
    if b.twist_half and r2 > 1e-24:  # h = twist^2 / 2, twist = (2 atan2(p, w) - mid) / half
        dq[0] += twist * (-2.0 * p / r2) / b.twist_half
        dq[1:] += twist * (2.0 * w / r2) / b.twist_half * a
    # q ⊗ (0, e_k) / 2 for k = x, y, z: the columns of dq/dv
    x, y, z = v
    dqdv = 0.5 * np.array([[-x, -y, -z], [w, -z, y], [z, w, -x], [-y, x, w]])
    return np.asarray(dqdv.T @ dq, dtype=float)
