"""The result every IK solver returns, and the one place that decides ``success``."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Protocol

import numpy as np
import numpy.typing as npt

from armctl.ik.goals import Goal
from armctl.kinematics.model import KinematicModel

__all__ = ["CheckedConstraint", "ConstraintError", "GoalError", "IKResult", "IKStatus", "evaluate",
           "finish"]

Array = npt.NDArray[np.float64]


class IKStatus(Enum):
    """How an IK solve ended."""

    CONVERGED = "converged"  # every goal met within tolerance, inside the joint limits
    MAX_ITERATIONS = "max_iterations"  # iteration budget used up before convergence
    TIME_LIMIT = "time_limit"  # time budget used up before convergence
    UNREACHABLE = "unreachable"  # the goal lies outside the reachable set; closest q returned
    INFEASIBLE = "infeasible"  # constraints that cannot hold together; best compromise returned
    SINGULAR = "singular"  # a singular goal; representatives returned
    FAILED = "failed"  # numerical failure inside the solver


@dataclass(frozen=True)
class GoalError:
    """How far one goal is from being met.

    Attributes:
        frame: The goal's frame.
        position: Position error [m].
        rotation: Rotation or direction error [rad].
        reached: Whether both are within the goal's tolerance.
    """

    frame: str
    position: float
    rotation: float
    reached: bool


class CheckedConstraint(Protocol):
    """What :func:`finish` needs from a constraint (see :mod:`armctl.ik.nlp.constraints`)."""

    @property
    def hard(self) -> bool:
        """Whether it must hold for success (else it is a weighted cost)."""
        ...

    @property
    def tolerance(self) -> float:
        """Largest violation that still counts as holding [m] or [rad]."""
        ...

    def violation(self, model: KinematicModel, q: npt.NDArray[np.float64]) -> float:
        """How far ``q`` is from satisfying it, by forward kinematics (0 when it holds)."""
        ...

    def describe(self, model: KinematicModel) -> str:
        """A short human-readable name."""
        ...


@dataclass(frozen=True)
class ConstraintError:
    """How far one constraint is from holding.

    Attributes:
        name: What the constraint is, e.g. ``"on plane (frame tool)"``.
        violation: Its violation [m] or [rad]; 0 when it holds.
        tolerance: The largest violation that counts as holding.
        hard: Whether success requires it.
        satisfied: Whether ``violation <= tolerance``.
    """

    name: str
    violation: float
    tolerance: float
    hard: bool
    satisfied: bool


@dataclass(frozen=True)
class IKResult:
    """The outcome of an IK solve.

    ``success`` is True only when every goal is met within its tolerance by the forward
    kinematics of ``q`` and ``q`` lies inside the joint limits; it is computed by :func:`finish`,
    never by the solver itself.

    Attributes:
        q: The joint vector found ``(dof,)`` [rad]/[m]: the solution, or the closest found.
        success: See above.
        status: How the solve ended.
        solver: The solver's registry name.
        iterations: Iterations used, summed over restarts.
        restarts: Restarts used beyond the first attempt.
        position_error: Largest position error over the goals [m].
        rotation_error: Largest rotation error over the goals [rad].
        goal_errors: Per-goal errors.
        within_limits: Whether ``q`` is inside the joint limits.
        time: Wall time of the solve [s].
        message: A human-readable summary.
        constraint_errors: Per-constraint violations (solvers that take constraints).
    """

    q: Array
    success: bool
    status: IKStatus
    solver: str
    iterations: int
    restarts: int
    position_error: float
    rotation_error: float
    goal_errors: tuple[GoalError, ...]
    within_limits: bool
    time: float
    message: str = ""
    constraint_errors: tuple[ConstraintError, ...] = ()


def evaluate(model: KinematicModel, goals: tuple[Goal, ...],
             q: npt.ArrayLike) -> tuple[GoalError, ...]:
    """Per-goal errors of ``q`` by forward kinematics.

    Args:
        model: The arm.
        goals: The goals.
        q: Joint vector ``(dof,)``.

    Returns:
        One :class:`GoalError` per goal.
    """
    out = []
    for g in goals:
        frame = g.frame or model.tool
        dp, dr = g.errors(model.fk(q, frame))
        reached = dp <= g.tolerance.position and dr <= g.tolerance.rotation
        out.append(GoalError(frame, dp, dr, reached))
    return tuple(out)


def finish(
    model: KinematicModel,
    goals: tuple[Goal, ...],
    q: npt.ArrayLike,
    *,
    solver: str,
    status: IKStatus,
    iterations: int,
    restarts: int,
    started: float,
    message: str = "",
    constraints: Sequence[CheckedConstraint] = (),
) -> IKResult:
    """Build the result, deciding ``success`` from FK and the joint limits.

    A solver passes the status it believes in; if the check disagrees (the solver said converged
    but a goal is not met or a limit is violated) the status becomes ``MAX_ITERATIONS``, and a
    failing status stays as given. A solver that reports anything but ``CONVERGED`` for a
    configuration that in fact meets every goal gets ``CONVERGED``.

    Args:
        model: The arm.
        goals: The goals.
        q: The joint vector found.
        solver: The solver's name.
        status: The solver's own verdict.
        iterations: Iterations used.
        restarts: Restarts used.
        started: ``time.perf_counter()`` at the start of the solve.
        message: Extra text for the summary.
        constraints: Constraints (:class:`CheckedConstraint`); success also requires every
            hard one to hold within its tolerance.

    Returns:
        The result.
    """
    qa = np.array(model.as_q(q), dtype=float)
    qa.setflags(write=False)
    errs = evaluate(model, goals, qa)
    inside = model.within_limits(qa)
    cerrs = []
    for c in constraints:
        v = float(c.violation(model, qa))
        cerrs.append(ConstraintError(c.describe(model), v, float(c.tolerance), bool(c.hard),
                                     v <= c.tolerance))
    met = all(e.reached for e in errs) and all(e.satisfied for e in cerrs if e.hard)
    success = met and inside
    if success:
        status = IKStatus.CONVERGED
    elif status is IKStatus.CONVERGED:
        status = IKStatus.MAX_ITERATIONS
    dp = max(e.position for e in errs)
    dr = max(e.rotation for e in errs)
    summary = (f"{solver}: {status.value}; position error {dp:.3g} m, rotation error "
               f"{dr:.3g} rad{'' if inside else ', outside the joint limits'}")
    if message:
        summary += f"; {message}"
    broken = [e for e in cerrs if e.hard and not e.satisfied]
    if broken:
        worst = max(broken, key=lambda e: e.violation)
        summary += (f"; {len(broken)} hard constraint(s) violated, worst {worst.name} by "
                    f"{worst.violation:.3g}")
    return IKResult(qa, success, status, solver, iterations, restarts, dp, dr, errs, inside,
                    time.perf_counter() - started, summary, tuple(cerrs))
