"""The control panel's server-side state, shared by every browser tab, independent of the page.

One :class:`ControlPanel` wraps one open :class:`~armctl.robot.Robot`. Several clients (browser
tabs) see the same state; one of them has control at a time and only it may preview targets,
move the arm or edit the keyframes; the others see who has it. An optional token protects
taking control. **Stop is accepted from every client at any time**: it decelerates the running
motion within the joint limits and holds (the Robot's stop path, as Ctrl-C in a terminal).

Every command goes through the Robot: a target is previewed with
:meth:`Robot.plan_pose <armctl.robot.Robot.plan_pose>` or :meth:`~armctl.robot.Robot.plan_joints`
(IK inside the effective limits, collision checks along the path), and Move runs
:meth:`~armctl.robot.Robot.move_to_pose` or :meth:`~armctl.robot.Robot.move_joints`, which plan
and check again from the present position. A refused preview carries the Robot's own error and
its kind (unreachable, outside the limits, colliding). Motions run in a worker thread, so the
page stays responsive; the bus is read by one thread at a time.

Example::

    from armctl.panel import ControlPanel
    from armctl.robot import Robot

    with Robot.open("so101", sim=True) as robot:
        panel = ControlPanel(robot)
        panel.join("tab-1")                       # the first tab gets control (no token set)
        preview = panel.preview_pose("tab-1", pose, oriented=False)
        if preview.ok:
            panel.move("tab-1")
            panel.wait()
"""

from __future__ import annotations

import hmac
import logging
import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from enum import Enum
from pathlib import Path

import numpy as np
import numpy.typing as npt

from armctl.collision.errors import CollisionError
from armctl.config.schema import JointRole
from armctl.errors import ArmctlError, InputError, JointLimitError, NoSolutionError
from armctl.ik import Goal, PoseGoal, PositionGoal
from armctl.motion.errors import LimitViolation
from armctl.motion.interpolate import Interpolation
from armctl.motion.keyframe_file import load_keyframes, save_keyframes
from armctl.motion.keyframes import AngleUnit, Keyframe, KeyframeProgram
from armctl.motion.playback import PlaybackOptions
from armctl.panel.errors import ControlDenied, PanelBusy
from armctl.robot.errors import MotionStopped
from armctl.robot.executor import CycleInfo
from armctl.robot.session import Robot
from armctl.robot.teach import ExistingFile, TeachSession, check_output, taught_joints
from armctl.typing import Array

__all__ = ["ControlPanel", "Outcome", "Phase", "Preview", "PreviewKind", "classify"]

logger = logging.getLogger(__name__)


class Phase(Enum):
    """What the arm is doing, as the panel started it."""

    IDLE = "idle"
    MOVING = "moving"  # a move to the previewed target
    PLAYING = "playing"  # a keyframe playback


class PreviewKind(Enum):
    """Whether a previewed target can be moved to, and if not, why (from the Robot's error)."""

    OK = "ok"
    UNREACHABLE = "unreachable"  # IK found no answer inside the effective limits, or no path
    OUTSIDE_LIMITS = "outside limits"  # a joint value outside the effective limits
    COLLIDES = "colliding"  # the goal or the way there brings a link into contact
    REFUSED = "refused"  # another refusal of the Robot (its message says why)


def classify(error: ArmctlError) -> PreviewKind:
    """The kind of a Robot's refusal of a plan."""
    if isinstance(error, CollisionError):
        return PreviewKind.COLLIDES
    if isinstance(error, JointLimitError) or (
            isinstance(error, LimitViolation) and error.kind == "position"):
        return PreviewKind.OUTSIDE_LIMITS
    if isinstance(error, NoSolutionError):
        return PreviewKind.UNREACHABLE
    return PreviewKind.REFUSED


@dataclass(frozen=True)
class Preview:
    """A target checked by the Robot (planned from the present position; nothing moved).

    Attributes:
        kind: :attr:`PreviewKind.OK`, or why the Robot refused it.
        message: What the page shows: the planned duration, or the Robot's error message.
        ghost: Joint values ``(dof,)`` [rad]/[m] the plan ends at (``None`` when refused).
        goal: The pose goal (for a pose target), else ``None``.
        joints: The joint target ``(dof,)`` (for a joint target), else ``None``.
        duration: Planned duration [s] (NaN when refused).
    """

    kind: PreviewKind
    message: str
    ghost: Array | None
    goal: Goal | None = None
    joints: Array | None = None
    duration: float = math.nan

    @property
    def ok(self) -> bool:
        """Whether Move may run it."""
        return self.kind is PreviewKind.OK


@dataclass(frozen=True)
class Outcome:
    """How the last motion started from the panel ended.

    Attributes:
        what: What ran (``"move"``, ``"playback"``).
        ok: Whether it reached its end.
        stopped: Whether a stop ended it (the arm holds where it stopped).
        message: The report or the error message.
        final: Joint values read back at the end ``(dof,)`` (``None`` when unknown).
    """

    what: str
    ok: bool
    stopped: bool
    message: str
    final: Array | None = None


class ControlPanel:
    """The state that every tab of the page shares, over one open :class:`Robot`.

    Args:
        robot: The open robot (it owns the bus; the panel never closes it).
        token: When given, taking control needs it (compared in constant time); without it the
            first tab to join gets control.
        solver: IK solver name for pose targets and pose keyframes.

    Attributes:
        robot: The robot.
        solver: The IK solver name.
    """

    def __init__(self, robot: Robot, *, token: str | None = None, solver: str = "auto"):
        if token is not None and not token:
            raise InputError("an empty token protects nothing: give a non-empty token or none")
        self.robot = robot
        self.solver = solver
        self._token = token
        self._lock = threading.RLock()  # the panel's state
        self._bus = threading.Lock()  # one thread reads or streams the bus at a time
        self._clients: dict[str, str] = {}
        self._controller: str | None = None
        self._phase = Phase.IDLE
        self._preview: Preview | None = None
        self._outcome: Outcome | None = None
        self._worker: threading.Thread | None = None
        self._listeners: list[Callable[[], None]] = []
        self._message = ""
        self._cancel = False  # Stop pressed before the motion's first cycle
        arm = robot.arm
        self._grippers = [i for i, r in enumerate(arm.joint_roles) if r is JointRole.GRIPPER]
        self._program = KeyframeProgram(arm.name, taught_joints(arm), (),
                                        robot.calibration_hash(), angle_unit=AngleUnit.DEG)
        self._interpolation = Interpolation.MIN_JERK
        self._recorder: threading.Thread | None = None
        self._end_recording = threading.Event()
        with self._bus:
            self._q = robot.joints()

    # ---- observers ------------------------------------------------------------------------
    def on_change(self, callback: Callable[[], None]) -> None:
        """Call ``callback()`` after every change of the shared state (from any thread)."""
        with self._lock:
            self._listeners.append(callback)

    def _changed(self, message: str | None = None) -> None:
        with self._lock:
            if message is not None:
                self._message = message
            listeners = list(self._listeners)
        for cb in listeners:
            try:
                cb()
            except Exception:  # a page that fails to update must not break the panel
                logger.exception("a panel listener failed")

    # ---- who commands ---------------------------------------------------------------------
    @property
    def controller(self) -> str | None:
        """The client that has control (``None``: nobody)."""
        with self._lock:
            return self._controller

    @property
    def clients(self) -> dict[str, str]:
        """The connected clients: id -> label."""
        with self._lock:
            return dict(self._clients)

    @property
    def protected(self) -> bool:
        """Whether taking control needs a token."""
        return self._token is not None

    def join(self, client: str, label: str | None = None) -> None:
        """A client connected. Without a token, it gets control when nobody has it."""
        with self._lock:
            self._clients[client] = label or client
            if self._controller is None and self._token is None:
                self._controller = client
        self._changed()

    def leave(self, client: str) -> None:
        """A client disconnected; its control (if it had it) is released."""
        with self._lock:
            self._clients.pop(client, None)
            if self._controller == client:
                self._controller = None
                self._end_recording.set()  # a recording ends with its recorder's control
        self._changed()

    def label(self, client: str | None) -> str:
        """A client's label (``"nobody"`` for ``None``)."""
        if client is None:
            return "nobody"
        with self._lock:
            return self._clients.get(client, client)

    def take_control(self, client: str, token: str | None = None, force: bool = False) -> None:
        """Give ``client`` control.

        Args:
            client: The client asking.
            token: The panel's token, when it has one.
            force: Take it from another client (only while no motion runs: a motion started
                by one client is never taken over; anyone may stop it).

        Raises:
            ControlDenied: A wrong or missing token, or another client has control (and
                ``force`` is not given, or a motion runs).
        """
        if self._token is not None and not hmac.compare_digest(
                (token or "").encode(), self._token.encode()):
            raise ControlDenied("wrong token: control needs the token the panel was started "
                                "with (armctl view --token)", client, self.controller)
        with self._lock:
            holder = self._controller
            if holder not in (None, client):
                if not force:
                    raise ControlDenied(f"{self.label(holder)} has control: it may release it, "
                                        "or take it over while the arm is at rest", client,
                                        holder)
                if self._phase is not Phase.IDLE:
                    raise ControlDenied(f"{self.label(holder)} runs a {self._phase.value} "
                                        "motion: wait for it to end or press Stop, then take "
                                        "control", client, holder)
            if holder != client:
                self._end_recording.set()  # a recording ends with its recorder's control
            self._controller = client
        self._changed(f"{self.label(client)} has control")

    def release_control(self, client: str) -> None:
        """``client`` gives up control (nothing when it does not have it)."""
        with self._lock:
            if self._controller != client:
                return
            self._controller = None
            self._end_recording.set()
        self._changed(f"{self.label(client)} released control")

    def _require(self, client: str, what: str) -> None:
        with self._lock:
            holder = self._controller
        if holder != client:
            who = ("nobody has control: take control first" if holder is None
                   else f"{self.label(holder)} has control")
            raise ControlDenied(f"cannot {what}: {who}", client, holder)

    def _require_idle(self, what: str) -> None:
        with self._lock:
            phase = self._phase
        if phase is not Phase.IDLE:
            raise PanelBusy(f"cannot {what} while a {phase.value} motion runs: wait for it to "
                            "end or press Stop", phase.value)

    # ---- state ----------------------------------------------------------------------------
    @property
    def phase(self) -> Phase:
        """What the arm is doing."""
        with self._lock:
            return self._phase

    @property
    def q(self) -> Array:
        """The latest joint values read from the bus ``(dof,)`` [rad]/[m]."""
        with self._lock:
            return self._q.copy()

    @property
    def preview(self) -> Preview | None:
        """The last previewed target."""
        with self._lock:
            return self._preview

    @property
    def outcome(self) -> Outcome | None:
        """How the last motion ended (``None`` before the first)."""
        with self._lock:
            return self._outcome

    @property
    def message(self) -> str:
        """The last thing that happened, in words."""
        with self._lock:
            return self._message

    @property
    def program(self) -> KeyframeProgram:
        """The keyframe list."""
        with self._lock:
            return self._program

    @property
    def interpolation(self) -> Interpolation:
        """How playback joins the keyframes."""
        with self._lock:
            return self._interpolation

    def refresh(self) -> Array:
        """Read the joints when the bus is free (a motion updates them every cycle).

        Returns:
            The latest joint values ``(dof,)`` [rad]/[m].
        """
        if self._bus.acquire(blocking=False):
            try:
                q = self.robot.joints()
            finally:
                self._bus.release()
            with self._lock:
                self._q = q
        return self.q

    def _cycle(self, info: CycleInfo) -> None:
        with self._lock:
            q = self._q.copy()
            q[self.robot.executor.idx] = info.measured
            self._q = q
            cancel, self._cancel = self._cancel, False
        if cancel:  # Stop was pressed while the motion was being planned
            self.robot.control.stop()

    # ---- previews -------------------------------------------------------------------------
    def preview_pose(self, client: str, pose: npt.ArrayLike, oriented: bool = True) -> Preview:
        """Check a tool target: IK and a plan from the present position, nothing moves.

        Args:
            client: The client asking (must have control).
            pose: The target ``(4, 4)`` in the base frame [m].
            oriented: Whether the orientation counts (else the position only).

        Returns:
            The preview (also kept as :attr:`preview` for :meth:`move`).
        """
        t = np.asarray(pose, dtype=float)
        if t.shape != (4, 4) or not np.all(np.isfinite(t)):
            raise InputError(f"a target pose is a finite 4x4 matrix, got shape {t.shape}")
        goal: Goal = PoseGoal(t) if oriented else PositionGoal(t[:3, 3])
        return self._preview_with(client, goal, None)

    def preview_joints(self, client: str, q: npt.ArrayLike) -> Preview:
        """Check a joint target ``(dof,)`` [rad]/[m]: a plan from the present position."""
        qv = self.robot.arm.as_q(q, "joint target")
        return self._preview_with(client, None, qv)

    def preview_joint(self, client: str, joint: str, value: float) -> Preview:
        """Check a move of one joint to ``value`` [rad]/[m], the others staying where they are."""
        i = self.robot.arm.joint_index(joint)
        q = self.refresh()
        q[i] = float(value)
        return self.preview_joints(client, q)

    def _preview_with(self, client: str, goal: Goal | None, joints: Array | None) -> Preview:
        self._require(client, "preview a target")
        self._require_idle("preview a target")
        robot = self.robot
        with self._bus:
            try:
                if goal is not None:
                    plan, _ = robot.plan_pose(goal, solver=self.solver)
                else:
                    assert joints is not None  # one of the two  # mypy.
                    plan = robot.plan_joints(joints)
            except ArmctlError as exc:
                preview = Preview(classify(exc), str(exc), None, goal, joints)
            else:
                ghost = np.asarray(plan.goal, dtype=float)
                preview = Preview(PreviewKind.OK, f"reachable: {plan.duration:.2f} s from here",
                                  ghost, goal, joints, float(plan.duration))
        with self._lock:
            self._preview = preview
        self._changed(preview.message if preview.ok else
                      f"{preview.kind.value}: {preview.message}")
        return preview

    # ---- motions --------------------------------------------------------------------------
    def move(self, client: str) -> None:
        """Move to the previewed target in a worker thread (planned and checked again).

        Raises:
            ControlDenied: ``client`` does not have control.
            PanelBusy: A motion runs.
            InputError: Nothing previewed, or the preview was refused (says why).
        """
        self._require(client, "move")
        preview = self.preview
        if preview is None:
            raise InputError("nothing to move to: set a target (drag it, type it, or move a "
                             "joint slider) first")
        if not preview.ok:
            raise InputError(f"the target is {preview.kind.value}: {preview.message}")
        goal, joints = preview.goal, preview.joints

        def run() -> tuple[str, Array]:
            if goal is not None:
                report = self.robot.move_to_pose(goal, solver=self.solver, on_cycle=self._cycle)
                assert report.result is not None  # not a dry run  # mypy.
                return (f"reached the target: position error "
                        f"{report.position_error * 1000:.2f} mm"), report.result.final
            assert joints is not None  # a preview has a goal or joints  # mypy.
            rep = self.robot.move_joints(joints, on_cycle=self._cycle)
            assert rep.result is not None  # mypy.
            return "reached the joint target", rep.result.final

        self._start(Phase.MOVING, "move", run)

    def play(self, client: str) -> None:
        """Play the keyframe list in a worker thread (the Robot plans and checks it first).

        Raises:
            ControlDenied, PanelBusy: As for :meth:`move`.
            InputError: No keyframes.
        """
        self._require(client, "play the keyframes")
        program, options = self._playback()

        def run() -> tuple[str, Array]:
            report = self.robot.play(program, options, solver=self.solver,
                                     on_cycle=self._cycle)
            assert report.result is not None  # mypy.
            return (f"played {len(program.keyframes)} keyframes in "
                    f"{report.plan.duration:.2f} s (planned)"), report.result.final

        self._start(Phase.PLAYING, "playback", run)

    def _playback(self) -> tuple[KeyframeProgram, PlaybackOptions]:
        with self._lock:
            program, interpolation = self._program, self._interpolation
        if not program.keyframes:
            raise InputError("no keyframes: record the present pose first")
        return program, PlaybackOptions(interpolation=interpolation)

    def _start(self, phase: Phase, what: str, run: Callable[[], tuple[str, Array]]) -> None:
        with self._lock:
            self._require_idle(what)
            self._phase = phase
            self._outcome = None
            self._cancel = False
            worker = threading.Thread(target=self._work, args=(what, run),
                                      name=f"armctl-panel-{what}", daemon=True)
            self._worker = worker
        self._changed(f"{what} started")
        worker.start()

    def _work(self, what: str, run: Callable[[], tuple[str, Array]]) -> None:
        outcome: Outcome
        with self._bus:
            try:
                text, final = run()
                outcome = Outcome(what, True, False, text, np.asarray(final, dtype=float))
            except MotionStopped as exc:
                outcome = Outcome(what, False, True, f"stopped: {exc}", None)
            except ArmctlError as exc:
                outcome = Outcome(what, False, False, f"{what} refused or failed: {exc}", None)
            except Exception as exc:  # a bug: shown in the page, the panel keeps running
                logger.exception("the %s failed", what)
                outcome = Outcome(what, False, False, f"{what} failed: {exc!r}", None)
            finally:
                if self.robot.control.paused:  # a stop ends the pause: the next motion goes
                    self.robot.resume()
            try:
                q = self.robot.joints()
            except ArmctlError:
                q = None
        with self._lock:
            if q is not None:
                self._q = q
                if outcome.final is None:
                    outcome = replace(outcome, final=q)
            self._outcome = outcome
            self._phase = Phase.IDLE
            self._preview = None  # planned from a position the arm has left
        self._changed(outcome.message)

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the running motion to end; returns whether none runs now."""
        with self._lock:
            worker = self._worker
        if worker is not None:
            worker.join(timeout)
            return not worker.is_alive()
        return True

    def stop(self, client: str | None = None) -> bool:
        """Stop the running motion: decelerate within the limits, then hold (any client).

        A second stop during the deceleration holds at once.

        Returns:
            Whether a motion was running.
        """
        streaming = self.robot.control.stop()
        with self._lock:
            running = self._phase is not Phase.IDLE
            if running and not streaming:
                self._cancel = True  # still being planned: stopped at its first cycle
        if running or streaming:
            self._changed(f"stop requested by {self.label(client)}")
        return running or streaming

    def pause(self, client: str) -> None:
        """Decelerate the running motion to rest along its path and hold (resume goes on)."""
        self._require(client, "pause")
        self.robot.pause()
        self._changed("paused")

    def resume(self, client: str) -> None:
        """Go on along the path after :meth:`pause`."""
        self._require(client, "resume")
        self.robot.resume()
        self._changed("resumed")

    def set_speed(self, client: str, speed: float) -> float:
        """Set the speed override [-] of the running and later motions (1: as planned).

        Returns:
            The override applied (capped at what the running plan's limits allow).
        """
        self._require(client, "change the speed")
        applied = self.robot.set_speed(speed)
        self._changed(f"speed x{applied:.2f}")
        return applied

    # ---- keyframes ------------------------------------------------------------------------
    def _edit(self, client: str, what: str, edit: Callable[[KeyframeProgram], KeyframeProgram],
              message: str) -> KeyframeProgram:
        self._require(client, what)
        self._require_not_recording(what)
        with self._lock:
            program = edit(self._program)
            self._program = program
        self._changed(message)
        return program

    def _index(self, i: int) -> int:
        n = len(self.program.keyframes)
        if not 0 <= i < n:
            raise InputError(f"no keyframe {i}: there are {n} (0 to {n - 1})" if n
                             else f"no keyframe {i}: the list is empty")
        return i

    def record(self, client: str, name: str = "") -> Keyframe:
        """Append the present pose as a joint keyframe (with the gripper's value, if any)."""
        self._require(client, "record a keyframe")
        q = self.refresh()
        arm = self.robot.arm

        def edit(program: KeyframeProgram) -> KeyframeProgram:
            values = tuple(float(q[arm.joint_index(n)]) for n in program.joints)
            grip = float(q[self._grippers[0]]) if self._grippers else None
            label = name or f"k{len(program.keyframes) + 1}"
            return program.append(Keyframe(q=values, name=label, gripper=grip))

        program = self._edit(client, "record a keyframe", edit, "recorded the present pose")
        return program.keyframes[-1]

    # ---- continuous recording -------------------------------------------------------------
    @property
    def recording(self) -> bool:
        """Whether a continuous recording runs."""
        with self._lock:
            return self._recorder is not None and self._recorder.is_alive()

    def _require_not_recording(self, what: str) -> None:
        if self.recording:
            raise PanelBusy(f"cannot {what} while a continuous recording runs: stop the "
                            "recording first", "recording")

    def start_recording(self, client: str, rate_hz: float = 10.0,
                        duration: float | None = None) -> None:
        """Record the arm's joints at ``rate_hz`` with time stamps, as ``armctl teach`` does.

        Samples are appended to the keyframe list as joint keyframes with time stamps [s] (the
        measured sampling times on the robot's clock, continuing after the list's last time
        stamp), while the arm is moved from the page (Move, sliders, the gizmo) or not at all.
        The recording ends on :meth:`stop_recording`, after ``duration``, or when its client
        loses control; the list is saved with :meth:`save` (the keyframe file of ``teach``).

        Args:
            client: The client asking (needs control).
            rate_hz: Sampling rate [Hz] (1 to 100).
            duration: End after this long [s] (``None``: until stopped).

        Raises:
            ControlDenied: ``client`` does not have control.
            PanelBusy: A recording runs already.
            InputError: A rate or duration out of range.
        """
        self._require(client, "start a recording")
        TeachSession.check_recording(rate_hz, duration)
        with self._lock:
            if self._recorder is not None and self._recorder.is_alive():
                raise PanelBusy("a continuous recording runs already: stop it first",
                                "recording")
            self._end_recording = threading.Event()
            self._recorder = threading.Thread(
                target=self._record_samples, args=(rate_hz, duration, self._end_recording),
                name="armctl-panel-recording", daemon=True)
            self._recorder.start()
        self._changed(f"recording at {rate_hz:g} Hz")

    def stop_recording(self, client: str | None = None, timeout: float = 5.0) -> int:
        """End a continuous recording (nothing when none runs).

        Args:
            client: The client asking (needs control); ``None`` for the server itself.
            timeout: Longest wait for the recording to end [s].

        Returns:
            The number of keyframes in the list afterwards.
        """
        if client is not None:
            self._require(client, "stop the recording")
        with self._lock:
            recorder = self._recorder
            self._end_recording.set()
        if recorder is not None:
            recorder.join(timeout)
        return len(self.program.keyframes)

    def _record_samples(self, rate_hz: float, duration: float | None,
                        end: threading.Event) -> None:
        clock = self.robot.clock
        dt = 1.0 / rate_hz
        arm = self.robot.arm
        with self._lock:
            stamps = [kf.time for kf in self._program.keyframes if kf.time is not None]
        offset = stamps[-1] + dt if stamps else 0.0
        t0 = clock.now()
        k = n = 0
        shown = t0
        while not end.is_set():
            if duration is not None and k * dt > duration + 1e-9:
                break
            deadline = t0 + k * dt
            while not end.is_set() and clock.now() < deadline:
                clock.sleep_until(min(deadline, clock.now() + 0.05))
            if end.is_set():
                break
            t = clock.now() - t0
            q = self.refresh()  # the bus, or the running motion's last measured cycle
            with self._lock:
                values = tuple(float(q[arm.joint_index(name)])
                               for name in self._program.joints)
                self._program = self._program.append(
                    Keyframe(q=values, time=round(offset + t, 4)))
            n += 1
            if clock.now() - shown >= 0.5:
                shown = clock.now()
                self._changed()
            k = max(k + 1, int((clock.now() - t0) / dt))  # no bursts after a delay
        self._changed(f"recorded {n} samples")

    def rename(self, client: str, i: int, name: str) -> None:
        """Rename keyframe ``i``."""
        self._index(i)

        def edit(p: KeyframeProgram) -> KeyframeProgram:
            kfs = list(p.keyframes)
            kfs[i] = replace(kfs[i], name=name.strip())
            return replace(p, keyframes=tuple(kfs))

        self._edit(client, "rename a keyframe", edit, f"keyframe {i} renamed")

    def move_keyframe(self, client: str, i: int, to: int) -> None:
        """Move keyframe ``i`` to position ``to`` in the list."""
        self._index(i)
        self._index(to)

        def edit(p: KeyframeProgram) -> KeyframeProgram:
            kfs = list(p.keyframes)
            kfs.insert(to, kfs.pop(i))
            return replace(p, keyframes=tuple(kfs))

        self._edit(client, "reorder the keyframes", edit, f"keyframe {i} moved to {to}")

    def delete_keyframe(self, client: str, i: int) -> None:
        """Delete keyframe ``i``."""
        self._index(i)

        def edit(p: KeyframeProgram) -> KeyframeProgram:
            return replace(p, keyframes=p.keyframes[:i] + p.keyframes[i + 1:])

        self._edit(client, "delete a keyframe", edit, f"keyframe {i} deleted")

    def set_timing(self, client: str, i: int, dwell: float | None = None,
                   time: float | None = None) -> None:
        """Set keyframe ``i``'s dwell [s] and time stamp [s] (``None`` keeps; NaN clears time).

        A program whose keyframes all have time stamps plays by them; else it is timed by the
        joint limits.
        """
        self._index(i)
        if dwell is not None and not (math.isfinite(dwell) and dwell >= 0.0):
            raise InputError(f"dwell {dwell} s: give a time of 0 s or more")
        if time is not None and not math.isnan(time) and not (math.isfinite(time) and time >= 0):
            raise InputError(f"time stamp {time} s: give a time of 0 s or more (blank: none)")

        def edit(p: KeyframeProgram) -> KeyframeProgram:
            kfs = list(p.keyframes)
            kf = kfs[i]
            if dwell is not None:
                kf = replace(kf, dwell=float(dwell))
            if time is not None:
                kf = replace(kf, time=None if math.isnan(time) else float(time))
            kfs[i] = kf
            return replace(p, keyframes=tuple(kfs))

        self._edit(client, "set a keyframe's times", edit, f"keyframe {i} timing set")

    def set_keyframe_interpolation(self, client: str, i: int,
                                   interpolation: Interpolation | None) -> None:
        """How the segment arriving at keyframe ``i`` is joined (``None``: the program's)."""
        self._index(i)
        kind = None if interpolation is None else Interpolation(interpolation)

        def edit(p: KeyframeProgram) -> KeyframeProgram:
            kfs = list(p.keyframes)
            kfs[i] = replace(kfs[i], interpolation=kind)
            return replace(p, keyframes=tuple(kfs))

        said = "as the program" if kind is None else kind.value
        self._edit(client, "set a keyframe's interpolation", edit,
                   f"keyframe {i} interpolation: {said}")

    def set_interpolation(self, client: str, interpolation: Interpolation) -> None:
        """How playback joins the keyframes."""
        self._require(client, "set the interpolation")
        with self._lock:
            self._interpolation = Interpolation(interpolation)
        self._changed(f"interpolation {self._interpolation.value}")

    def keyframe_q(self, i: int) -> Array | None:
        """Keyframe ``i`` as whole-arm joint values (``None`` for a pose keyframe).

        Joints the keyframe does not give stay at their present values.
        """
        kf = self.program.keyframes[self._index(i)]
        if kf.q is None:
            return None
        q = self.q
        arm = self.robot.arm
        for n, v in zip(self.program.joints, kf.q, strict=True):
            q[arm.joint_index(n)] = v
        if kf.gripper is not None:
            q[self._grippers] = kf.gripper
        return q

    def set_keyframe_pose(self, client: str, i: int, pose: npt.ArrayLike,
                          orientation: bool = True) -> Preview:
        """Give pose keyframe ``i`` a new tool pose, re-solved by the Robot first.

        The new pose is previewed as a target from the present position (the Robot's IK,
        limits and collision checks, as :meth:`preview_pose`); only a pose the Robot accepts
        replaces the keyframe's, so the list never holds a pose the page refused.

        Args:
            client: The client asking (needs control).
            i: The keyframe's index.
            pose: ``(4, 4)`` tool pose in the base frame [m].
            orientation: Whether the keyframe constrains the orientation too.

        Returns:
            The accepted preview (its ghost is the solution).

        Raises:
            InputError: Keyframe ``i`` is a joint keyframe, or the Robot refuses the pose (the
                message is its reason; the preview shows it).
        """
        self._require(client, "edit a keyframe")
        self._require_not_recording("edit a keyframe")
        kf = self.program.keyframes[self._index(i)]
        if kf.pose is None:
            raise InputError(f"keyframe {i} ({kf.label}) holds joint values, not a pose: "
                             "move the arm there and Record, or delete it")
        target = np.array(pose, dtype=float)
        preview = self.preview_pose(client, target, orientation)
        if not preview.ok:
            raise InputError(f"keyframe {i} ({kf.label}) keeps its pose: the new one is "
                             f"{preview.kind.value}: {preview.message}")

        def edit(p: KeyframeProgram) -> KeyframeProgram:
            kfs = list(p.keyframes)
            kfs[i] = replace(kfs[i], pose=target, orientation=orientation)
            return replace(p, keyframes=tuple(kfs))

        self._edit(client, "edit a keyframe", edit, f"keyframe {i} has a new pose")
        return preview

    def preview_keyframe(self, client: str, i: int) -> Preview:
        """Preview a move to keyframe ``i`` (Move then goes there)."""
        kf = self.program.keyframes[self._index(i)]
        q = self.keyframe_q(i)
        if q is not None:
            return self.preview_joints(client, q)
        assert kf.pose is not None  # a keyframe has q or a pose  # mypy.
        return self.preview_pose(client, kf.pose, kf.orientation)

    def preview_playback(self, client: str, rate: float = 20.0) -> tuple[Array, Array]:
        """Plan the playback from the present pose (the Robot's checks; nothing moves).

        Returns:
            Times ``(n,)`` [s] and joint values ``(n, dof)`` sampled at ``rate`` [Hz], for a
            ghost to replay.

        Raises:
            The Robot's refusal of the program (limits, collisions, IK of pose keyframes).
        """
        self._require(client, "preview the playback")
        self._require_idle("preview the playback")
        program, options = self._playback()
        with self._bus:
            plan = self.robot.plan_program(program, options, self.solver)
        ts = np.arange(0.0, plan.duration, 1.0 / rate)
        if ts.size == 0 or ts[-1] < plan.duration:
            ts = np.append(ts, plan.duration)
        qs = plan.trajectory.sample_many(ts)[0]
        self._changed(f"playback planned: {plan.duration:.2f} s")
        return ts, np.asarray(qs, dtype=float)

    def save(self, client: str, path: str | Path, overwrite: bool = False) -> Path:
        """Write the keyframes to a keyframe file (the format of ``armctl teach``/``play``).

        The write is atomic; an existing file is replaced only with ``overwrite``.

        Raises:
            InputError: No keyframes, an existing file without ``overwrite``, or a bad path
                (not ``.yaml``, missing folder, an arm config).
        """
        self._require(client, "save the keyframes")
        program = self.program
        if not program.keyframes:
            raise InputError("no keyframes to save: record the present pose first")
        p = Path(path).expanduser()
        if p.exists() and not p.is_dir() and not overwrite:
            raise InputError(f"{p} exists already: tick 'overwrite' to replace it, or choose "
                             "another name")
        p = check_output(p, ExistingFile.OVERWRITE, can_append=False)
        written = save_keyframes(program, p, self.robot.arm)
        self._changed(f"saved {len(program.keyframes)} keyframes to {written}")
        return written

    def load(self, client: str, path: str | Path) -> KeyframeProgram:
        """Replace the keyframe list by a keyframe file's (checked for this arm)."""
        self._require(client, "load keyframes")
        self._require_not_recording("load keyframes")
        program = load_keyframes(Path(path).expanduser(), self.robot.arm)
        with self._lock:
            self._program = program
        self._changed(f"loaded {len(program.keyframes)} keyframes from {path}")
        return program

    def joint_names(self) -> Sequence[str]:
        """The arm's joint names, in order."""
        return self.robot.arm.joint_names
