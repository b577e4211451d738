"""Teaching keyframes: hand-guiding with torque off, jogging with torque on, continuous recording.

The keyframe file is rewritten atomically after every keyframe, so a crash or Ctrl-C loses
nothing that was recorded. Torque comes back on holding the present pose (goal = present
position first), so the arm never jumps to a stale goal; while joints are limp nothing writes goal
positions (on the STS3215 a goal write switches torque back on).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.motion import AngleUnit, Keyframe, KeyframeProgram, save_keyframes
from armctl.robot.session import MoveReport, Robot

__all__ = ["TeachSession"]

Array = npt.NDArray[np.float64]


class TeachSession:
    """Record a keyframe program on a robot.

    Args:
        robot: The open robot.
        path: The keyframe file to write (created at :meth:`start`).
        release: Joints whose torque goes off for hand-guiding; ``None``: every arm joint
            (grippers stay stiff).
        angle_unit: Unit of angles in the file.
        description: Text stored in the file.
    """

    def __init__(self, robot: Robot, path: str | Path, release: Sequence[str] | None = None,
                 angle_unit: AngleUnit = AngleUnit.RAD, description: str = ""):
        self.robot = robot
        self.path = Path(path)
        grippers = set(robot.gripper_joints)
        on_bus = robot.bus.joint_names
        self.joints = tuple(n for n in robot.arm.joint_names if n not in grippers)
        if release is None:
            release = [n for n in on_bus if n not in grippers]
        for name in release:
            if name not in on_bus:
                from armctl.errors import UnknownNameError

                raise UnknownNameError("joint with a servo", name, on_bus,
                                       f"arm {robot.arm.name!r}")
        self.release = tuple(release)
        self.program = KeyframeProgram(robot.arm.name, self.joints, (),
                                       robot.calibration_hash(), angle_unit=angle_unit,
                                       description=description)
        self.limp = False
        self._t0: float | None = None
        self._lock = threading.Lock()

    # ---- file -------------------------------------------------------------------------------
    def _save(self) -> None:
        save_keyframes(self.program, self.path, self.robot.arm)

    def start(self, limp: bool = True) -> None:
        """Write the (empty) file and release the chosen joints for hand-guiding."""
        self._save()
        if limp:
            self.set_limp(True)

    def set_limp(self, limp: bool) -> None:
        """Torque off for the released joints, or back on holding the present pose."""
        if limp:
            self.robot.bus.set_torque(False, self.release)
        else:
            self.robot.hold()
        self.limp = limp

    # ---- recording ----------------------------------------------------------------------------
    def record(self, name: str = "", dwell: float = 0.0, gripper: float | None = None,
               with_gripper: bool = False) -> Keyframe:
        """Record the present pose as a keyframe and save the file.

        Args:
            name: Keyframe name.
            dwell: Time to stay there on playback [s].
            gripper: Gripper value to command there [rad]/[m].
            with_gripper: Record the gripper's present position as its value.

        Returns:
            The keyframe.
        """
        q = self.robot.joints()
        if with_gripper and gripper is None and self.robot.gripper_joints:
            gripper = float(q[self.robot.arm.joint_index(self.robot.gripper_joints[0])])
        if gripper is not None and not self.robot.gripper_joints:
            raise InputError(f"arm {self.robot.arm.name!r} has no gripper joint")
        values = tuple(float(q[self.robot.arm.joint_index(n)]) for n in self.joints)
        kf = Keyframe(q=values, name=name, dwell=dwell, gripper=gripper)
        with self._lock:
            self.program = self.program.append(kf)
            self._save()
        return kf

    def undo(self) -> Keyframe | None:
        """Remove the last keyframe (and save)."""
        with self._lock:
            if not self.program.keyframes:
                return None
            last = self.program.keyframes[-1]
            self.program = replace(self.program, keyframes=self.program.keyframes[:-1])
            self._save()
            return last

    def record_continuous(self, rate_hz: float, stop: threading.Event,
                          duration: float | None = None, save_every: float = 0.25) -> int:
        """Sample the pose at a fixed rate with time stamps until ``stop`` is set.

        The file is rewritten with the new samples at least every ``save_every`` seconds (and
        at the end), so a crash loses at most that much of a continuous recording. Time stamps
        are the measured sampling times and continue from earlier recordings.

        Args:
            rate_hz: Sampling rate [Hz] (1 to 100).
            stop: Set it to end the recording.
            duration: Also end after this long [s].
            save_every: Longest time between two saves [s].

        Returns:
            The number of samples recorded.
        """
        if not 1.0 <= rate_hz <= 100.0:
            raise InputError(f"recording rate {rate_hz} Hz is outside 1 to 100 Hz")
        dt = 1.0 / rate_hz
        last = [kf.time for kf in self.program.keyframes if kf.time is not None]
        offset = (last[-1] + dt) if last else 0.0
        t0 = last_save = time.perf_counter()
        k = n = 0
        try:
            while not stop.is_set():
                deadline = t0 + k * dt
                if duration is not None and k * dt > duration + 1e-9:
                    break
                now = time.perf_counter()
                if now < deadline and stop.wait(deadline - now):
                    break
                t_sample = time.perf_counter() - t0
                q = self.robot.joints()
                values = tuple(float(q[self.robot.arm.joint_index(n)]) for n in self.joints)
                with self._lock:
                    self.program = self.program.append(
                        Keyframe(q=values, time=round(offset + t_sample, 4)))
                    if time.perf_counter() - last_save >= save_every:
                        self._save()
                        last_save = time.perf_counter()
                n += 1
                k = max(k + 1, int((time.perf_counter() - t0) / dt))  # no bursts after a delay
        finally:
            with self._lock:
                self._save()
        return n

    # ---- jogging ------------------------------------------------------------------------------
    def jog_joint(self, joint: str, delta: float, speed: float = 0.3) -> MoveReport:
        """Move one joint by ``delta`` [rad]/[m] (torque comes on first, holding the pose)."""
        if self.limp:
            self.set_limp(False)
        q = self.robot.joints()
        q[self.robot.arm.joint_index(joint)] += delta
        return self.robot.move_joints(q, speed)

    def jog_cartesian(self, delta_xyz: npt.ArrayLike, speed: float = 0.3,
                      solver: str = "auto") -> MoveReport:
        """Move the tool by ``delta_xyz`` [m] in the base frame along a straight line."""
        from armctl.ik import PositionGoal

        if self.limp:
            self.set_limp(False)
        target = self.robot.pose()[:3, 3] + np.asarray(delta_xyz, dtype=float)
        return self.robot.move_to_pose(PositionGoal(target), linear=True, speed=speed,
                                       solver=solver)

    def finish(self) -> KeyframeProgram:
        """Torque back on, holding the present pose; the file is already saved."""
        self.set_limp(False)
        return self.program
