"""Teaching keyframes: hand-guiding with torque off, jogging with torque on, continuous recording.

The keyframe file is rewritten atomically after every keyframe, so a crash or Ctrl-C loses
nothing that was recorded. Torque comes back on holding the present pose (goal = present
position first), so the arm never jumps to a stale goal; while joints are limp nothing writes goal
positions (on the STS3215 a goal write switches torque back on).
"""

from __future__ import annotations

import math
import threading
from collections.abc import Sequence
from dataclasses import replace
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from armctl.clock import Clock
from armctl.config.schema import JointRole, JointType
from armctl.errors import ConfigError, InputError
from armctl.motion import AngleUnit, Keyframe, KeyframeProgram, load_keyframes, save_keyframes
from armctl.robot.session import MoveReport, Robot

if TYPE_CHECKING:
    from armctl.arm import Arm

__all__ = ["ExistingFile", "TeachSession", "appendable", "check_output", "load_for_append",
           "taught_joints"]


class ExistingFile(Enum):
    """What a teach session does with a keyframe file that exists already."""

    REFUSE = "refuse"
    """Refuse to start (nothing is overwritten)."""
    OVERWRITE = "overwrite"
    """Replace it with the new recording."""
    APPEND = "append"
    """Add the new keyframes after the file's own (same arm and joints; its units are kept)."""


def check_output(path: str | Path, existing: ExistingFile, can_append: bool = True) -> Path:
    """Check that a teach session may write ``path``, before anything is opened.

    ``can_append``: whether the caller offers appending (the refusal names only what it offers).

    Raises:
        InputError: If the file exists and ``existing`` is :attr:`ExistingFile.REFUSE`, if the
            path is an arm config or a folder, if its name does not end in ``.yaml`` or
            ``.yml``, or if its folder is missing.
    """
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p} is a folder; give the keyframe file to write "
                         f"(e.g. {p / 'pick.yaml'})")
    if p.suffix.lower() not in (".yaml", ".yml"):
        raise InputError(f"{p}: a keyframe file is YAML: give a name ending in .yaml (e.g. "
                         f"{p.with_suffix('.yaml')})")
    folder = p.parent if str(p.parent) else Path()
    if not folder.is_dir():
        raise InputError(f"cannot write {p}: the folder {folder} does not exist; create it first")
    if not p.exists():
        return p
    if _is_arm_config(p):
        raise InputError(f"{p} is an arm config (armctl YAML or URDF), not a keyframe file; "
                         "teaching would replace it: choose another file name for the keyframes")
    if existing is ExistingFile.REFUSE:
        how = ("pass --append to add to its keyframes, --force to overwrite it"
               if can_append else "pass --force to overwrite it")
        raise InputError(f"{p} exists already: {how}, or choose another name")
    return p


def taught_joints(arm: Arm) -> tuple[str, ...]:
    """The joints whose values a teach session records: every joint but the grippers."""
    return tuple(n for n, r in zip(arm.joint_names, arm.joint_roles, strict=True)
                 if r is not JointRole.GRIPPER)


def appendable(old: KeyframeProgram, arm: Arm, path: str | Path,
               calibration: str | None = None) -> KeyframeProgram:
    """A keyframe file's program, checked so that a teach session can add to it.

    :func:`armctl.motion.load_keyframes` has checked the arm's name; the file keeps its units.

    Args:
        old: The program read from the file.
        arm: The arm being taught.
        path: The file, for messages.
        calibration: Hash of the calibration in use, if known.

    Raises:
        InputError: If it lists other joints or was taught with another calibration.
    """
    joints = taught_joints(arm)
    if old.joints != joints:
        raise InputError(
            f"cannot append to {path}: it lists the joints {', '.join(old.joints)}; a teach "
            f"session records {', '.join(joints)}; use a new file")
    if old.calibration and calibration and old.calibration != calibration:
        raise InputError(
            f"cannot append to {path}: it was taught with calibration {old.calibration}, the "
            f"arm now uses {calibration}; the joint values would not match. Use a new file")
    return replace(old, calibration=old.calibration or calibration)


def load_for_append(path: str | Path, arm: Arm) -> KeyframeProgram:
    """Read a keyframe file that a teach session of ``arm`` is to add to.

    Raises:
        ConfigError: As :func:`armctl.motion.load_keyframes`; a file of another arm says to
            teach into a new file.
    """
    try:
        return load_keyframes(path, arm)
    except ConfigError as exc:
        if exc.where.keys != ("arm",):
            raise
        raise ConfigError(exc.problem, exc.where,
                          f"teach {arm.name!r} into a new file (without --append); change "
                          "'arm:' only if the arms are the same") from None


def _is_arm_config(path: Path) -> bool:
    """Whether ``path`` is an armctl arm YAML (top-level ``armctl:`` key) or a URDF."""
    if path.suffix.lower() == ".urdf":
        return True
    try:
        with path.open(encoding="utf-8", errors="replace") as fh:
            head = fh.read(65536)
    except OSError:
        return False
    return any(line.startswith("armctl:") for line in head.splitlines()) or (
        head.lstrip().startswith("<?xml") and "<robot" in head)


class TeachSession:
    """Record a keyframe program on a robot.

    Args:
        robot: The open robot.
        path: The keyframe file to write (created at :meth:`start`).
        release: Joints whose torque goes off for hand-guiding; ``None``: every arm joint
            (grippers stay stiff).
        angle_unit: Unit of angles in a new file (an appended file keeps its units).
        description: Text stored in a new file.
        existing: What to do when the file exists already (default: refuse).
        clock: Time base of continuous recording (default: the robot's clock).

    Raises:
        InputError: For an existing file without ``existing``, or one that cannot be appended
            to (another arm, other joints, another calibration).
    """

    def __init__(self, robot: Robot, path: str | Path, release: Sequence[str] | None = None,
                 angle_unit: AngleUnit = AngleUnit.RAD, description: str = "",
                 existing: ExistingFile = ExistingFile.REFUSE, clock: Clock | None = None):
        self.robot = robot
        self.clock: Clock = clock if clock is not None else robot.clock
        self.path = check_output(path, existing)
        grippers = set(robot.gripper_joints)
        on_bus = robot.bus.joint_names
        self.joints = taught_joints(robot.arm)
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
        if existing is ExistingFile.APPEND and self.path.exists():
            self.program = appendable(load_for_append(self.path, robot.arm), robot.arm,
                                      self.path, self.program.calibration)
        self.limp = False
        self._t0: float | None = None
        self._lock = threading.Lock()
        #: Whether the file holds keyframes that must be kept when none are added (appending).
        self._keep_empty = existing is ExistingFile.APPEND and self.path.exists()
        #: Whether this session has written the file.
        self.written = False

    # ---- file -------------------------------------------------------------------------------
    def _save(self) -> None:
        save_keyframes(self.program, self.path, self.robot.arm)
        self.written = True

    def start(self, limp: bool = True) -> None:
        """Release the chosen joints for hand-guiding.

        The file is written with the first keyframe (an existing file is untouched until
        then), and after every change.
        """
        if limp:
            self.set_limp(True)

    def set_limp(self, limp: bool) -> None:
        """Torque off for the released joints, or back on holding the present pose."""
        if limp:
            self.robot.bus.set_torque(False, self.release)
            if self.robot.live is not None:  # watchers: off for all, or some on (unknown)
                everyone = set(self.release) >= set(self.robot.bus.joint_names)
                self.robot.live.torque = False if everyone else None
        else:
            self.robot.hold()
        self.limp = limp

    # ---- recording ----------------------------------------------------------------------------
    def record(self, name: str = "", dwell: float = 0.0, gripper: float | None = None,
               with_gripper: bool = False, at: npt.ArrayLike | None = None) -> Keyframe:
        """Record the present pose as a keyframe and save the file.

        Args:
            name: Keyframe name.
            dwell: Time to stay there on playback [s].
            gripper: Gripper value to command there [rad]/[m].
            with_gripper: Record the gripper's present position as its value.
            at: Joint values ``(dof,)`` [rad]/[m] to record instead of the present ones (e.g.
                the goal a jogged arm holds, which its servos settle within a tick of).

        Returns:
            The keyframe.
        """
        if not (math.isfinite(dwell) and dwell >= 0):
            raise InputError(f"dwell must be a time of 0 s or more, got {dwell}")
        if gripper is not None:
            self._check_gripper(gripper)
        q = self.robot.joints() if at is None else self.robot.arm.as_q(at, "keyframe joints")
        if with_gripper and gripper is None and self.robot.gripper_joints:
            gripper = float(q[self.robot.arm.joint_index(self.robot.gripper_joints[0])])
        values = tuple(float(q[self.robot.arm.joint_index(n)]) for n in self.joints)
        kf = Keyframe(q=values, name=name, dwell=dwell, gripper=gripper)
        with self._lock:
            self.program = self.program.append(kf)
            self._save()
        return kf

    def _check_gripper(self, value: float) -> None:
        """Refuse a gripper value [rad]/[m] that the gripper joints cannot take.

        Raises:
            InputError: Without a gripper joint, for NaN/inf, or outside a gripper's limits
                (saying when the value looks like degrees or millimetres).
        """
        arm = self.robot.arm
        if not self.robot.gripper_joints:
            raise InputError(f"arm {arm.name!r} has no gripper joint")
        if not math.isfinite(value):
            raise InputError(f"gripper value {value} is not a finite number")
        for name in self.robot.gripper_joints:
            i = arm.joint_index(name)
            lo, hi = float(arm.lower[i]), float(arm.upper[i])
            if lo - 1e-9 <= value <= hi + 1e-9:
                continue
            prismatic = arm.joint_types[i] is JointType.PRISMATIC
            unit = "m" if prismatic else "rad"
            hint = ""
            if prismatic and lo <= value / 1000 <= hi:
                hint = f"; gripper values are in metres: did you mean {value / 1000:g} m?"
            elif not prismatic and lo <= math.radians(value) <= hi:
                hint = (f"; gripper values are in radians: did you mean {math.radians(value):.4g}"
                        f" rad ({value:g} deg)?")
            raise InputError(f"gripper value {value:g} {unit} is outside the limits of joint "
                             f"{name!r} [{lo:.6g}, {hi:.6g}] {unit}{hint}")

    def undo(self) -> Keyframe | None:
        """Remove the last keyframe (and save)."""
        with self._lock:
            if not self.program.keyframes:
                return None
            last = self.program.keyframes[-1]
            self.program = replace(self.program, keyframes=self.program.keyframes[:-1])
            self._save()
            return last

    @staticmethod
    def check_recording(rate_hz: float, duration: float | None = None) -> None:
        """Refuse a continuous recording's rate [Hz] outside 1 to 100 or a duration [s] <= 0.

        Raises:
            InputError: Saying the valid range.
        """
        if not 1.0 <= rate_hz <= 100.0:
            raise InputError(f"recording rate {rate_hz:g} Hz is outside 1 to 100 Hz")
        if duration is not None and not (math.isfinite(duration) and duration > 0):
            raise InputError(f"recording duration {duration:g} s must be more than 0 s")

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
        self.check_recording(rate_hz, duration)
        dt = 1.0 / rate_hz
        last = [kf.time for kf in self.program.keyframes if kf.time is not None]
        offset = (last[-1] + dt) if last else 0.0
        clock = self.clock
        t0 = last_save = clock.now()
        k = n = 0
        try:
            while not stop.is_set():
                deadline = t0 + k * dt
                if duration is not None and k * dt > duration + 1e-9:
                    break
                if _wait(clock, deadline, stop):
                    break
                t_sample = clock.now() - t0
                q = self.robot.joints()
                values = tuple(float(q[self.robot.arm.joint_index(n)]) for n in self.joints)
                with self._lock:
                    self.program = self.program.append(
                        Keyframe(q=values, time=round(offset + t_sample, 4)))
                    if clock.now() - last_save >= save_every:
                        self._save()
                        last_save = clock.now()
                n += 1
                k = max(k + 1, int((clock.now() - t0) / dt))  # no bursts after a delay
        finally:
            with self._lock:
                self._save()
        return n

    # ---- jogging ------------------------------------------------------------------------------
    def jog_joint(self, joint: str, delta: float, speed: float = 0.3) -> MoveReport:
        """Move one joint by ``delta`` [rad]/[m] (torque comes on first, holding the pose)."""
        if self.limp:
            self.set_limp(False)
        q = self.robot.plan_start()  # a joint resting just outside its limits counts as at them
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
        """Torque back on, holding the present pose; the file is already saved.

        A session that ends without keyframes leaves no empty file: a file it wrote (every
        keyframe undone) is removed, unless it was appended to.
        """
        with self._lock:
            if self.written and not self.program.keyframes and not self._keep_empty:
                self.path.unlink(missing_ok=True)
        self.set_limp(False)
        return self.program


def _wait(clock: Clock, deadline: float, stop: threading.Event) -> bool:
    """Sleep on ``clock`` until ``deadline`` [s] or until ``stop`` is set.

    Sleeps in steps of at most 50 ms so that ``stop`` is seen soon.

    Returns:
        Whether ``stop`` was set.
    """
    while not stop.is_set():
        now = clock.now()
        if now >= deadline:
            return False
        clock.sleep_until(min(deadline, now + 0.05))
    return True
