"""Point-to-point joint profiles: Ruckig S-curves, minimum-jerk quintics, controlled stops.

Every move here starts and ends with all joints together (time-synchronised). Position limits are
not enforced by the free Ruckig, so callers check the result with
:func:`armctl.motion.limits.check_trajectory`.
"""

from __future__ import annotations

import math
import re

import numpy as np
import numpy.typing as npt
import ruckig

from armctl.errors import PlanningError
from armctl.motion.limits import MotionLimits
from armctl.motion.trajectory import Hold, PiecewisePolynomial, RuckigTrajectory, Trajectory
from armctl.typing import Array

__all__ = [
    "min_jerk_duration",
    "quintic_segment",
    "ruckig_move",
    "stop_trajectory",
]


_STILL = 1e-12


def _input(limits: MotionLimits, q0: Array, v0: Array | None, a0: Array | None
           ) -> ruckig.InputParameter:
    inp = ruckig.InputParameter(limits.dof)
    inp.current_position = np.asarray(q0, dtype=float).tolist()
    inp.current_velocity = (np.zeros(limits.dof) if v0 is None else np.asarray(v0)).tolist()
    inp.current_acceleration = (np.zeros(limits.dof) if a0 is None else np.asarray(a0)).tolist()
    inp.max_velocity = limits.velocity.tolist()
    inp.max_acceleration = limits.acceleration.tolist()
    inp.max_jerk = limits.jerk.tolist()
    return inp


def ruckig_move(q0: npt.ArrayLike, q1: npt.ArrayLike, limits: MotionLimits, *,
                v0: npt.ArrayLike | None = None, v1: npt.ArrayLike | None = None,
                a0: npt.ArrayLike | None = None, a1: npt.ArrayLike | None = None,
                straight: bool = True, min_duration: float | None = None) -> Trajectory:
    """A time-optimal, jerk-limited move from ``q0`` to ``q1`` with every joint synchronised.

    Args:
        q0: Start position ``(dof,)`` [rad]/[m].
        q1: Goal position.
        limits: Velocity, acceleration and jerk limits (already speed-scaled).
        v0: Start velocity (rest when ``None``).
        v1: Goal velocity (rest when ``None``).
        a0: Start acceleration (zero when ``None``).
        a1: Goal acceleration (zero when ``None``).
        straight: Phase synchronisation: a straight line in joint space (rest to rest only).
        min_duration: Make the move last at least this long [s].

    Returns:
        The trajectory (a :class:`Hold` of zero length when already there at rest).

    Raises:
        PlanningError: If Ruckig cannot compute a trajectory for these inputs.
    """
    a = np.asarray(q0, dtype=float)
    b = np.asarray(q1, dtype=float)
    rest = all(x is None or not np.any(np.asarray(x)) for x in (v0, v1, a0, a1))
    if rest and np.max(np.abs(b - a), initial=0.0) < _STILL and not min_duration:
        return Hold(b, 0.0)
    inp = _input(limits, a, None if v0 is None else np.asarray(v0, dtype=float),
                 None if a0 is None else np.asarray(a0, dtype=float))
    inp.target_position = b.tolist()
    inp.target_velocity = (np.zeros(limits.dof) if v1 is None else np.asarray(v1)).tolist()
    inp.target_acceleration = (np.zeros(limits.dof) if a1 is None else np.asarray(a1)).tolist()
    inp.synchronization = (ruckig.Synchronization.Phase if straight and rest
                           else ruckig.Synchronization.Time)
    if min_duration:
        inp.minimum_duration = float(min_duration)
    first = _calculate(inp, limits.dof)
    if isinstance(first, RuckigTrajectory):
        return first
    # Ruckig's step 1 fails on some inputs that sit exactly on the border between two profile
    # shapes (e.g. a distance of exactly 2 a^3 / j^2 at rest, common with round numbers and
    # speed factors): the candidates on both sides are rejected by rounding. Limits a hair
    # lower move the input off that border; the result stays inside the requested limits.
    for shrink in _RETRY_SHRINK:
        inp.max_jerk = (limits.jerk * (1.0 - shrink)).tolist()
        retry = _calculate(inp, limits.dof)
        if isinstance(retry, RuckigTrajectory):
            return retry
    if inp.synchronization == ruckig.Synchronization.Phase:
        inp.max_jerk = limits.jerk.tolist()
        inp.synchronization = ruckig.Synchronization.Time  # not a straight line, still in time
        retry = _calculate(inp, limits.dof)
        if isinstance(retry, RuckigTrajectory):
            return retry
    raise PlanningError(f"the trajectory generator could not plan the move from "
                        f"{np.round(a, 6).tolist()} to {np.round(b, 6).tolist()}: {first}; "
                        "nothing was moved. Try another speed factor or an intermediate goal")


#: Relative reductions of the jerk limits tried when Ruckig fails on an input [-].
_RETRY_SHRINK = (1e-9, 1e-6, 1e-3)
#: Ruckig's result codes that its Python enum does not list.
_RESULT_CODES = {-101: "the move would last too long for the trajectory generator (more than "
                       "about 2 hours); use a higher speed factor",
                 -104: "a velocity, acceleration or jerk limit is zero"}


def _calculate(inp: ruckig.InputParameter, dof: int) -> RuckigTrajectory | str:
    """Run Ruckig once: the trajectory, or why it failed (one line)."""
    traj = ruckig.Trajectory(dof)
    try:
        result = ruckig.Ruckig(dof).calculate(inp, traj)
    except ruckig.RuckigError as exc:  # derives from Exception, not RuntimeError
        lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
        return (lines[0] if lines else "error").removeprefix("[ruckig] ").removesuffix(
            " input:")
    except ValueError as exc:  # a result code that the Python enum lacks, e.g. -101
        code = re.search(r"-?\d+", str(exc))
        known = _RESULT_CODES.get(int(code.group())) if code else None
        return known or f"result {exc}"
    if result not in (ruckig.Result.Working, ruckig.Result.Finished):
        return str(result)
    if not math.isfinite(traj.duration):
        return f"duration {traj.duration}"
    return RuckigTrajectory(traj)


def stop_trajectory(q: npt.ArrayLike, qd: npt.ArrayLike, qdd: npt.ArrayLike,
                    limits: MotionLimits) -> Trajectory:
    """The quickest jerk-limited stop from a moving state, within the limits.

    Uses Ruckig's velocity interface to bring every joint to rest together.

    Args:
        q: Present commanded position.
        qd: Present commanded velocity.
        qdd: Present commanded acceleration.
        limits: Limits to respect while stopping (the hard limits, not the speed-scaled ones).

    Returns:
        A trajectory that ends at rest.
    """
    pos = np.asarray(q, dtype=float)
    vel = np.asarray(qd, dtype=float)
    acc = np.asarray(qdd, dtype=float)
    if np.max(np.abs(vel), initial=0.0) < _STILL and np.max(np.abs(acc), initial=0.0) < _STILL:
        return Hold(pos, 0.0)
    # Ruckig rejects a current state beyond the limits; clip in case sampling rounded past them.
    vel = np.clip(vel, -limits.velocity, limits.velocity)
    acc = np.clip(acc, -limits.acceleration, limits.acceleration)
    inp = _input(limits, pos, vel, acc)
    inp.control_interface = ruckig.ControlInterface.Velocity
    inp.target_velocity = [0.0] * limits.dof
    inp.target_acceleration = [0.0] * limits.dof
    inp.synchronization = ruckig.Synchronization.Time
    planned = _calculate(inp, limits.dof)
    if isinstance(planned, RuckigTrajectory):
        return planned
    # Fall back to a constant-deceleration stop (acceleration limit, unbounded jerk).
    t_stop = float(np.max(np.abs(vel) / limits.acceleration))
    dec = -vel / t_stop if t_stop > 0 else np.zeros_like(vel)
    coeffs = np.stack([pos, vel, dec / 2.0])[None]
    return PiecewisePolynomial([0.0, max(t_stop, 1e-6)], coeffs)


def min_jerk_duration(distance: npt.ArrayLike, limits: MotionLimits) -> float:
    """Shortest duration [s] of a rest-to-rest minimum-jerk (quintic) move within the limits.

    For ``s = 10 tau^3 - 15 tau^4 + 6 tau^5`` the peaks are 1.875 D/T (velocity),
    5.7735 D/T^2 (acceleration) and 60 D/T^3 (jerk).
    """
    d = np.abs(np.asarray(distance, dtype=float))
    t_v = 1.875 * d / limits.velocity
    t_a = np.sqrt(10.0 / math.sqrt(3.0) * d / limits.acceleration)
    t_j = np.cbrt(60.0 * d / limits.jerk)
    return float(np.max(np.concatenate([t_v, t_a, t_j]), initial=0.0))


def quintic_segment(q0: Array, v0: Array, a0: Array, q1: Array, v1: Array, a1: Array,
                    h: float) -> Array:
    """Coefficients ``(6, dof)`` (lowest power first) of the quintic matching both end states.

    Args:
        q0: Start position.
        v0: Start velocity.
        a0: Start acceleration.
        q1: End position.
        v1: End velocity.
        a1: End acceleration.
        h: Duration [s].
    """
    d = q1 - q0 - v0 * h - a0 * h * h / 2.0
    dv = v1 - v0 - a0 * h
    da = a1 - a0
    c3 = (10.0 * d - 4.0 * dv * h + da * h * h / 2.0) / h**3
    c4 = (-15.0 * d + 7.0 * dv * h - da * h * h) / h**4
    c5 = (6.0 * d - 3.0 * dv * h + da * h * h / 2.0) / h**5
    return np.stack([q0, v0, a0 / 2.0, c3, c4, c5])
