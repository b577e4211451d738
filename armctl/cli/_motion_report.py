"""What the motion commands print: plans, streaming figures, where a move ended or stopped."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from armctl.cli._common import fmt, table

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.motion import MotionPlan
    from armctl.robot import MoveReport, Robot


def plan_data(robot: Robot, plan: MotionPlan) -> dict[str, Any]:
    vr, ar = plan.peak_ratios()
    return {"description": plan.description, "duration": plan.duration,
            "planning_time": plan.planning_time, "samples_checked": plan.samples_checked,
            "start": robot.arm.values_by_name(plan.start),
            "target": robot.arm.values_by_name(plan.goal),
            "peak_velocity_ratio": vr, "peak_acceleration_ratio": ar}

def shown(arm: Arm, i: int, value: float) -> tuple[str, str]:
    """A joint value for text output: degrees for rotary joints, millimetres for prismatic."""
    from armctl.config.schema import JointType

    if arm.joint_types[i] is JointType.PRISMATIC:
        return fmt(value * 1000.0, 2), "mm"
    return fmt(math.degrees(value), 2), "deg"

def plan_text(robot: Robot, plan: MotionPlan, head: str) -> str:
    arm = robot.arm
    rows = [[n, shown(arm, i, a)[0], *shown(arm, i, b)]
            for i, (n, a, b) in enumerate(zip(arm.joint_names, plan.start, plan.goal,
                                              strict=True))]
    vr, ar = plan.peak_ratios()
    return (f"{head}\nplan: {plan.description}, duration {plan.duration:.2f} s, planned in "
            f"{plan.planning_time * 1000:.1f} ms ({plan.samples_checked} samples checked; peak "
            f"velocity {vr:.0%}, acceleration {ar:.0%} of the limits)\n"
            + table(["joint", "from", "to", "unit"], rows, right=[1, 2]))

def stream_text(robot: Robot, report: MoveReport, idle: str | None = None
                 ) -> tuple[dict[str, Any], str]:
    """Streaming figures; ``idle`` is the message when the plan did not move the arm."""
    res = report.result
    if idle is not None:
        return {"moved": False, "nothing_to_do": True}, idle
    if res is None:
        return {"moved": False}, "dry run: nothing moved"
    s = res.stats
    data = {"moved": True, "final_joints": robot.arm.values_by_name(res.final),
            "loop_rate": s.achieved_rate, "jitter_p99": s.jitter_p99,
            "max_tracking_error": float(np.max(s.max_tracking_error, initial=0.0)),
            "settle_time": s.settle_time}
    text = (f"streamed {s.cycles} cycles at {s.achieved_rate:.1f} Hz (target {s.rate_hz:g}), "
            f"jitter p99 {s.jitter_p99 * 1000:.2f} ms, max tracking error "
            f"{math.degrees(float(np.max(s.max_tracking_error, initial=0.0))):.2f} deg")
    mapping = getattr(robot.bus, "mapping", None)
    names = {j.servo_id: j.name for j in mapping.joints} if mapping is not None else {}
    data["bus_retries"] = [{"servo_id": sid, "joint": names.get(sid), "count": n}
                           for sid, n in s.retries.items()]
    if s.retries:  # retries hide intermittent faults: never a silent success
        text += ("\nbus retries (replies missing, corrupt or late): " + ", ".join(
            f"servo {sid}" + (f" ({names[sid]})" if sid in names else "") + f" {n}"
            for sid, n in s.retries.items()))
    return data, text

def stop_text(robot: Robot, stopped: Any) -> str:
    """Where a stopped motion left the arm: joints (deg, mm) and the tool pose."""
    where = stopped.stopped_at
    head = f"stopped {stopped.time:.2f} s into the motion"
    if where is None:
        return head + "; the position could not be read back"
    arm = robot.arm
    joints = where["joints"]
    rows = [[n, *shown(arm, i, float(joints[n]))] for i, n in enumerate(arm.joint_names)]
    rpy = np.degrees(np.asarray(where["rpy"], dtype=float))
    return (f"{head}; the arm holds here (joints read back):\n"
            + table(["joint", "stopped at", "unit"], rows, right=[1]) + "\n"
            f"tool xyz {np.round(np.asarray(where['xyz'], dtype=float), 4).tolist()} m, rpy "
            f"{np.round(rpy, 1).tolist()} deg (FK of the joints read back)")

def reached_joints(robot: Robot, goal: np.ndarray, final: np.ndarray, reached: np.ndarray
                    ) -> tuple[dict[str, Any], str]:
    """The reached tool pose and the remaining error of a joint move (JSON fields, text).

    Args:
        robot: The robot.
        goal: The joint goal ``(dof,)`` [rad]/[m].
        final: The joints read back after the move ``(dof,)``.
        reached: FK of ``final`` (the tool) ``(4, 4)``.
    """
    from armctl.config.schema import JointRole
    from armctl.spatial import matrix_to_rpy

    arm = robot.arm
    aimed = arm.fk(goal)
    dp = float(np.linalg.norm(reached[:3, 3] - aimed[:3, 3]))
    cos = (float(np.trace(aimed[:3, :3].T @ reached[:3, :3])) - 1.0) / 2.0
    dr = math.acos(min(1.0, max(-1.0, cos)))
    err = np.asarray(final, dtype=float) - np.asarray(goal, dtype=float)
    rpy = matrix_to_rpy(reached[:3, :3])
    data = {"reached_xyz": reached[:3, 3], "reached_rpy": rpy, "position_error": dp,
            "rotation_error": dr, "joint_errors": arm.values_by_name(err)}
    arm_joints = [i for i, r in enumerate(arm.joint_roles) if r is not JointRole.GRIPPER]
    worst = max(arm_joints or range(arm.dof), key=lambda i: abs(err[i]))
    value, unit = shown(arm, worst, abs(float(err[worst])))
    text = (f"reached xyz {np.round(reached[:3, 3], 4).tolist()} m, rpy "
            f"{np.round(np.degrees(rpy), 1).tolist()} deg (FK of the joints read back)\n"
            f"remaining error: tool {dp * 1000:.2f} mm, {math.degrees(dr):.2f} deg; joints at "
            f"most {value} {unit} ({arm.joint_names[worst]})")
    return data, text
