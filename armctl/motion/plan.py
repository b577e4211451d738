"""A checked motion plan, and the joint-space move that every command builds on."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from armctl.motion.limits import MotionLimits, check_trajectory
from armctl.motion.multi_dof import geodesic_move
from armctl.motion.profiles import ruckig_move
from armctl.motion.trajectory import Trajectory
from armctl.typing import Array

__all__ = ["Event", "MotionPlan", "Waypoint", "plan_joint_move"]


@dataclass(frozen=True)
class Event:
    """Something that happens at a time along a plan (a gripper command, a keyframe reached).

    Attributes:
        time: When [s] from the start of the plan.
        kind: ``"keyframe"``, ``"gripper"`` or ``"dwell"``.
        name: The keyframe's name (may be empty).
        value: The gripper value [rad]/[m] or the dwell time [s]; ``None`` for keyframes.
    """

    time: float
    kind: str
    name: str = ""
    value: float | None = None


@dataclass(frozen=True)
class Waypoint:
    """A keyframe position the plan passes through, and when.

    Attributes:
        time: When [s].
        q: Joint values [rad]/[m].
        name: Keyframe name.
        stop: Whether the arm is at rest there.
    """

    time: float
    q: Array
    name: str = ""
    stop: bool = True


@dataclass(frozen=True)
class MotionPlan:
    """A trajectory that has been checked against the hard limits, ready to stream.

    Attributes:
        trajectory: The joint trajectory.
        limits: The hard limits it was checked against.
        events: Gripper and keyframe events, by time.
        waypoints: The keyframes it passes through.
        planning_time: Wall time spent planning and checking [s].
        samples_checked: How many samples were checked against the limits.
        description: One line saying what the plan does.
    """

    trajectory: Trajectory
    limits: MotionLimits
    events: tuple[Event, ...] = ()
    waypoints: tuple[Waypoint, ...] = ()
    planning_time: float = 0.0
    samples_checked: int = 0
    description: str = ""
    extra: dict[str, object] = field(default_factory=dict)

    @property
    def duration(self) -> float:
        """Length of the motion [s]."""
        return self.trajectory.duration

    @property
    def start(self) -> Array:
        """First joint vector."""
        return self.trajectory.start

    @property
    def goal(self) -> Array:
        """Last joint vector."""
        return self.trajectory.end

    def peak_ratios(self, dt: float = 0.005) -> tuple[float, float]:
        """Largest |velocity| / limit and |acceleration| / limit over the plan [-]."""
        n = max(2, int(self.duration / dt) + 1)
        _, qd, qdd = self.trajectory.sample_many(np.linspace(0.0, self.duration, n))
        vel, acc, _ = self.limits.rate_limits()
        return (float(np.max(np.abs(self.limits.rates(qd)) / vel, initial=0.0)),
                float(np.max(np.abs(self.limits.rates(qdd)) / acc, initial=0.0)))


def plan_joint_move(q0: npt.ArrayLike, q1: npt.ArrayLike, limits: MotionLimits,
                    speed: float = 1.0, description: str = "") -> MotionPlan:
    """A synchronised, time-optimal, jerk-limited joint move, checked before anything moves.

    All joints start and stop together and move along a straight line in joint space; a ball
    joint turns on the great circle (slerp), timed by its geodesic angle.

    Args:
        q0: Start joint values (the present position) ``(nq,)`` [rad]/[m] (a ball joint's
            unit quaternion ``w, x, y, z``).
        q1: Goal joint values.
        limits: The arm's hard limits.
        speed: Speed factor in (0, 1] applied to the velocity, acceleration and jerk limits.
        description: Text for the plan.

    Returns:
        The checked plan.

    Raises:
        LimitViolation: If the goal (or any sample) is outside the limits.
        InputError: For a speed factor outside (0, 1], or a ball joint's quaternion that is not
            of unit norm.
    """
    t0 = time.perf_counter()
    start = np.asarray(q0, dtype=float)
    goal = np.asarray(q1, dtype=float)
    if limits.layout is not None:  # a ball joint's quaternions must be unit (names the joint)
        from armctl.kinematics.joint_space import check_unit

        check_unit(start, limits.layout.balls, "start of the move")
        check_unit(goal, limits.layout.balls, "goal of the move")
    limits.check_position(goal, "goal of the move")
    if limits.layout is not None:
        traj: Trajectory = geodesic_move(start, goal, limits.scaled(speed))
    else:
        traj = ruckig_move(start, goal, limits.scaled(speed))
    n = check_trajectory(traj, limits, hint="lower the speed factor or check the limits")
    wps = (Waypoint(0.0, start, "start"), Waypoint(traj.duration, goal, "goal"))
    return MotionPlan(traj, limits, (), wps, time.perf_counter() - t0, n,
                      description or "joint move")
