"""Showing the live state of another armctl command that owns a port (``status`` attached).

The owner publishes its state (:mod:`armctl.robot.live_publisher`); this module prints it: a
table of measured and commanded joints, what runs and how far, the tool pose and clearance,
once or refreshed until the owner releases the port (or Ctrl-C, which ends only the watching).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from armctl.cli._common import JSON_SCHEMA, emit, fmt, table
from armctl.errors import InputError
from armctl.robot.errors import LiveStateError
from armctl.robot.live_state import Activity

if TYPE_CHECKING:
    from armctl.config.bus import BusSpec
    from armctl.robot.live_state import LiveHello, LiveSnapshot
    from armctl.robot.live_watch import LiveWatcher

__all__ = ["OwnerFollower", "PoseLines", "check_same_arm", "owner_line", "port_owner",
           "watch_owner"]

#: Seconds without a snapshot after which the owner is said to be silent (it sends 25 a second).
_SILENT = 2.0

#: ``(names, values) -> (tool, tool line, clearance, clearance line)``: the tool pose and the
#: clearance at joint values given by name (JSON fields and text lines, as ``status`` shows).
PoseLines = Callable[[Sequence[str], Sequence[float]], tuple[Any, str, Any, str]]


def check_same_arm(hello: LiveHello, arm: str, joints: Sequence[str]) -> None:
    """Refuse to show a port driven by another arm (its joints would be drawn on this one).

    Raises:
        InputError: The owner's arm has another name, or bus joints this arm does not have.
    """
    missing = [j for j in hello.joints if j not in joints]
    if hello.arm != arm or missing:
        what = (f"whose joints {', '.join(missing)} arm {arm!r} does not have" if missing
                else f"not {arm!r}")
        raise InputError(
            f"port {hello.port} is driven by arm {hello.arm!r} ({hello.config}; pid "
            f"{hello.pid}: {hello.command}), {what}; give its config ({hello.config}) to watch "
            "it",
            {"port": hello.port, "owner_arm": hello.arm, "arm": arm})


def owner_line(hello: LiveHello) -> str:
    """Who owns the port, in one line."""
    return (f"port {hello.port} is owned by pid {hello.pid}: {hello.command} (arm "
            f"{hello.arm!r}); showing its live state")


def _activity_line(snap: LiveSnapshot) -> str:
    words = [snap.activity.value]
    if snap.description:
        words[0] += f": {snap.description}"
    if snap.t is not None and snap.duration is not None:
        words.append(f"{fmt(snap.t, 2)} / {fmt(snap.duration, 2)} s"
                     + (f" ({100 * snap.progress:.0f}%)" if snap.progress is not None else ""))
    elif snap.t is not None:
        words.append(f"{fmt(snap.t, 1)} s")
    if snap.stopping:
        words.append("STOPPING")
    if snap.paused:
        words.append("PAUSED")
    elif snap.paused is not None and snap.activity is not Activity.IDLE:
        words.append("running")
    if snap.speed is not None:
        words.append(f"speed {100 * snap.speed:.0f}%")
    if snap.torque is not None:
        words.append(f"torque {'on' if snap.torque else 'off'}")
    words.append(f"(updated {1000 * snap.age:.0f} ms ago)")
    return "   ".join(words)


def _value(v: float | None, unit: str, deg: bool) -> str:
    if v is None:
        return "-"
    return fmt(math.degrees(v), 2) if deg and unit == "rad" else fmt(v, 4)


def _render(hello: LiveHello, snap: LiveSnapshot, deg: bool, pose_lines: PoseLines
            ) -> tuple[dict[str, Any], str]:
    """The JSON fields and the text of one snapshot."""
    rows, joints = [], []
    for i, (name, unit) in enumerate(zip(hello.joints, hello.units, strict=True)):
        meas = None if snap.measured is None else snap.measured[i]
        cmd = None if snap.commanded is None else snap.commanded[i]
        rows.append([name, _value(meas, unit, deg), _value(cmd, unit, deg),
                     "deg" if deg and unit == "rad" else unit])
        joints.append({"joint": name, "measured": meas, "commanded": cmd, "unit": unit})
    text = _activity_line(snap) + "\n" + table(["joint", "measured", "commanded", "unit"],
                                               rows, [1, 2])
    tool = clearance = None
    if snap.measured is not None:
        tool, tool_text, clearance, clearance_text = pose_lines(hello.joints, snap.measured)
        text += "\n" + tool_text + "\n" + clearance_text
    owner = {k: v for k, v in hello.as_json().items() if k != "type"}
    state = {k: v for k, v in snap.as_json().items() if k != "type"}
    return {"arm": hello.arm, "port": hello.port, "attached": True, "owner": owner,
            "state": state, "joints": joints, "tool": tool, "clearance": clearance}, text


def _line(args: argparse.Namespace, data: dict[str, Any]) -> None:
    """One JSON line (``--json --follow``)."""
    from armctl.cli._common import json_safe

    payload = {"schema": JSON_SCHEMA, "command": args.command, "ok": True, **data}
    print(json.dumps(json_safe(payload)), flush=True)


def watch_owner(args: argparse.Namespace, watcher: LiveWatcher, pose_lines: PoseLines) -> int:
    """Show the owner's live state, once or until the owner releases the port.

    Once with ``--once``, or ``--json`` without ``--follow``; else refreshed every
    ``--interval`` until the owner releases the port or Ctrl-C.

    Returns:
        0 (also when the owner ends; Ctrl-C ends with the usual interrupt exit).
    """
    hello = watcher.hello
    deg = bool(getattr(args, "deg", False))
    follow = bool(getattr(args, "follow", False))
    once = bool(args.once) or (bool(args.json) and not follow)
    with watcher:
        if once:
            try:
                first = watcher.next(timeout=_SILENT)
            except TimeoutError:
                raise LiveStateError(f"{owner_line(hello).split(';')[0]}, but it has sent no "
                                     f"state for {_SILENT:g} s (is it stopped?)",
                                     {"pid": hello.pid}) from None
            data, text = _render(hello, first, deg, pose_lines)
            emit(args, data, owner_line(hello) + "\n\n" + text)
            return 0
        watcher.follow()
        seq, text, heard = -1, "", time.monotonic()
        tick = threading.Event()
        while True:
            watcher.wait_newer(seq, max(0.02, args.interval))
            done = watcher.ended is not None
            snap = watcher.latest  # read after 'done': the last one once the owner is gone
            quiet = time.monotonic() - heard
            if snap is not None and snap.seq > seq:
                seq, heard, quiet = snap.seq, time.monotonic(), 0.0
                data, text = _render(hello, snap, deg, pose_lines)
                if args.json:
                    _line(args, data)
            if not args.json and (quiet == 0.0 or quiet > _SILENT):
                note = (f"\nNO STATE from pid {hello.pid} for {quiet:.0f} s (is it stopped?)"
                        if quiet > _SILENT else "")
                sys.stdout.write("\x1b[H\x1b[2J" + owner_line(hello)
                                 + " (Ctrl-C stops watching; the command goes on)\n\n"
                                 + text + note + "\n")
                sys.stdout.flush()
            if done:
                break
            tick.wait(max(0.02, args.interval))  # at most one refresh per interval
        if args.json:
            _line(args, {"attached": True, "owner": {k: v for k, v in hello.as_json().items()
                                                      if k != "type"},
                         "ended": watcher.ended})
        else:
            print(watcher.ended)
    return 0


def port_owner(bus: BusSpec, failure: Exception | None) -> LiveWatcher | None:
    """The live state of the armctl command that owns a bus's port, if one does.

    Args:
        bus: The bus section (with the port to read).
        failure: Why opening the port failed (``None``: not tried yet). A busy port held by an
            armctl command is given a moment to start publishing (it may be opening the port).

    Raises:
        LiveStateError: With ``failure``: the owner's live state cannot be read (say why).
    """
    from armctl.robot.live_watch import attach
    from armctl.servo.port_holders import port_holders

    if bus.simulated:
        return None  # the built-in simulated bus is this process's own
    if failure is None:
        try:
            return attach(bus.port)
        except LiveStateError:  # said again if the port turns out busy
            return None
    if "busy" not in str(failure) or not any(h.is_armctl for h in port_holders(bus.port)):
        return None
    return attach(bus.port, wait=2.0)


class OwnerFollower:
    """Joint values of whichever armctl command owns a port, for a view that follows it.

    Reads the owner's latest snapshot (the port is never opened). When the owner releases the
    port, the last values stay and the next armctl command that opens the port is watched in
    turn (tried at most every :attr:`RETRY` seconds).

    Args:
        watcher: The first owner's live state.
        arm: The view's arm's name.
        joint_names: The view's arm's joints.
        q0: Values ``(dof,)`` [rad]/[m] for joints the owner does not publish.
        say: Called with a line when the owner changes or leaves (``None``: silent).
    """

    #: Seconds between attempts to watch the port's next owner.
    RETRY = 0.5

    def __init__(self, watcher: LiveWatcher, arm: str, joint_names: Sequence[str],
                 q0: Any, say: Callable[[str], None] | None = None):
        import numpy as np

        self.arm = arm
        self.port = watcher.hello.port
        self.joint_names = tuple(joint_names)
        self.q = np.array(q0, dtype=float)
        self.say = say
        self._retry_at = 0.0
        self.watcher: LiveWatcher | None = None
        self._watch(watcher)

    def _watch(self, watcher: LiveWatcher) -> None:
        hello = watcher.hello
        check_same_arm(hello, self.arm, self.joint_names)
        self._index = [self.joint_names.index(n) for n in hello.joints]
        self.watcher = watcher.follow()
        if self.say is not None:
            self.say(f"watching pid {hello.pid}: {hello.command}")

    def read(self) -> Any:
        """The joint values ``(dof,)`` [rad]/[m] as the owner last published them."""
        import time

        from armctl.robot.live_watch import attach

        w = self.watcher
        if w is not None and w.latest is not None and w.latest.measured is not None:
            self.q[self._index] = w.latest.measured
        if w is not None and w.ended is not None:
            if self.say is not None:
                self.say(f"{w.ended}; waiting for the next armctl command on {self.port}")
            w.close()
            self.watcher = None
        if self.watcher is None and time.monotonic() >= self._retry_at:
            self._retry_at = time.monotonic() + self.RETRY
            nxt = attach(self.port)
            if nxt is not None:
                try:
                    self._watch(nxt)
                except InputError as exc:  # another arm on the port: not this view's
                    nxt.close()
                    if self.say is not None:
                        self.say(str(exc))
        return self.q.copy()

    def close(self) -> None:
        """Stop watching."""
        if self.watcher is not None:
            self.watcher.close()
            self.watcher = None
