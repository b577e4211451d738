"""The result every IK solver returns, and the one place that decides ``success``.

:func:`finish` also settles the statuses that need a look at the answer: ``FAILED`` for
non-finite joint values or goal errors, ``SINGULAR`` for a failed search that ended at a
singular configuration of its goals (:mod:`armctl.ik.singular`), ``COLLIDES`` for an answer
that meets every goal but brings a link into contact (when a collision checker is given). The
statuses are listed in ``docs/ik-goals.md``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.ik.goals import Goal
from armctl.ik.singular import SINGULAR_THRESHOLD, stuck_at_singularity
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.collision.contact import Contact
    from armctl.collision.model import CollisionModel

__all__ = ["CheckedConstraint", "ConstraintViolation", "GoalResidual", "IKResult", "IKStatus",
           "converged", "evaluate", "finish"]


class IKStatus(Enum):
    """How an IK solve ended; ``success`` holds exactly for ``CONVERGED``."""

    CONVERGED = "converged"  # every goal met within tolerance, inside the joint limits
    MAX_ITERATIONS = "max_iterations"  # iteration budget used up before convergence
    TIME_LIMIT = "time_limit"  # time budget used up before convergence
    UNREACHABLE = "unreachable"  # no solution: every start ended at a minimum of the error, or
    # the closed form has none; the closest q returned
    INFEASIBLE = "infeasible"  # constraints that cannot hold together; best compromise returned
    SINGULAR = "singular"  # a search that ended at a singular configuration of its goals
    # where the error still falls (armctl.ik.singular); that q returned
    FAILED = "failed"  # numerical failure: non-finite joint values or goal errors; the start
    # returned
    COLLIDES = "collides"  # every goal met inside the limits, but a link is in contact (a
    # collision checker was given); the answer found with the shallowest contact returned


@dataclass(frozen=True)
class GoalResidual:
    """How far one goal is from being met (a record of the result, not an exception).

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
class ConstraintViolation:
    """How far one constraint is from holding (a record of the result, not an exception).

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
        goal_errors: Per-goal residuals.
        within_limits: Whether ``q`` is inside the joint limits.
        time: Wall time of the solve [s].
        message: A human-readable summary.
        constraint_errors: Per-constraint violations (solvers that take constraints).
        contact: When a collision checker was given (``IKOptions.avoid``) and ``q`` collides:
            the deepest contact at ``q`` (pair, distance, depth); ``None`` otherwise.
    """

    q: Array
    success: bool
    status: IKStatus
    solver: str
    iterations: int
    restarts: int
    position_error: float
    rotation_error: float
    goal_errors: tuple[GoalResidual, ...]
    within_limits: bool
    time: float
    message: str = ""
    constraint_errors: tuple[ConstraintViolation, ...] = ()
    contact: Contact | None = None


class _OnFirstRead:
    """A field of :class:`IKResult` that a result built by :func:`converged` fills when read.

    :func:`converged` builds a result without running the dataclass ``__init__`` and leaves out
    the fields that cost more to build than the whole solve (the summary text and the per-goal
    records); the first read computes the value from the numbers kept in ``_pending`` and
    stores it in the instance, so the result reads, compares and prints as any other. Results
    built by ``__init__`` always hold every field and never reach this.
    """

    def __init__(self, name: str, default: object) -> None:
        self.name = name
        self.default = default

    def __get__(self, obj: object, owner: type | None = None) -> object:
        if obj is None:
            return self.default  # the class attribute, as the dataclass left it
        d = obj.__dict__
        if self.name not in d:
            _fill_pending(d)
        return d[self.name]


def _fill_pending(d: dict[str, Any]) -> None:
    """Compute the fields :func:`converged` left out, from ``d["_pending"]``."""
    tool, goals, errs, note = d["_pending"]
    solver, dp, dr = d["solver"], d["position_error"], d["rotation_error"]
    d.setdefault("goal_errors", tuple([
        GoalResidual(g.frame or tool, e[0], e[1], True) for g, e in zip(goals, errs, strict=True)]))
    d.setdefault("message", f"{solver}: converged; position error {dp:.3g} m, rotation error "
                            f"{dr:.3g} rad" + (f"; {note}" if note else ""))


IKResult.goal_errors = _OnFirstRead("goal_errors", None)  # type: ignore[assignment]
IKResult.message = _OnFirstRead("message", "")  # type: ignore[assignment]

_new = object.__new__
_set = object.__setattr__


def converged(tool: str, goals: tuple[Goal, ...], q: Array, errs: Sequence[Sequence[float]],
              position_error: float, rotation_error: float, *, solver: str, iterations: int,
              restarts: int, started: float, note: str = "") -> IKResult:
    """The result of an answer already checked to meet every goal inside the limits.

    For solvers whose compiled core checks its own answer the way :func:`finish` does (forward
    kinematics of ``q``, every goal's error within its tolerance, ``q`` finite and inside the
    limits with 1e-9 of slack; :func:`armctl.ik._engine.solve_checked`): the same result
    :func:`finish` would build, without checking again. Anything not checked that way goes
    through :func:`finish`.

    Args:
        tool: The arm's tool frame (the frame of goals that name none).
        goals: The goals.
        q: The answer ``(dof,)``; made read-only and kept (not copied).
        errs: Per goal, its position [m] and rotation [rad] error at ``q``.
        position_error: The largest position error [m].
        rotation_error: The largest rotation error [rad].
        solver: The solver's name.
        iterations: Iterations used.
        restarts: Restarts used.
        started: ``time.perf_counter()`` at the start of the solve.
        note: Extra text for the summary.
    """
    q.setflags(write=False)
    res = _new(IKResult)
    _set(res, "__dict__", {
        "q": q, "success": True, "status": IKStatus.CONVERGED, "solver": solver,
        "iterations": iterations, "restarts": restarts, "position_error": position_error,
        "rotation_error": rotation_error, "within_limits": True,
        "time": time.perf_counter() - started, "_pending": (tool, goals, errs, note)})
    # constraint_errors and contact: the class's defaults, () and None
    return res


def evaluate(model: KinematicModel, goals: tuple[Goal, ...],
             q: npt.ArrayLike) -> tuple[GoalResidual, ...]:
    """Per-goal errors of ``q`` by forward kinematics.

    Args:
        model: The arm.
        goals: The goals.
        q: Joint vector ``(dof,)``.

    Returns:
        One :class:`GoalResidual` per goal.
    """
    out = []
    for g in goals:
        frame = g.frame or model.tool
        dp, dr = g.errors(model.fk(q, frame))
        reached = dp <= g.tolerance.position and dr <= g.tolerance.rotation
        out.append(GoalResidual(frame, dp, dr, reached))
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
    start: npt.ArrayLike | None = None,
    search: bool = False,
    avoid: CollisionModel | None = None,
) -> IKResult:
    """Build the result, deciding ``success`` from FK and the joint limits.

    A solver passes the status it believes in; if the check disagrees (the solver said converged
    but a goal is not met or a limit is violated) the status becomes ``MAX_ITERATIONS``, and a
    failing status stays as given, except:

    * ``FAILED`` when ``q`` has a NaN or infinite value (``start`` is returned instead) or a goal
      error or constraint violation is not finite;
    * ``SINGULAR`` for a search (``search``) that reports ``UNREACHABLE`` or ``MAX_ITERATIONS``
      with a goal not reached, at a configuration that is singular for the goals (a singular
      value of the dimensionless goal Jacobian below
      :data:`armctl.ik.singular.SINGULAR_THRESHOLD`) where the error still falls along a lost
      direction (:func:`armctl.ik.singular.stuck_at_singularity`).

    A solver that reports anything but ``CONVERGED`` for a configuration that in fact meets every
    goal gets ``CONVERGED``, unless a collision checker is given and ``q`` collides: then
    ``COLLIDES``, and ``success`` is False.

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
        start: The solve's start ``(dof,)``, returned when ``q`` is not finite; the middle of
            the ranges when not given.
        search: Whether the solver searches iteratively from a start (and can get stuck at a
            singular configuration); a closed form's verdict is never changed to ``SINGULAR``.
        avoid: A collision checker; success also requires ``q`` to be free of contact, and
            the result names the contact at ``q`` when there is one.

    Returns:
        The result.
    """
    try:
        qa = np.array(model.as_q(q), dtype=float)
        finite = True
    except InputError:  # a wrong shape (a bug: raised again), or a NaN or infinite value
        if np.shape(q) != (model.nq,):
            raise
        qa = np.array(model.as_q(model.middle() if start is None else start), dtype=float)
        finite = False
    qa.setflags(write=False)
    errs = evaluate(model, goals, qa)
    inside = model.within_limits(qa)
    cerrs = []
    for c in constraints:
        v = float(c.violation(model, qa))
        cerrs.append(ConstraintViolation(c.describe(model), v, float(c.tolerance),
                                         bool(c.hard), v <= c.tolerance))
    reached = all([e.reached for e in errs])
    met = reached and all([e.satisfied for e in cerrs if e.hard])
    contact = avoid.contact(qa) if avoid is not None and finite else None
    success = met and inside and contact is None
    dp = max([e.position for e in errs])
    dr = max([e.rotation for e in errs])
    notes = [message] if message else []
    if success:
        status = IKStatus.CONVERGED
    elif met and inside and contact is not None and _finite(errs, cerrs):
        status = IKStatus.COLLIDES
        notes.append(f"collides: {contact.describe()}")
    elif not finite or not _finite(errs, cerrs):
        status = IKStatus.FAILED
        dp = math.nan if any(math.isnan(e.position) for e in errs) else dp  # max() may skip it
        dr = math.nan if any(math.isnan(e.rotation) for e in errs) else dr
        notes.insert(0, "numerical failure: " + (
            "a goal error or constraint violation is not finite" if finite else
            "the solver returned non-finite joint values; the start is returned"))
    elif status in (IKStatus.CONVERGED, IKStatus.COLLIDES):
        status = IKStatus.MAX_ITERATIONS
    elif (search and not reached
          and status in (IKStatus.UNREACHABLE, IKStatus.MAX_ITERATIONS)):
        sigma = stuck_at_singularity(model, goals, qa)
        if sigma is not None:
            status = IKStatus.SINGULAR
            notes.append(f"ended at a singular configuration (smallest singular value of the "
                         f"goal Jacobian {sigma:.2g} < {SINGULAR_THRESHOLD:g}); another start "
                         "or more restarts may reach the goal")
    summary = (f"{solver}: {status.value}; position error {dp:.3g} m, rotation error "
               f"{dr:.3g} rad{'' if inside else ', outside the joint limits'}")
    for note in notes:
        summary += f"; {note}"
    broken = [e for e in cerrs if e.hard and not e.satisfied]
    if broken:
        worst = max(broken, key=lambda e: e.violation)
        summary += (f"; {len(broken)} hard constraint(s) violated, worst {worst.name} by "
                    f"{worst.violation:.3g}")
    return IKResult(qa, success, status, solver, iterations, restarts, dp, dr, errs, inside,
                    time.perf_counter() - started, summary, tuple(cerrs), contact)


def _finite(errs: Sequence[GoalResidual], cerrs: Sequence[ConstraintViolation]) -> bool:
    """Whether every goal error and constraint violation is a finite number."""
    return all(math.isfinite(e.position) and math.isfinite(e.rotation) for e in errs) and all(
        math.isfinite(c.violation) for c in cerrs)
