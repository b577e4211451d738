"""The :class:`Arm`: an arm's kinematic model plus the solvers that work on it."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy.typing as npt

from armctl.config import load_spec
from armctl.config.schema import ArmSpec
from armctl.kinematics.model import KinematicModel

if TYPE_CHECKING:
    from armctl.collision.model import CollisionModel
    from armctl.ik import GoalLike, IKOptions, IKResult
    from armctl.ik.analytic import IKSolutions
    from armctl.ik.goals import Goal

__all__ = ["Arm", "load_arm"]

#: ``armctl.ik.solve``, imported on the first ``Arm.ik`` (an import statement in the method
#: would cost more than a solve's own Python code)
_IK_SOLVE: list[Any] = []


def _ik_solve() -> Any:
    from armctl.ik import solve

    _IK_SOLVE.append(solve)
    return solve


class Arm(KinematicModel):
    """An arm model: the kinematic tree, its limits and named frames.

    Build one with :func:`load_arm`. Everything is in SI units: joint values in [rad] (revolute,
    continuous) or [m] (prismatic), poses as ``(4, 4)`` transforms in [m].
    """

    @classmethod
    def from_spec(cls, spec: ArmSpec) -> Arm:
        """An arm from an already validated description."""
        return cls(spec)

    def ik(
        self,
        goal: GoalLike,
        q0: npt.ArrayLike | None = None,
        solver: str = "auto",
        *,
        options: IKOptions | None = None,
        constraints: Sequence[Any] = (),
        avoid: CollisionModel | None = None,
    ) -> IKResult:
        """Inverse kinematics: joint values that bring frames to goals.

        Args:
            goal: A ``(4, 4)`` tool pose, a goal object (:class:`armctl.ik.PositionGoal`,
                ``OrientationGoal``, ``DirectionGoal``, ``PoseGoal``, ``LookAtGoal``), or a
                sequence of them for several frames at once.
            q0: Starting joint vector [rad]/[m]; the middle of the joint ranges when ``None``.
            solver: Solver name, see :func:`armctl.ik.available_solvers`.
            options: Iteration and time budgets, restarts and RNG seed.
            constraints: Extra constraints for solvers that accept them (``"nlp"``).
            avoid: A collision checker (``CollisionModel.of(arm)``; overrides
                ``options.avoid``): answers in contact are discarded and the search restarts;
                ``None``: collisions are not checked (unless ``options.avoid`` is set).

        Returns:
            The result. ``result.success`` is True only if every goal is met within tolerance,
            ``result.q`` is inside the joint limits and (with a checker) free of contact;
            otherwise ``result.q`` is the closest configuration found and ``result.status``
            says why (``COLLIDES`` with ``result.contact`` when every answer found collides).

        Raises:
            UnsupportedGoalError: For goals or constraints the solver cannot take (its
                capabilities, :func:`armctl.ik.solver_info`); the message names those that can.
        """
        solve = _IK_SOLVE[0] if _IK_SOLVE else _ik_solve()
        return solve(self, goal, q0, solver, options=options, constraints=constraints,
                     avoid=avoid)

    def ik_all(
        self,
        pose: Goal | npt.ArrayLike,
        q_ref: npt.ArrayLike | None = None,
        frame: str | None = None,
        *,
        variants: bool = False,
        avoid: CollisionModel | None = None,
    ) -> IKSolutions:
        """Every distinct inverse kinematics solution of a goal, in closed form.

        Args:
            pose: A ``(4, 4)`` pose, or a :class:`armctl.ik.PoseGoal`, ``DirectionGoal`` or
                ``PositionGoal``.
            q_ref: Reference joint vector [rad]: solutions are sorted by distance to it and
                redundant joints are held at its values; the middle of the ranges when ``None``.
            frame: The frame a pose array is for (the tool frame when ``None``).
            variants: Also list every 2 pi variant of each solution that fits in the joint
                ranges (by default each solution is one row: its variant inside the limits
                nearest to ``q_ref``).
            avoid: A collision checker (``CollisionModel.of(arm)``): each solution is marked
                free or in contact (``contacts``, ``collision_free``), and ``valid`` and
                ``best`` keep the free ones only.

        Returns:
            The solutions, each marked inside or outside the joint limits, with its FK residual
            (and its contact when checked), and whether the goal is singular (see
            :class:`armctl.ik.analytic.IKSolutions`).

        Raises:
            NoDecompositionError: If the arm (or the goal type) has no closed form.
        """
        from armctl.ik.analytic import ik_all

        sols = ik_all(self, pose, q_ref, frame, variants=variants)
        return sols if avoid is None else sols.checked(avoid)


def load_arm(path: str | Path, tip: str | None = None) -> Arm:
    """Load an arm from armctl YAML, a URDF file, or the name of a bundled arm.

    Args:
        path: A ``.yaml``/``.urdf`` path, or a bundled name such as ``"so101"``.
        tip: URDF only: keep the chain from the root to this link and use it as the tool frame.

    Returns:
        The arm.

    Raises:
        ConfigError: If the file is missing or invalid; the message names the file, the key path
            and line, what was found and what is expected.
    """
    return Arm(load_spec(path, tip))
