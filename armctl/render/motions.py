"""Planned motions to draw: keyframe playback and straight-line moves, planned by armctl.motion.

Planning here is exactly what playing would do (same planner, limits and checks), but nothing is
sent to any servo: the result is only drawn.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from armctl.errors import NoSolutionError
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.motion import KeyframeProgram, MotionPlan
    from armctl.motion.playback import IKFunction

__all__ = ["PlannedLine", "plan_keyframes", "plan_straight_line", "sample_plan"]


def _ik_for(arm: Arm, program: KeyframeProgram, solver: str) -> IKFunction:
    """IK for pose keyframes: a full pose goal, or a position goal where orientation is free.

    Joints that do not move the keyframes' frame (a gripper) keep their seed value. The first
    call runs the solver once with a one-iteration budget first (as ``armctl ik`` does): the
    first call of a compiled solver loads its kernels, which would otherwise eat into the
    time budget of the first keyframe's solve.
    """
    from armctl.ik import IKOptions, PoseGoal, PositionGoal
    from armctl.ik.registry import solver_info

    frame = program.frame or None
    moving = set(arm.chain(frame))
    still = [k for i in range(len(arm.joint_names)) if i not in moving
             for k in range(arm.q_index(i).start, arm.q_index(i).stop)]

    warmed: list[bool] = []

    def ik(pose: Array, seed: Array, orientation: bool) -> Array:
        goal: Any = (PoseGoal(pose, frame=frame) if orientation
                     else PositionGoal(pose[:3, 3], frame=frame))
        if not warmed:  # load the compiled kernels outside the solve's time budget
            warmed.append(True)
            if solver_info(solver).capabilities.compiled:
                arm.ik(goal, q0=seed, solver=solver,
                       options=IKOptions(max_iterations=1, restarts=0, time_limit=1.0))
        res = arm.ik(goal, q0=seed, solver=solver)
        if not res.success:
            raise NoSolutionError(f"{res.status.value}: closest found is "
                                  f"{res.position_error * 1000:.1f} mm and "
                                  f"{np.degrees(res.rotation_error):.1f} deg away")
        q = np.array(res.q, dtype=float)
        q[still] = np.asarray(seed, dtype=float)[still]
        return q

    return ik


def plan_keyframes(arm: Arm, path: str | Path, q_start: npt.ArrayLike, solver: str = "auto",
                   speed: float = 1.0) -> MotionPlan:
    """Plan the playback of a keyframe file from ``q_start``, as ``armctl play`` would.

    Raises:
        ConfigError: For an invalid keyframe file.
        NoSolutionError, PlanningError: If the program cannot be planned.
    """
    from armctl.motion import MotionLimits, PlaybackOptions, load_keyframes, plan_program

    program = load_keyframes(path, arm)
    limits = MotionLimits.from_model(arm)
    return plan_program(program, arm, limits, arm.as_q(q_start, "start joints"),
                        PlaybackOptions(speed=speed), _ik_for(arm, program, solver))


@dataclass(frozen=True, eq=False)
class PlannedLine:
    """A planned straight-line move.

    Attributes:
        plan: The checked motion plan.
        samples: Joint values at the IK samples along the line ``(n + 1, nq)`` (ball joints
            as unit quaternions).
        line: Start and end of the line ``(2, 3)`` [m].
    """

    plan: MotionPlan
    samples: Array
    line: Array


def plan_straight_line(arm: Arm, q_start: npt.ArrayLike, goal_pose: npt.ArrayLike,
                       oriented: bool, solver: str = "auto", speed: float = 1.0) -> PlannedLine:
    """Plan a straight-line tool move from ``q_start`` to a goal, as ``move-to-pose --linear``.

    Args:
        arm: The arm.
        q_start: Start joint values ``(nq,)`` (ball joints as unit quaternions).
        goal_pose: ``(4, 4)`` goal of the tool frame.
        oriented: Whether the goal's orientation counts (else position only).
        solver: IK solver name.
        speed: Speed factor in (0, 1].

    Raises:
        PathError: If the line cannot be followed (with how far it got).
    """
    from armctl.ik import PoseGoal, PositionGoal
    from armctl.motion import MotionLimits, check_speed
    from armctl.motion.cartesian import LineOptions, SpherePathTrajectory, plan_line
    from armctl.motion.trajectory import PathTrajectory

    check_speed(speed)
    q0 = arm.as_q(q_start, "start joints")
    pose = np.asarray(goal_pose, dtype=float)
    goal: Any = PoseGoal(pose) if oriented else PositionGoal(pose[:3, 3])
    plan = plan_line(arm, q0, goal, MotionLimits.from_model(arm), speed,
                     LineOptions(solver=solver))
    traj = plan.trajectory
    if isinstance(traj, (PathTrajectory, SpherePathTrajectory)):
        # the joint path passes through the IK samples (at its breakpoints in s)
        samples = traj.path.sample_many(traj.path.breakpoints())[0]
    else:  # pragma: no cover - plan_line always builds one of the two
        samples = sample_plan(plan, 50.0)[1]
    line = np.vstack([arm.fk(q0)[:3, 3], pose[:3, 3]])
    return PlannedLine(plan, samples, line)


def sample_plan(plan: MotionPlan, rate: float) -> tuple[Array, Array]:
    """Times ``(n,)`` [s] and joint values ``(n, dof)`` of a plan, ``rate`` samples per second.

    The last sample is at the end of the plan.
    """
    ts = np.arange(0.0, plan.duration, 1.0 / rate)
    if ts.size == 0 or ts[-1] < plan.duration:
        ts = np.append(ts, plan.duration)
    return ts, plan.trajectory.sample_many(ts)[0]
