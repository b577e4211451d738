"""The error for a goal that IK cannot reach: the closest configuration found, and advice."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from armctl.ik.errors import IKFailedError

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.ik import Goal, IKResult

__all__ = ["unreachable"]


def unreachable(arm: Arm, goal: Goal, res: IKResult, why: str, *, bus_opened: bool = True,
                note: str = "") -> IKFailedError:
    """The error for ``goal``, which ``res`` (a failed solve) did not reach.

    Args:
        arm: The arm that was solved for.
        goal: The goal.
        res: The solver's result (its closest configuration).
        why: What makes it unreachable, e.g. the solver's status or the reach bound.
        bus_opened: Whether the bus had been opened (the message says so when not).
        note: A sentence to add to the advice.

    Returns:
        An :class:`IKFailedError` (exit code 3) whose ``details`` hold the solver's status, the
        closest joints (``closest_q``, ``closest_joints``), their tool position
        (``closest_xyz`` [m]), the remaining errors ([m], [rad]) and the joints that do not
        move the goal frame (``not_involved``: they keep the solver's start value).
    """
    advice = "Check the goal is inside the arm's reach"
    if goal.has_rotation:
        advice += ", or give fewer orientation constraints"
    advice += "." + (f" {note}" if note else "")
    details = {"status": res.status.value, "solver": res.solver,
               "closest_q": np.asarray(res.q, dtype=float),
               "closest_joints": arm.values_by_name(res.q),
               "position_error": res.position_error, "rotation_error": res.rotation_error,
               "closest_xyz": arm.fk(res.q, goal.frame)[:3, 3],
               "not_involved": [n for i, n in enumerate(arm.joint_names)
                                if i not in set(arm.chain(goal.frame))]}
    where = "" if bus_opened else " (the bus was not opened)"
    away = f"{res.position_error * 1000:.1f} mm" + (
        f" and {np.degrees(res.rotation_error):.1f} deg" if goal.has_rotation else "")
    return IKFailedError(
        res, f"the goal cannot be reached ({why}): closest found is {away} away "
        f"(solver {res.solver}); nothing was moved{where}. {advice}", details)
