"""Time scaling along a plan: pause, resume and speed changes that keep its path and the limits.

A plan ``q(s)`` is streamed along its own time ``s`` [s], which advances at the rate
``r = ds/dt`` [-] (1: as planned, 0: held). Pausing, resuming and changing the speed change
``r`` only, never the path, so the joints go through the same positions as planned (a plan
checked for collisions stays checked). The commanded joint motion is then::

    velocity      q'(s) r
    acceleration  q''(s) r^2 + q'(s) r'
    jerk          q'''(s) r^3 + 3 q''(s) r r' + q'(s) r''

where ``'`` on ``q`` is a derivative in plan time and on ``r`` one in real time. A change of
``r`` follows a :class:`RateProfile`: pieces of constant ``r''``, so that ``r`` and ``r'`` are
continuous and ``r''`` is bounded (never a step in joint velocity or acceleration). Before a
change is applied it is checked forward along the plan (:func:`plan_rate_change`): every
sample of the commanded velocity, acceleration and jerk must stay within the joint limits, and
a slower change is tried until one does. A rate above :attr:`PlanTable.cap` would exceed a limit
somewhere along the plan, so a requested speed is capped there.

The limits are the joints' hard limits. Where the plan itself commands more than a limit at its
own timing (a plan made without a jerk limit has jerk steps), the plan's own value at that point
is the bound: time scaling never makes a point of the plan worse than the plan and its limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from armctl.motion import MotionLimits, Trajectory
from armctl.typing import Array

__all__ = ["MAX_RATE", "PlanTable", "RateFollower", "RateProfile", "plan_rate_change",
           "rate_change_pieces"]

#: The largest rate (speed override) ever applied [-]: a plan made at the slowest speed
#: factor (0.01) played at the joint limits.
MAX_RATE = 100.0
#: Step of the plan table in plan time [s] (that of the plan check before motion).
TABLE_STEP = 0.002
#: Relative slack of the forward check, for rounding [-].
_REL_TOL = 1e-6
#: The shortest change of rate tried, for a change by the whole present rate [s] ...
RAMP_SHORTEST = 0.05
#: ... the longest [s] ...
RAMP_LONGEST = 8.0
#: ... and the factor between two tries [-].
RAMP_GROWTH = 1.35
#: A change that does not fit is tried again after this long [s].
RETRY_AFTER = 0.1


def _interp_rows(x: Array, xp: Array, fp: Array) -> Array:
    """``np.interp`` of every column of ``fp`` ``(N, J)`` at ``x`` ``(M,)`` -> ``(M, J)``."""
    idx = np.clip(np.searchsorted(xp, x, side="right") - 1, 0, xp.size - 2)
    w = ((x - xp[idx]) / (xp[idx + 1] - xp[idx]))[:, None]
    w = np.clip(w, 0.0, 1.0)
    return fp[idx] * (1.0 - w) + fp[idx + 1] * w


@dataclass(frozen=True)
class PlanTable:
    """A plan's derivatives in plan time, sampled for the checks of the time scaling.

    Attributes:
        s: Plan times ``(N,)`` [s], every :data:`TABLE_STEP` and at the breakpoints.
        d1: ``q'(s)`` ``(N, dof)`` [rad/s]/[m/s] (at rate 1).
        d2: ``q''(s)`` ``(N, dof)``.
        d3: ``q'''(s)`` ``(N, dof)``, by central differences of ``d2``.
        velocity: Velocity limits ``(dof,)``.
        acceleration: Acceleration limits ``(dof,)``.
        jerk: Jerk limits ``(dof,)`` (``inf`` where none).
    """

    s: Array
    d1: Array
    d2: Array
    d3: Array
    velocity: Array
    acceleration: Array
    jerk: Array

    @classmethod
    def of(cls, traj: Trajectory, limits: MotionLimits, step: float = TABLE_STEP) -> PlanTable:
        """Sample ``traj`` every ``step`` [s] of plan time and at its breakpoints."""
        dur = max(float(traj.duration), 0.0)
        n = max(2, math.ceil(dur / step) + 1)
        ts = np.unique(np.concatenate([np.linspace(0.0, dur, n),
                                       np.clip(traj.breakpoints(), 0.0, dur)]))
        if ts.size < 2:
            ts = np.array([0.0, max(dur, 1e-9)])
        _, d1, d2 = traj.sample_many(ts)
        d3 = np.gradient(d2, ts, axis=0) if ts.size > 2 else np.zeros_like(d2)
        return cls(ts, d1, d2, d3, np.asarray(limits.velocity, dtype=float),
                   np.asarray(limits.acceleration, dtype=float),
                   np.asarray(limits.jerk, dtype=float))

    @property
    def duration(self) -> float:
        """Length of the plan in plan time [s]."""
        return float(self.s[-1])

    def at(self, s: Array) -> tuple[Array, Array, Array]:
        """``q'``, ``q''`` and ``q'''`` at plan times ``s`` ``(M,)`` -> three ``(M, dof)``."""
        x = np.clip(np.asarray(s, dtype=float), self.s[0], self.s[-1])
        return (_interp_rows(x, self.s, self.d1), _interp_rows(x, self.s, self.d2),
                _interp_rows(x, self.s, self.d3))

    def bounds(self, d1: Array, d2: Array, d3: Array) -> tuple[Array, Array, Array]:
        """The bounds of the commanded velocity, acceleration and jerk at given samples.

        The joint limit, or the plan's own value at its own timing where that is larger.
        """
        return (np.maximum(self.velocity, np.abs(d1)), np.maximum(self.acceleration, np.abs(d2)),
                np.maximum(self.jerk, np.abs(d3)))

    @property
    def cap(self) -> float:
        """The largest constant rate the whole plan can run at within the bounds [-].

        At rate ``r`` the plan's velocity scales by ``r``, its acceleration by ``r^2`` and its
        jerk by ``r^3``; at least 1 (the plan as timed), at most :data:`MAX_RATE`.
        """
        vb, ab, jb = self.bounds(self.d1, self.d2, self.d3)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratios = [vb / np.abs(self.d1), np.sqrt(ab / np.abs(self.d2)),
                      np.cbrt(jb / np.abs(self.d3))]
        cap = MAX_RATE
        for r in ratios:
            r = r[np.isfinite(r)]
            if r.size:
                cap = min(cap, float(r.min()))
        return max(1.0, cap)

    def check(self, s: Array, r: Array, rd: Array, rdd: Array) -> str | None:
        """Check the commanded motion at samples of a rate profile.

        Args:
            s: Plan times ``(M,)`` [s].
            r: Rates ``(M,)`` [-].
            rd: Their derivatives in real time ``(M,)`` [1/s].
            rdd: Their second derivatives ``(M,)`` [1/s^2].

        Returns:
            ``None`` when every sample is within the bounds, else what is exceeded first.
        """
        if r.size and float(r.min()) < -1e-9:
            return "the plan's time would run backwards"
        d1, d2, d3 = self.at(s)
        vb, ab, jb = self.bounds(d1, d2, d3)
        rc, rdc, rddc = r[:, None], rd[:, None], rdd[:, None]
        vel = d1 * rc
        acc = d2 * rc**2 + d1 * rdc
        jerk = d3 * rc**3 + 3.0 * d2 * rc * rdc + d1 * rddc
        slack = 1.0 + _REL_TOL
        for name, value, bound in (("velocity", vel, vb), ("acceleration", acc, ab),
                                   ("jerk", jerk, jb)):
            if np.any(np.abs(value) > bound * slack + 1e-12):
                return name
        return None


class RateProfile:
    """The plan's time ``s`` and its rate ``r`` from a start time on: pieces of constant ``r''``.

    After the last piece the rate stays at :attr:`target`.

    Args:
        t0: Start time (on the loop's time axis) [s].
        s0: Plan time at ``t0`` [s].
        r0: Rate at ``t0`` [-].
        a0: ``r'`` at ``t0`` [1/s].
        pieces: ``(duration [s], r'' [1/s^2])`` pairs.
        target: The rate after the last piece [-].
    """

    def __init__(self, t0: float, s0: float, r0: float, a0: float,
                 pieces: list[tuple[float, float]], target: float):
        self.target = float(target)
        starts = [float(t0)]
        states = [(float(s0), float(r0), float(a0))]
        jerks = []
        for dur, j in pieces:
            s, r, a = states[-1]
            jerks.append(float(j))
            starts.append(starts[-1] + dur)
            states.append((s + r * dur + a * dur**2 / 2 + j * dur**3 / 6,
                           r + a * dur + j * dur**2 / 2, a + j * dur))
        s_end = states[-1][0]
        states[-1] = (s_end, self.target, 0.0)  # no rounding drift after the change
        jerks.append(0.0)
        self._t = np.array(starts)
        self._state = np.array(states)
        self._jerk = np.array(jerks)

    @classmethod
    def constant(cls, t0: float, s0: float, rate: float) -> RateProfile:
        """A constant rate from ``t0`` on."""
        return cls(t0, s0, rate, 0.0, [], rate)

    @property
    def end(self) -> float:
        """When the change ends (on the loop's time axis) [s]."""
        return float(self._t[-1])

    def at_many(self, t: Array) -> tuple[Array, Array, Array, Array]:
        """``s``, ``r``, ``r'`` and ``r''`` at times ``t`` ``(M,)`` (not before the start)."""
        tt = np.asarray(t, dtype=float)
        k = np.clip(np.searchsorted(self._t, tt, side="right") - 1, 0, self._t.size - 1)
        dt = np.maximum(tt - self._t[k], 0.0)
        s0, r0, a0 = self._state[k, 0], self._state[k, 1], self._state[k, 2]
        j = self._jerk[k]
        return (s0 + r0 * dt + a0 * dt**2 / 2 + j * dt**3 / 6, r0 + a0 * dt + j * dt**2 / 2,
                a0 + j * dt, j)

    def at(self, t: float) -> tuple[float, float, float, float]:
        """``s`` [s], ``r`` [-], ``r'`` [1/s] and ``r''`` [1/s^2] at time ``t`` [s]."""
        s, r, a, j = self.at_many(np.array([t]))
        return float(s[0]), float(r[0]), float(a[0]), float(j[0])


def rate_change_pieces(r0: float, a0: float, r1: float, amax: float, jmax: float
                       ) -> list[tuple[float, float]]:
    """The quickest change of rate from ``(r0, a0)`` to ``(r1, 0)``: constant-``r''`` pieces.

    At most three pieces, with ``|r'| <= amax`` (or ``|a0|``) and ``|r''| <= jmax``: bring
    ``r'`` towards the target's side at ``jmax``, hold it at the peak (when ``amax`` caps it),
    bring it back to zero at ``jmax``.

    Args:
        r0: Rate at the start [-].
        a0: ``r'`` at the start [1/s].
        r1: Rate to reach [-].
        amax: Largest ``|r'|`` [1/s] (at least ``|a0|`` is allowed).
        jmax: Largest ``|r''|`` [1/s^2].

    Returns:
        ``(duration [s], r'' [1/s^2])`` of each piece; empty when already there.
    """
    amax = max(amax, abs(a0))
    after = r0 + a0 * abs(a0) / (2.0 * jmax)  # the rate once r' is brought to zero
    gap = r1 - after
    if abs(gap) <= 1e-12 * max(1.0, abs(r1)):
        return [(abs(a0) / jmax, -math.copysign(jmax, a0))] if a0 != 0.0 else []
    d = math.copysign(1.0, gap)
    dist = d * (r1 - r0)
    peak = math.sqrt(max((2.0 * jmax * dist + a0 * a0) / 2.0, 0.0))
    hold = 0.0
    if peak > amax:
        peak = amax
        hold = max((dist - (2.0 * amax**2 - a0 * a0) / (2.0 * jmax)) / amax, 0.0)
    pieces = [(max((peak - d * a0) / jmax, 0.0), d * jmax), (hold, 0.0), (peak / jmax, -d * jmax)]
    return [p for p in pieces if p[0] > 0.0]


def plan_rate_change(table: PlanTable, now: RateProfile, t: float, target: float,
                     step: float, to_rest: bool) -> RateProfile | None:
    """A change of rate from the state of ``now`` at ``t`` to ``target``, within the limits.

    The changes tried get slower (from :data:`RAMP_SHORTEST` to :data:`RAMP_LONGEST` for a
    change by the whole present rate) until one keeps every sample of the commanded velocity,
    acceleration and jerk, every ``step`` [s] until the change has ended, within the bounds of
    :meth:`PlanTable.check`.

    Args:
        table: The plan's table.
        now: The rate profile followed so far.
        t: When the change starts [s] (loop time).
        target: The rate to change to [-].
        step: Time between two checked samples [s] (at most the loop's period).
        to_rest: The change must end before the plan does (a pause); otherwise the plan may
            end during the change.

    Returns:
        The new profile, or ``None`` when none fits (yet): e.g. the plan already decelerates
        at a joint's limit, so that slowing down further would exceed it; or a pause could
        not come to rest before the plan ends.
    """
    s0, r0, a0, _ = now.at(t)
    scale = max(r0, target, 0.01)
    length = RAMP_SHORTEST
    while length <= RAMP_LONGEST * (1 + 1e-9):
        amax = 2.0 * scale / length
        jmax = 8.0 * scale / length**2
        prof = RateProfile(t, s0, r0, a0, rate_change_pieces(r0, a0, target, amax, jmax), target)
        s_end = prof.at(prof.end)[0]
        if to_rest and s_end >= table.duration - 1e-9:
            return None  # slower changes end even later
        n = max(2, math.ceil((prof.end - t) / step) + 1)
        ts = np.linspace(t, prof.end, n)
        s, r, rd, rdd = prof.at_many(ts)
        keep = s <= table.duration
        if table.check(s[keep], r[keep], rd[keep], rdd[keep]) is None:
            return prof
        length *= RAMP_GROWTH
    return None


class RateFollower:
    """The plan's time on the loop's time axis, following a wanted rate within the limits.

    Args:
        table: The plan's table (``None``: the rate stays at ``rate``, no checks needed).
        rate: The rate at the start [-] (the plan starts at rest, so any rate up to the cap
            is a uniform rescaling of the plan).
        step: Time between two checked samples of a change [s].

    Attributes:
        profile: The rate profile followed.
        target: The rate the profile heads for [-].
        pending: A wanted rate that did not fit yet (tried again every :data:`RETRY_AFTER`).
    """

    def __init__(self, table: PlanTable | None, rate: float, step: float):
        self.table = table
        self.step = step
        self.profile = RateProfile.constant(0.0, 0.0, rate)
        self.target = rate
        self.pending: float | None = None
        self._retry_at = -math.inf

    def follow(self, t: float, wanted: float) -> tuple[float, float, float, float]:
        """The plan's state at loop time ``t`` [s], heading for rate ``wanted`` [-].

        Returns:
            ``s`` [s], ``r`` [-], ``r'`` [1/s], ``r''`` [1/s^2].
        """
        if self.table is not None and wanted != self.target and (
                wanted != self.pending or t >= self._retry_at):
            prof = plan_rate_change(self.table, self.profile, t, wanted, self.step,
                                    to_rest=wanted == 0.0)
            if prof is None:
                self.pending = wanted
                self._retry_at = t + RETRY_AFTER
            else:
                self.profile, self.target, self.pending = prof, wanted, None
        elif wanted == self.target:
            self.pending = None
        return self.profile.at(t)
