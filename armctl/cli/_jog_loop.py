"""The key loop of ``armctl jog``: one key, one action; a status line redrawn in place.

Keys are read one at a time (:class:`armctl.cli._keys.KeyReader`). While a step runs, its
``on_cycle`` callback reads the keys that arrive: space stops the step (it decelerates and
holds), ``q`` stops it and ends the session, the settings keys (mode, selection, step, speed,
help) apply at once, and every other key (a jog key repeating while it is held down, a gripper,
home or record key) is dropped, so that key repeat never queues a run of steps.
"""

from __future__ import annotations

import math
import os
import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum
from functools import partial
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:
    from armctl.cli._keys import KeyReader
    from armctl.robot.executor import CycleInfo
    from armctl.robot.jog import Jogger, JogOutcome
    from armctl.robot.stop import SignalGuard
    from armctl.typing import Array

__all__ = ["JOG_HELP", "Action", "JogEnd", "StatusLine", "action_of", "final_state", "jog_loop",
           "status_text"]


class Action(Enum):
    """What a key asks for."""

    PLUS = "step +"
    MINUS = "step -"
    SELECT = "select"
    MODE = "mode"
    BIGGER = "bigger step"
    SMALLER = "smaller step"
    FASTER = "faster"
    SLOWER = "slower"
    OPEN = "open gripper"
    CLOSE = "close gripper"
    RECORD = "record"
    UNDO = "undo"
    HOME = "home"
    STOP = "stop"
    HELP = "help"
    QUIT = "quit"


#: Every key and its action (number keys select: see :func:`action_of`).
KEYS: dict[str, Action] = {
    "+": Action.PLUS, "=": Action.PLUS, "UP": Action.PLUS, "RIGHT": Action.PLUS,
    "-": Action.MINUS, "_": Action.MINUS, "DOWN": Action.MINUS, "LEFT": Action.MINUS,
    "m": Action.MODE, "TAB": Action.MODE,
    "]": Action.BIGGER, "[": Action.SMALLER,
    ".": Action.FASTER, ">": Action.FASTER, ",": Action.SLOWER, "<": Action.SLOWER,
    "o": Action.OPEN, "c": Action.CLOSE,
    "k": Action.RECORD, "ENTER": Action.RECORD, "u": Action.UNDO,
    "0": Action.HOME, "HOME": Action.HOME,
    " ": Action.STOP,
    "?": Action.HELP, "h": Action.HELP,
    "q": Action.QUIT,
}

#: Actions that move the arm or write the file: dropped when they arrive during a step.
_BUSY_DROPS = {Action.PLUS, Action.MINUS, Action.OPEN, Action.CLOSE, Action.RECORD, Action.UNDO,
               Action.HOME}

JOG_HELP = """keys (no Enter needed):
  1..9          select joint 1..9 (joint mode) or axis 1..6 = x y z rx ry rz (base/tool mode)
  + = UP RIGHT  one step of the selected joint or axis in the positive direction
  - _ DOWN LEFT one step in the negative direction
  m TAB         mode: joint -> base frame -> tool frame -> joint
  [ ]           smaller / bigger step (deg for rotations, mm for translations)
  , <   . >     slower / faster (speed factor of the joint limits)
  o  c          open / close the gripper
  k ENTER       record a keyframe (with -o FILE)      u  remove the last keyframe
  0 HOME        go to the 'home' pose
  space         stop the running step (it decelerates and holds)
  ? h           this help
  q             quit (Ctrl-C: stop, hold where the arm is and quit)
a refused step moves nothing; the status line says why. Keys pressed while a step runs are
dropped, except stop, quit and the settings keys."""


def action_of(key: str) -> Action | None:
    """The action of a key (``None``: not a jog key)."""
    if len(key) == 1 and "1" <= key <= "9":
        return Action.SELECT
    return KEYS.get(key)


class StatusLine:
    """One status line at the bottom of the terminal, redrawn in place; messages scroll above.

    Args:
        stream: The terminal's output stream.
    """

    def __init__(self, stream: TextIO):
        self.stream = stream
        self.text = ""

    def width(self) -> int:
        """The width in columns of the terminal the status goes to (at least 40)."""
        try:
            columns = os.get_terminal_size(self.stream.fileno()).columns
        except (AttributeError, OSError, ValueError):
            columns = 0
        if columns <= 0:  # not a terminal, or one that does not know its size: $COLUMNS or 100
            columns = shutil.get_terminal_size((100, 24)).columns
        return max(columns, 40)

    def show(self, text: str) -> None:
        """Redraw the status line (cut to the terminal's width)."""
        self.text = text
        self.stream.write("\r" + text[: self.width() - 1] + "\x1b[K")
        self.stream.flush()

    def say(self, text: str) -> None:
        """Print whole lines above the status line, then redraw it."""
        self.stream.write("\r\x1b[K" + text.rstrip("\n") + "\n")
        self.show(self.text)

    def close(self) -> None:
        """End the status line (the cursor goes to a new line)."""
        self.stream.write("\n")
        self.stream.flush()


def status_text(jogger: Jogger, q: Array, message: str) -> str:
    """The status line: mode and selection, step, speed, keyframes, joints, tool pose, message.

    Joints in deg (mm for prismatic ones), the tool position in mm and its roll, pitch, yaw in
    deg.
    """
    import numpy as np

    from armctl.config.schema import JointType
    from armctl.spatial import matrix_to_rpy

    arm = jogger.robot.arm
    pose = arm.fk(q)
    rpy = np.degrees(matrix_to_rpy(pose[:3, :3]))
    xyz = pose[:3, 3] * 1000
    sel = jogger.targets.index(jogger.target) + 1
    joints = " ".join(
        f"{q[i] * 1000:.1f}mm" if t is JointType.PRISMATIC else f"{math.degrees(q[i]):.1f}"
        for i, t in enumerate(arm.joint_types))
    return (f"[{jogger.mode.value} {sel}:{jogger.target} step {jogger.step_text()} "
            f"speed {jogger.speed:.0%} kf {jogger.keyframes}] joints[deg] {joints} | "
            f"tcp[mm] {xyz[0]:.1f} {xyz[1]:.1f} {xyz[2]:.1f} rpy[deg] {rpy[0]:.1f} "
            f"{rpy[1]:.1f} {rpy[2]:.1f} | {message}")


class JogEnd(Enum):
    """Why the key loop ended."""

    QUIT = "quit key"
    END_OF_INPUT = "end of input"
    SIGNAL = "signal"
    """A stop signal (Ctrl-C, SIGTERM, SIGHUP); the arm holds."""


@dataclass
class _Busy:
    """What the keys read during a step asked for."""

    quit: bool = False
    dropped: int = 0
    notes: list[str] = field(default_factory=list)


def _apply_setting(jogger: Jogger, action: Action, key: str, screen: StatusLine) -> str:
    """Apply a settings key (mode, selection, step, speed, help); the status message."""
    from armctl.errors import InputError

    if action is Action.SELECT:
        try:
            return f"selected {jogger.select(int(key) - 1)}"
        except InputError as exc:
            return str(exc)
    if action is Action.MODE:
        jogger.set_mode(jogger.mode.next())
        return f"mode {jogger.mode.value}"
    if action is Action.BIGGER:
        jogger.bigger_step()
        return f"step {jogger.step_text()}"
    if action is Action.SMALLER:
        jogger.smaller_step()
        return f"step {jogger.step_text()}"
    if action is Action.FASTER:
        jogger.faster()
        return f"speed {jogger.speed:.0%}"
    if action is Action.SLOWER:
        jogger.slower()
        return f"speed {jogger.speed:.0%}"
    screen.say(JOG_HELP)
    return "help above"


def jog_loop(jogger: Jogger, reader: KeyReader, screen: StatusLine,
             guard: SignalGuard | None = None, idle: float = 0.25) -> JogEnd:
    """Read keys and run them on ``jogger`` until quit, the end of input or a stop signal.

    Args:
        jogger: The jogger.
        reader: The terminal's keys.
        screen: Where the status line and the messages go.
        guard: The command's signal guard: a signal it records (after a motion has run) ends
            the loop.
        idle: How long to wait for a key before looking at the guard again [s].

    Raises:
        SignalInterrupt: A stop signal before any motion ran (from the guard).
        MotionStopped: A step stopped for a fault (the arm holds).
    """
    from armctl.errors import InputError
    from armctl.robot.jog import JogResult

    robot = jogger.robot
    q_full = robot.joints()
    message = "ready: press ? for the keys"
    screen.show(status_text(jogger, q_full, message))
    last_draw = 0.0

    def read_busy(busy: _Busy) -> None:
        """Take the keys that arrived during a step (never blocks)."""
        nonlocal message
        while (key := reader.key(0)) is not None:
            action = action_of(key)
            if action is Action.STOP:
                jogger.stop("the space key")
            elif action is Action.QUIT:
                if not robot.stop.requested:  # after the stop key: not a second request
                    jogger.stop("the quit key")  # (which would hold at once)
                busy.quit = True
            elif action is None or action in _BUSY_DROPS:
                busy.dropped += 1
            else:
                message = _apply_setting(jogger, action, key, screen)

    def run(step: Callable[[Callable[[CycleInfo], None]], JogOutcome]) -> tuple[JogOutcome,
                                                                             _Busy]:
        nonlocal last_draw
        busy = _Busy()
        idx = robot.executor.idx
        live = q_full.copy()

        def on_cycle(info: CycleInfo) -> None:
            nonlocal last_draw
            read_busy(busy)
            now = time.monotonic()
            if now - last_draw >= 0.1:
                live[idx] = info.measured
                screen.show(status_text(jogger, live, "stopping" if info.stopping else
                                        f"moving: {busy_label}"))
                last_draw = now

        outcome = step(on_cycle)
        read_busy(busy)  # keys typed while the step was planned or settled
        return outcome, busy

    busy_label = ""
    while True:
        if guard is not None and guard.signum is not None:
            return JogEnd.SIGNAL
        key = reader.key(idle)
        if key is None:
            if reader.closed:
                return JogEnd.END_OF_INPUT
            continue
        action = action_of(key)
        outcome: JogOutcome | None = None
        busy = _Busy()
        if action is None:
            message = f"key {key!r} does nothing: press ? for the keys"
        elif action is Action.QUIT:
            return JogEnd.QUIT
        elif action is Action.STOP:
            message = "nothing is moving"
        elif action in (Action.PLUS, Action.MINUS):
            sign = 1 if action is Action.PLUS else -1
            busy_label = f"{jogger.target} {'+' if sign > 0 else '-'}"
            outcome, busy = run(partial(jogger.jog, sign))
        elif action in (Action.OPEN, Action.CLOSE):
            busy_label = action.value
            outcome, busy = run(partial(jogger.gripper, action is Action.OPEN))
        elif action is Action.HOME:
            busy_label = "home"
            outcome, busy = run(jogger.home)
        elif action in (Action.RECORD, Action.UNDO):
            try:
                if action is Action.RECORD:
                    jogger.record()
                    message = f"keyframe {jogger.keyframes} recorded"
                else:
                    message = ("removed the last keyframe" if jogger.undo() is not None
                               else "no keyframe to remove")
            except InputError as exc:
                message = f"{exc}: start jog with -o FILE to record keyframes"
            screen.say(message)
        else:
            message = _apply_setting(jogger, action, key, screen)
        if outcome is not None:
            message = outcome.message
            if outcome.result is JogResult.REFUSED:
                screen.say(f"refused: {outcome.detail}")
            elif outcome.result is JogResult.STOPPED:
                signum = getattr(outcome.error, "signum", None)
                if signum is not None:  # Ctrl-C (or SIGTERM, SIGHUP) during the step
                    q_full = robot.joints()
                    screen.show(status_text(jogger, q_full, message))
                    return JogEnd.SIGNAL
            if busy.dropped:
                message += f" ({busy.dropped} key{'s' if busy.dropped > 1 else ''} dropped)"
            q_full = robot.joints()
        screen.show(status_text(jogger, q_full, message))
        if busy.quit:
            return JogEnd.QUIT


def final_state(jogger: Jogger) -> dict[str, Any]:
    """The state at the end, for ``--json``: joints [rad]/[m], tool pose, counts."""
    import numpy as np

    from armctl.spatial import matrix_to_rpy

    robot = jogger.robot
    q = robot.joints()
    pose = robot.arm.fk(q)
    return {"arm": robot.arm.name, "joints": robot.arm.values_by_name(q),
            "tool": {"xyz": pose[:3, 3], "rpy": np.asarray(matrix_to_rpy(pose[:3, :3]))},
            "mode": jogger.mode.value, "speed": jogger.speed,
            "steps": jogger.steps_run, "refused": jogger.refusals,
            "keyframes": jogger.keyframes}
