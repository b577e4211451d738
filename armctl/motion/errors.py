"""Errors of motion planning: limits that a plan would exceed, paths that cannot be followed."""

from __future__ import annotations

from armctl.errors import PlanningError

__all__ = ["DetourError", "LimitViolation", "PathError"]


class LimitViolation(PlanningError):
    """A planned trajectory would exceed a joint limit; nothing was moved.

    Args:
        joint: The joint's name.
        kind: ``"position"``, ``"velocity"``, ``"acceleration"`` or ``"jerk"``.
        value: The planned value (signed) in SI units.
        bound: The limit it exceeds (positive for velocity and above, the crossed position limit
            for position).
        time: When along the trajectory [s].
        hint: How to fix it (a sentence; its first letter is capitalised).
        unit: The joint's unit, ``"rad"`` or ``"m"`` (the value's unit follows from ``kind``,
            e.g. rad/s for a velocity); empty when unknown.

    ``details``: ``joint``, ``limit`` (the kind), ``value``, ``bound`` and ``time``.
    """

    def __init__(self, joint: str, kind: str, value: float, bound: float, time: float,
                 hint: str = "", unit: str = ""):
        self.joint = joint
        self.kind = kind
        self.value = value
        self.bound = bound
        self.time = time
        self.unit = unit
        shown = f" {unit}{_PER_TIME.get(kind, '')}" if unit else ""
        text = (f"planned {kind} of joint {joint!r} would be {value:.6g}{shown} at "
                f"t={time:.3f} s, beyond its limit {bound:.6g}{shown}; nothing was moved")
        if hint:
            text += f". {hint[:1].upper()}{hint[1:]}"
        super().__init__(text, {"joint": joint, "limit": kind, "value": value, "bound": bound,
                                "time": time})


#: The time derivative in a limit's unit, by kind (rad/s, rad/s^2, ...).
_PER_TIME = {"velocity": "/s", "acceleration": "/s^2", "jerk": "/s^3"}


class PathError(PlanningError):
    """A Cartesian path cannot be followed; the fraction that could be planned is attached.

    Args:
        fraction: Fraction of the path [0-1] planned before the failure.
        reason: What failed there (IK, a joint limit, a jump between IK branches).
        joint: The joint involved, when one is.

    ``details``: ``fraction``, ``reason`` and ``joint``.
    """

    def __init__(self, fraction: float, reason: str, joint: str | None = None):
        self.fraction = fraction
        self.reason = reason
        self.joint = joint
        super().__init__(
            f"straight-line path planned to {fraction:.0%}, fails at s={fraction:.2f}: {reason}; "
            "nothing was moved. Try a joint-space move (without --linear), or a goal closer to "
            "the arm's workspace centre", {"fraction": fraction, "reason": reason, "joint": joint})


class DetourError(PlanningError):
    """No collision-free way from the start to the goal was found in the time allowed.

    Args:
        reason: What failed (no path within the budget, or a timed path that still collides).
        budget: The time allowed [s].
        elapsed: The time spent [s].
        planner: The planner's name.
        hint: How to get a plan (a sentence).

    ``details``: ``reason``, ``budget``, ``elapsed`` and ``planner``.
    """

    def __init__(self, reason: str, budget: float, elapsed: float, planner: str,
                 hint: str = ""):
        self.reason = reason
        self.budget = budget
        self.elapsed = elapsed
        self.planner = planner
        text = (f"no collision-free detour: {reason} ({planner}, {elapsed:.3f} s of "
                f"{budget:g} s); nothing was moved")
        if hint:
            text += f". {hint[:1].upper()}{hint[1:]}"
        super().__init__(text, {"reason": reason, "budget": budget, "elapsed": elapsed,
                                "planner": planner})
