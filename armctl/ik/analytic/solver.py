"""The ``"analytic"`` entry of the IK solver registry.

It returns the valid closed-form solution nearest to the start configuration (with a
collision checker, ``options.avoid``: the nearest one that is also free of contact).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from armctl.config.schema import JointType
from armctl.errors import InputError
from armctl.ik.analytic.solve_all import IKSolutions, acceptance, ik_all
from armctl.ik.goals import Goal
from armctl.ik.options import IKOptions
from armctl.ik.result import IKResult, IKStatus, finish
from armctl.kinematics.model import KinematicModel

__all__ = ["solve"]


def solve(model: KinematicModel, goals: tuple[Goal, ...], q0: npt.NDArray[np.float64],
          options: IKOptions, constraints: Sequence[Any]) -> IKResult:
    """Solve in closed form and return the valid solution nearest to ``q0``.

    Args:
        model: The arm.
        goals: Exactly one goal (pose, position + direction, or position).
        q0: Start configuration: the solutions are ranked by distance to it, and redundant joints
            are held at its values.
        options: Only ``avoid`` is used (the closed form has no iterations or restarts): with
            a collision checker the nearest valid solution free of contact is returned, or,
            when every valid one collides, the one with the shallowest contact (status
            ``COLLIDES``).
        constraints: Must be empty.

    Returns:
        The result from :func:`armctl.ik.result.finish`: ``CONVERGED`` with the nearest valid
        solution; ``INFEASIBLE`` with the nearest solution when every one is outside the joint
        limits; ``UNREACHABLE`` with ``q0`` when there is none.

    Raises:
        InputError: For several goals or any constraint.
        NoDecompositionError: If the arm or the goal type has no closed form.
    """
    started = time.perf_counter()
    if constraints:
        raise InputError("the analytic solver takes no constraints; use solver 'nlp'")
    if len(goals) != 1:
        raise InputError(f"the analytic solver takes one goal, got {len(goals)}; use solver "
                         "'nlp' or 'dls' for several frames at once")
    goal = goals[0]
    sols = ik_all(model, goal, q_ref=q0, tol=acceptance(goal))
    note = "singular goal (a continuum of solutions; the nearest representative)" if (
        sols.singular) else ""
    best = sols.best
    distinct = sols.distinct([t is not JointType.PRISMATIC for t in model.joint_types])
    avoid = options.avoid
    if best is not None and avoid is not None:
        checked = distinct.checked(avoid)
        free = checked.q[checked.within_limits & checked.collision_free]
        inside = int(distinct.within_limits.sum())
        msg = (f"{inside} of {len(distinct)} distinct solutions inside the limits, "
               f"{len(free)} of them free of contact")
        if len(free):
            q, status = free[0], IKStatus.CONVERGED
        else:
            valid = [i for i in range(len(checked)) if checked.within_limits[i]]
            q = checked.q[min(valid, key=lambda i: _depth(checked, i))]
            status = IKStatus.COLLIDES
    elif best is not None:
        q, status = best, IKStatus.CONVERGED
        msg = (f"{int(distinct.within_limits.sum())} of {len(distinct)} distinct solutions "
               "inside the limits")
    elif len(sols):
        q, status = sols.q[0], IKStatus.INFEASIBLE
        msg = f"all {len(distinct)} distinct solutions are outside the joint limits"
    else:
        q, status = q0, IKStatus.UNREACHABLE
        msg = "no solution: the goal is out of reach"
    if note:
        msg = f"{msg}; {note}"
    return finish(model, goals, q, solver="analytic", status=status, iterations=0, restarts=0,
                  started=started, message=msg, start=q0, avoid=avoid)


def _depth(sols: IKSolutions, i: int) -> float:
    """How deep solution ``i`` is in contact [m] (0 when free)."""
    contacts = sols.contacts or ()
    c = contacts[i] if i < len(contacts) else None
    return 0.0 if c is None else c.depth
