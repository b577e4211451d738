"""Joint trajectories: anything that gives ``(q, qd, qdd)`` at a time in ``[0, duration]``.

All classes here are immutable after construction and sample in SI units: [rad] or [m],
per second and per second squared. Times outside ``[0, duration]`` are clamped to the nearest end.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from armctl.typing import Array

if TYPE_CHECKING:
    import ruckig

__all__ = [
    "Chain",
    "Hold",
    "PathTrajectory",
    "PiecewisePolynomial",
    "RuckigTrajectory",
    "Sampled",
    "TimeScaled",
    "Trajectory",
]

Sampled = tuple[Array, Array, Array]


class Trajectory(ABC):
    """A time-parameterised joint motion.

    Positions have :attr:`nq` entries, velocities and accelerations :attr:`dof`: the same for
    an arm of 1-DOF joints; a ball joint takes a unit quaternion in the position and its angular
    velocity [rad/s] (three entries, in its moved frame) in the velocity.

    Attributes:
        dof: Number of velocity entries (joints, for an arm of 1-DOF joints).
    """

    dof: int

    @property
    def nq(self) -> int:
        """Number of position entries (:attr:`dof` unless the arm has ball joints)."""
        return self.dof

    @property
    @abstractmethod
    def duration(self) -> float:
        """Length in time [s]."""

    @abstractmethod
    def sample(self, t: float) -> Sampled:
        """Position ``(nq,)``, velocity and acceleration ``(dof,)`` at time ``t`` [s]."""

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:
        """Samples at many times: positions ``(N, nq)``, velocities, accelerations ``(N, dof)``."""
        times = np.asarray(ts, dtype=float).reshape(-1)
        q = np.empty((times.size, self.nq))
        out = np.empty((2, times.size, self.dof))
        for k, t in enumerate(times):
            q[k], out[0, k], out[1, k] = self.sample(float(t))
        return q, out[0], out[1]

    def breakpoints(self) -> Array:
        """Times [s] where the motion changes piece (segment ends, keyframes)."""
        return np.array([0.0, self.duration])

    @property
    def start(self) -> Array:
        """Position at ``t = 0``."""
        return self.sample(0.0)[0]

    @property
    def end(self) -> Array:
        """Position at ``t = duration``."""
        return self.sample(self.duration)[0]


class RuckigTrajectory(Trajectory):
    """A jerk-limited, time-synchronised trajectory computed by Ruckig.

    Args:
        traj: The computed ``ruckig.Trajectory``.
    """

    def __init__(self, traj: ruckig.Trajectory):
        self._traj = traj
        self.dof = int(traj.degrees_of_freedom)
        self._duration = float(traj.duration)

    @property
    def duration(self) -> float:  # noqa: D102
        return self._duration

    def sample(self, t: float) -> Sampled:  # noqa: D102
        p, v, a = self._traj.at_time(min(max(t, 0.0), self._duration))
        return np.array(p), np.array(v), np.array(a)

    def position_extrema(self) -> tuple[Array, Array]:
        """Exact lowest and highest position ``(dof,)`` of each joint over the trajectory."""
        ext = self._traj.position_extrema
        return np.array([e.min for e in ext]), np.array([e.max for e in ext])


class PiecewisePolynomial(Trajectory):
    """Polynomials between breakpoints: ``q(t) = sum_i c[k, i] (t - t_k)^i`` on piece ``k``.

    Args:
        breaks: ``(m + 1,)`` increasing times [s], starting at 0.
        coeffs: ``(m, order + 1, dof)`` coefficients, lowest power first.
    """

    def __init__(self, breaks: npt.ArrayLike, coeffs: npt.ArrayLike):
        self._breaks = np.asarray(breaks, dtype=float)
        self._c = np.asarray(coeffs, dtype=float)
        if self._c.ndim != 3 or self._c.shape[0] != self._breaks.size - 1:
            raise ValueError("coeffs must have shape (pieces, order + 1, dof)")
        if np.any(np.diff(self._breaks) <= 0):
            raise ValueError("breakpoints must increase strictly")
        self.dof = int(self._c.shape[2])
        powers = np.arange(self._c.shape[1], dtype=float)
        self._d1 = self._c[:, 1:, :] * powers[1:, None]
        self._d2 = self._d1[:, 1:, :] * powers[1:-1, None] if self._c.shape[1] > 2 else (
            np.zeros((self._c.shape[0], 1, self.dof)))

    @property
    def duration(self) -> float:  # noqa: D102
        return float(self._breaks[-1] - self._breaks[0])

    def breakpoints(self) -> Array:  # noqa: D102
        return self._breaks - self._breaks[0]

    @staticmethod
    def _horner(c: Array, tau: Array) -> Array:
        # c: (N, order + 1, dof), tau: (N,)
        out = np.array(c[:, -1, :])
        for i in range(c.shape[1] - 2, -1, -1):
            out = out * tau[:, None] + c[:, i, :]
        return out

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:  # noqa: D102
        t = np.asarray(ts, dtype=float).reshape(-1) + self._breaks[0]
        t = np.clip(t, self._breaks[0], self._breaks[-1])
        k = np.clip(np.searchsorted(self._breaks, t, side="right") - 1, 0, self._c.shape[0] - 1)
        tau = t - self._breaks[k]
        q = self._horner(self._c[k], tau)
        qd = self._horner(self._d1[k], tau)
        qdd = self._horner(self._d2[k], tau)
        return q, qd, qdd

    def sample(self, t: float) -> Sampled:  # noqa: D102
        q, qd, qdd = self.sample_many([t])
        return q[0], qd[0], qdd[0]


class Hold(Trajectory):
    """Standing still at ``q`` for ``duration`` [s] (a dwell).

    Args:
        q: The position ``(nq,)``.
        duration: How long [s].
        dof: Velocity entries; ``None``: as many as ``q`` has (an arm without ball joints).
    """

    def __init__(self, q: npt.ArrayLike, duration: float, dof: int | None = None):
        self._q = np.array(q, dtype=float)
        self.dof = int(self._q.size) if dof is None else int(dof)
        self._duration = float(duration)

    @property
    def nq(self) -> int:  # noqa: D102
        return int(self._q.size)

    @property
    def duration(self) -> float:  # noqa: D102
        return self._duration

    def sample(self, t: float) -> Sampled:  # noqa: D102
        z = np.zeros(self.dof)
        return self._q.copy(), z, z.copy()

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:  # noqa: D102
        n = np.asarray(ts).size
        z = np.zeros((n, self.dof))
        return np.tile(self._q, (n, 1)), z, z.copy()


class Chain(Trajectory):
    """Trajectories played one after the other; each must start where the previous ends.

    Args:
        parts: The pieces, in order (at least one).
    """

    def __init__(self, parts: Sequence[Trajectory]):
        if not parts:
            raise ValueError("a chain needs at least one trajectory")
        self.parts = tuple(parts)
        self.dof = parts[0].dof
        self._nq = parts[0].nq
        self._starts = np.concatenate([[0.0], np.cumsum([p.duration for p in parts])])

    @property
    def duration(self) -> float:  # noqa: D102
        return float(self._starts[-1])

    @property
    def nq(self) -> int:  # noqa: D102
        return self._nq

    @property
    def offsets(self) -> Array:
        """Start time [s] of each part, then the total duration."""
        return self._starts.copy()

    def breakpoints(self) -> Array:  # noqa: D102
        pts = [p.breakpoints() + s for p, s in zip(self.parts, self._starts, strict=False)]
        return np.unique(np.concatenate(pts))

    def _part(self, t: float) -> int:
        k = int(np.searchsorted(self._starts, t, side="right")) - 1
        return min(max(k, 0), len(self.parts) - 1)

    def sample(self, t: float) -> Sampled:  # noqa: D102
        k = self._part(t)
        return self.parts[k].sample(t - float(self._starts[k]))

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:  # noqa: D102
        times = np.asarray(ts, dtype=float).reshape(-1)
        idx = np.clip(np.searchsorted(self._starts, times, side="right") - 1, 0,
                      len(self.parts) - 1)
        if self._nq != self.dof:
            pos = np.empty((times.size, self._nq))
            rates = np.empty((2, times.size, self.dof))
            for k in np.unique(idx):
                sel = idx == k
                pos[sel], rates[0, sel], rates[1, sel] = self.parts[k].sample_many(
                    times[sel] - self._starts[k])
            return pos, rates[0], rates[1]
        out = np.empty((3, times.size, self.dof))
        for k in np.unique(idx):
            sel = idx == k
            q, qd, qdd = self.parts[k].sample_many(times[sel] - self._starts[k])
            out[0, sel], out[1, sel], out[2, sel] = q, qd, qdd
        return out[0], out[1], out[2]


class TimeScaled(Trajectory):
    """Another trajectory played ``factor`` times slower (``factor`` > 1) or faster (< 1)."""

    def __init__(self, inner: Trajectory, factor: float):
        if not factor > 0:
            raise ValueError("time-scaling factor must be positive")
        self.inner = inner
        self.factor = float(factor)
        self.dof = inner.dof

    @property
    def nq(self) -> int:  # noqa: D102
        return self.inner.nq

    @property
    def duration(self) -> float:  # noqa: D102
        return self.inner.duration * self.factor

    def breakpoints(self) -> Array:  # noqa: D102
        return self.inner.breakpoints() * self.factor

    def sample(self, t: float) -> Sampled:  # noqa: D102
        q, qd, qdd = self.inner.sample(t / self.factor)
        return q, qd / self.factor, qdd / self.factor**2

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:  # noqa: D102
        q, qd, qdd = self.inner.sample_many(np.asarray(ts, dtype=float) / self.factor)
        return q, qd / self.factor, qdd / self.factor**2


class PathTrajectory(Trajectory):
    """A geometric joint path ``q(s)``, ``s`` in [0, 1], followed with a timing law ``s(t)``.

    Args:
        path: ``q(s)`` as a piecewise polynomial over ``s`` in [0, 1].
        timing: ``s(t)`` as a one-joint piecewise polynomial from 0 to 1.
    """

    def __init__(self, path: PiecewisePolynomial, timing: PiecewisePolynomial):
        self.path = path
        self.timing = timing
        self.dof = path.dof

    @property
    def duration(self) -> float:  # noqa: D102
        return self.timing.duration

    def sample_many(self, ts: npt.ArrayLike) -> Sampled:  # noqa: D102
        s, sd, sdd = self.timing.sample_many(ts)
        s = np.clip(s[:, 0], 0.0, 1.0)
        q, dq, ddq = self.path.sample_many(s)
        return q, dq * sd, ddq * sd**2 + dq * sdd

    def sample(self, t: float) -> Sampled:  # noqa: D102
        q, qd, qdd = self.sample_many([t])
        return q[0], qd[0], qdd[0]
