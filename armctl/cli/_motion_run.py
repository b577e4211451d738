"""Running a motion command: open the robot, move, close it with the right exit policy."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

import numpy as np

from armctl.cli._progress import Progress

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.motion import MotionPlan
    from armctl.robot import Robot

#: A plan shorter than this [s] does not move the arm.
_STILL_TIME = 1e-6

#: Start and goal closer than this [rad]/[m] are the same position.
_STILL_GAP = 1e-6


def open_robot(args: argparse.Namespace, arm: Arm, hold: bool = False) -> Robot:
    """Open the arm's robot (and its bus), with the command's exit policy (default: hold).

    Without ``hold`` nothing is written to the servos until the first motion (which holds the
    present pose first), so a plan is checked against the effective limits before torque comes
    on, and a dry run never switches torque on. With ``--exit-policy park`` the park pose is
    checked against the config's limits before the bus opens and against the effective limits
    right after, before anything moves. ``--port PORT`` and ``--sim`` choose the bus (see
    :mod:`armctl.cli._bus_choice`); ``--scene FILE`` the scene plans are checked against (see
    :mod:`armctl.cli._scene`).

    Raises:
        ConfigError: A bad ``--scene`` file.
        InputError: ``--exit-policy park`` for an arm without a 'park' pose; ``--port`` for a
            config without a ``bus:`` section.
        JointLimitError: A 'park' pose outside the config's or the effective limits.
    """
    from armctl.cli import _checks
    from armctl.cli._bus_choice import arm_on_chosen_bus
    from armctl.cli._scene import scene_arg
    from armctl.config.motion import ExitPolicy
    from armctl.robot import Robot

    scene = scene_arg(args, arm)  # --scene FILE, read before the bus opens
    arm = arm_on_chosen_bus(args, arm)  # --port PORT / --sim
    policy = ExitPolicy(getattr(args, "exit_policy", None) or "hold")
    if policy is ExitPolicy.PARK:
        _checks.check_park_pose(arm)
    speed = getattr(args, "speed", None)
    robot = Robot.open(arm, speed=speed if speed is not None and speed <= 1 else None,
                       exit_policy=policy, hold=hold, scene=scene)
    try:
        if policy is ExitPolicy.PARK:
            robot.effective.check(robot.arm.named_pose("park"),
                                  "the 'park' pose of --exit-policy park")
    except BaseException:
        robot.close_holding("the park pose was refused")
        raise
    if robot.simulated and not getattr(args, "json", False):
        print(f"--- SIMULATED BUS: arm {robot.arm.name!r}, no hardware ---", file=sys.stderr)
    return robot


def run_motion(args: argparse.Namespace, fn: Any, arm: Arm) -> Any:
    """Open the robot, run ``fn(robot, progress)`` and close.

    The exit policy applies only when the command ends normally after a real run: a dry run
    writes nothing at all; a stop, an error or a signal holds the arm where it is. With a
    terminal on stdin, keys pause, resume and change the speed of the motions meanwhile
    (:mod:`armctl.cli._motion_keys`).
    """
    from armctl.cli._motion_keys import MotionKeys
    from armctl.config.motion import ExitPolicy
    from armctl.robot import MotionStopped

    log_path = getattr(args, "log", None)
    if log_path is not None:
        from armctl.robot.motion_log import check_log_target

        check_log_target(log_path)  # before anything moves
    robot = open_robot(args, arm)
    dry = getattr(args, "dry_run", False)
    progress = Progress(not args.json and not dry)
    recorder = _CycleRecorder(robot, log_path) if log_path is not None and not dry else None
    try:
        with MotionKeys(robot.control, enabled=not dry, announce=not args.json):
            result = fn(robot, progress)
        progress.done()
        if recorder is not None:
            recorder.write(quiet=args.json)
    except BaseException as exc:
        progress.done()
        if recorder is not None:
            recorder.write_after_failure()
        if isinstance(exc, MotionStopped) and not args.json:
            from armctl.cli import _motion_report

            print(_motion_report.stop_text(robot, exc), flush=True)
        robot.close_holding("the motion was stopped" if isinstance(exc, MotionStopped)
                            else "the command failed")
        raise
    guard = getattr(args, "signal_guard", None)
    if dry:  # nothing was written to the servos, and nothing will be
        if robot.exit_policy is not ExitPolicy.HOLD:
            print(f"armctl: dry run: --exit-policy {robot.exit_policy.value} not applied "
                  "(nothing was written to the servos)", file=sys.stderr)
        robot.close(ExitPolicy.HOLD)
    elif guard is not None and guard.signalled:  # a signal after the motion: no exit policy
        robot.close_holding("signal received")
    else:
        close_with_policy(robot)
    return robot, result


def close_with_policy(robot: Robot) -> None:
    """Close the robot with its exit policy, saying on stderr what a park or release does.

    Parking is a motion of its own after the command's, and releasing torque lets a raised arm
    fall: both are said before they happen.
    """
    from armctl.config.motion import ExitPolicy

    policy = robot.exit_policy
    if policy is ExitPolicy.PARK and not robot.control.paused:
        print("armctl: exit policy park: moving on to the 'park' pose (the report is of the "
              "motion before it)", file=sys.stderr, flush=True)
    elif policy is ExitPolicy.RELEASE:
        print("armctl: exit policy release: torque off (a raised arm falls)", file=sys.stderr,
              flush=True)
    robot.close()


class _CycleRecorder:
    """Collect the cycles of every motion a command streams, one time axis for all.

    The robot hands over the cycles of every motion it streams (``Robot.on_motion_cycles``),
    also when a motion ends in a stop or a failure.
    """

    def __init__(self, robot: Robot, path: str) -> None:
        self.robot = robot
        self.path = path
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        robot.on_motion_cycles = self._take

    def _take(self, cycles: tuple[list[float], list[Any], list[Any]]) -> None:
        t, cmd, meas = cycles
        if t:
            self.parts.append((np.array(t), np.array(cmd), np.array(meas)))

    def log(self) -> Any:
        """The cycles so far as a :class:`~armctl.robot.motion_log.MotionLog`."""
        from armctl.config.schema import JointType
        from armctl.robot.motion_log import MotionLog

        ex = self.robot.executor
        arm = self.robot.arm
        n = len(ex.idx)
        times, cmds, meass = [], [], []
        offset = 0.0
        for t, cmd, meas in self.parts:
            times.append(t + offset)
            cmds.append(cmd.reshape(-1, n))
            meass.append(meas.reshape(-1, n))
            offset = float(times[-1][-1]) + 1.0 / ex.rate_hz
        return MotionLog(
            arm.name, ex.rate_hz, tuple(arm.joint_names[i] for i in ex.idx),
            tuple(arm.joint_types[i] is JointType.PRISMATIC for i in ex.idx),
            np.concatenate(times) if times else np.zeros(0),
            np.concatenate(cmds) if cmds else np.zeros((0, n)),
            np.concatenate(meass) if meass else np.zeros((0, n)))

    def write(self, quiet: bool) -> None:
        """Write the log (atomically) and say so on stderr."""
        from armctl.robot.motion_log import write_log

        path, log = self.path, self.log()
        if log.t.size == 0:
            print(f"armctl: motion log: no cycle was streamed; {path} was not written",
                  file=sys.stderr)
            return
        write_log(path, log)
        if not quiet:
            print(f"armctl: motion log: {log.t.size} cycles written to {path}", file=sys.stderr)

    def write_after_failure(self) -> None:
        """Write the cycles that ran before a stop or a failure; never mask the failure."""
        from armctl.errors import ArmctlError

        try:
            self.write(quiet=False)
        except ArmctlError as exc:
            print(f"armctl: the motion log was not written: {exc}", file=sys.stderr)


def nothing_to_do(plan: MotionPlan, endpoints: bool = True,
                   still: float | np.ndarray = _STILL_GAP) -> bool:
    """Whether a plan does not move the arm (zero duration, or start = goal without events).

    ``still``: start and goal closer than this on every joint are the same position [rad]/[m]
    (a scalar or ``(dof,)``, e.g. one servo tick).
    """
    if plan.duration < _STILL_TIME:
        return True
    gap = np.abs(plan.goal - plan.start)
    return endpoints and not plan.events and bool(np.all(gap < still))

def one_tick(robot: Robot) -> np.ndarray:
    """One servo tick of every joint in joint units ``(dof,)`` [rad]/[m] (at least 1e-6)."""
    eff = robot.effective
    tick = {j.name: j.margin / max(eff.margin_ticks, 1) for j in eff.joints}
    return np.maximum([tick.get(n, 0.0) for n in robot.arm.joint_names], _STILL_GAP)
