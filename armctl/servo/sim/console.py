"""The command language of the standalone simulator (``armctl sim`` reads it on stdin).

:class:`SimConsole` turns one line into an action on a :class:`~armctl.servo.sim.bus.SimulatedBus`
and returns the text to show. A line with bad arguments (unknown command, wrong number of
words, a word that is not a number, an unknown servo, joint or fault kind, a parameter the fault
does not take) is an error line; the simulator and its pty carry on.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from armctl.errors import ArmctlError, InputError
from armctl.servo.sim import faults as F

if TYPE_CHECKING:
    from armctl.servo.sim.bus import SimulatedBus

__all__ = ["HELP", "ConsoleReply", "SimConsole"]

HELP = """commands:
  get                        joint values and ticks
  set JOINT VALUE [deg]      hand-guide a torque-off joint (rad or m; 'deg' for degrees)
  ticks ID TICKS             hand-guide a torque-off servo by id, in ticks
  fault KIND ID [COUNT] [KEY=VALUE ...]
                             inject a fault; COUNT: replies affected (default 1) or 'forever'
                             kinds: dropped_reply, corrupted_reply, truncated_reply, late_reply,
                             latency_spike (no ID: every servo), missing_servo, hardware_alarm,
                             wrong_model, lockup_after_overload, obstacle
                             keys: every=N (one reply in N), delay=S [s], keep=N [bytes],
                             alarm=overload|overheating|input_voltage|encoder, model=N, ticks=N
  faults                     list the active faults
  clear [ID]                 remove all faults (or those of one servo)
  quit                       stop the simulator"""

_COUNT_WORDS = ("forever", "always", "none")


@dataclass(frozen=True)
class ConsoleReply:
    """What a command line produced.

    Attributes:
        text: The lines to show (``"error: ..."`` for a refused line).
        quit: Whether the simulator should stop.
        ok: Whether the line was carried out.
    """

    text: str
    quit: bool = False
    ok: bool = True


def _integer(word: str, what: str, lo: int | None = None, hi: int | None = None) -> int:
    try:
        value = int(word, 10)
    except ValueError:
        raise InputError(f"{what}: {word!r} is not a whole number") from None
    if lo is not None and hi is None and value < lo:
        raise InputError(f"{what}: {value} must be at least {lo}")
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise InputError(f"{what}: {value} is outside {lo}..{hi}")
    return value


def _number(word: str, what: str, nonnegative: bool = False) -> float:
    try:
        value = float(word)
    except ValueError:
        raise InputError(f"{what}: {word!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{what}: {word!r} is not a finite number")
    if nonnegative and value < 0:
        raise InputError(f"{what}: {value:g} must not be negative")
    return value


def _count(word: str) -> int | None:
    if word.lower() in _COUNT_WORDS:
        return None
    return _integer(word, "COUNT (replies affected, or 'forever')", lo=1)


# The fault parameters a console line may set: key -> (dataclass field, parser).
_KEYS: dict[str, tuple[str, Any]] = {
    "count": ("count", _count),
    "every": ("every", lambda w: _integer(w, "every", lo=1)),
    "delay": ("delay", lambda w: _number(w, "delay [s]", nonnegative=True)),
    "keep": ("keep", lambda w: _integer(w, "keep [bytes]", lo=0)),
    "alarm": ("alarm", lambda w: _alarm(w)),
    "model": ("model_number", lambda w: _integer(w, "model", lo=0, hi=65535)),
    "model_number": ("model_number", lambda w: _integer(w, "model_number", lo=0, hi=65535)),
    "ticks": ("ticks", lambda w: _integer(w, "ticks", lo=-(2**31), hi=2**31 - 1)),
}


def _alarm(word: str) -> F.Alarm:
    try:
        return F.Alarm(word.lower())
    except ValueError:
        raise InputError(f"alarm: unknown alarm {word!r}; one of "
                         f"{', '.join(a.value for a in F.Alarm)}") from None


def parse_fault(words: list[str]) -> F.Fault:
    """The fault of the words after ``fault``: ``KIND [ID] [COUNT] [KEY=VALUE ...]``.

    Raises:
        InputError: For an unknown kind, a missing or extra word, or a bad value.
    """
    if not words:
        raise InputError("fault: give a kind, e.g. 'fault dropped_reply 3' (see 'help')")
    kind = words[0].lower()
    cls = F.FAULT_KINDS.get(kind)
    if cls is None:
        raise InputError(f"fault: unknown kind {words[0]!r}; one of "
                         f"{', '.join(F.FAULT_KINDS)}")
    names = {f.name for f in dataclasses.fields(cls)}
    rest = words[1:]
    kw: dict[str, Any] = {}
    if "servo_id" in names:
        if not rest or "=" in rest[0]:
            raise InputError(f"fault {kind}: give the servo id, e.g. 'fault {kind} 3'")
        kw["servo_id"] = _integer(rest[0], "servo id", lo=0, hi=252)
        rest = rest[1:]
    if rest and "=" not in rest[0]:
        if "count" not in names:
            raise InputError(f"fault {kind}: {rest[0]!r}: this fault is a state and takes no "
                             "COUNT (it lasts until 'clear')")
        kw["count"] = _count(rest[0])
        rest = rest[1:]
    for word in rest:
        key, sep, value = word.partition("=")
        if not sep:
            raise InputError(f"fault {kind}: unexpected {word!r}; give parameters as "
                             "KEY=VALUE (see 'help')")
        spec = _KEYS.get(key.lower())
        if spec is None or spec[0] not in names:
            takes = sorted(k for k, (field, _) in _KEYS.items() if field in names
                           and k != "model_number")
            raise InputError(f"fault {kind}: no parameter {key!r}; it takes "
                             f"{', '.join(takes) or 'none'}")
        kw[spec[0]] = spec[1](value)
    fault: F.Fault = cls(**kw)
    return fault


class SimConsole:
    """Carries out console lines on a simulated bus.

    Args:
        sim: The simulated bus (running).
    """

    def __init__(self, sim: SimulatedBus):
        self.sim = sim

    def execute(self, line: str) -> ConsoleReply:
        """Carry out one line; never raises for a bad line (the reply is an error line)."""
        words = line.split()
        if not words:
            return ConsoleReply("")
        try:
            return self._run(words)
        except ArmctlError as exc:
            return ConsoleReply(f"error: {exc}", ok=False)

    def _run(self, words: list[str]) -> ConsoleReply:
        cmd, args = words[0].lower(), words[1:]
        if cmd in ("quit", "exit"):
            self._arity(cmd, args, 0, 0)
            return ConsoleReply("", quit=True)
        if cmd == "help":
            return ConsoleReply(HELP)
        if cmd == "get":
            self._arity(cmd, args, 0, 0)
            return ConsoleReply(self._get())
        if cmd == "set":
            self._arity(cmd, args, 2, 3, "set JOINT VALUE [deg]")
            value = _number(args[1], "VALUE")
            if len(args) == 3:
                if args[2].lower() != "deg":
                    raise InputError(f"set: the third word must be 'deg', not {args[2]!r}")
                value = math.radians(value)
            self.sim.set_joint(args[0], value)
            return ConsoleReply("ok")
        if cmd == "ticks":
            self._arity(cmd, args, 2, 2, "ticks ID TICKS")
            sid = _integer(args[0], "ID", lo=0, hi=252)
            self.sim.set_joint(sid, _integer(args[1], "TICKS", lo=-(2**31), hi=2**31 - 1))
            return ConsoleReply("ok")
        if cmd == "fault":
            self.sim.inject(parse_fault(args))
            return ConsoleReply("ok")
        if cmd == "faults":
            self._arity(cmd, args, 0, 0)
            return ConsoleReply("\n".join(map(repr, self.sim.faults)) or "no faults")
        if cmd == "clear":
            self._arity(cmd, args, 0, 1, "clear [ID]")
            servo_id = _integer(args[0], "ID", lo=0, hi=252) if args else None
            if servo_id is not None:
                self.sim.servo(servo_id)  # an unknown id is an error, not a silent no-op
            self.sim.clear_faults(servo_id)
            return ConsoleReply("ok")
        raise InputError(f"unknown command {words[0]!r}; type 'help' for the commands")

    @staticmethod
    def _arity(cmd: str, args: list[str], lo: int, hi: int, usage: str | None = None) -> None:
        if not lo <= len(args) <= hi:
            raise InputError(f"{cmd}: expected {usage or cmd + ' (no arguments)'}, got "
                             f"{len(args)} argument{'s' if len(args) != 1 else ''}")

    def _get(self) -> str:
        ticks = self.sim.positions
        if self.sim.mapping is None:
            return "\n".join(f"servo {sid}: {t} ticks" for sid, t in ticks.items())
        return "\n".join(f"{j.name} (id {j.servo_id}): {j.to_joint(ticks[j.servo_id]):.4f} "
                         f"[{ticks[j.servo_id]} ticks]" for j in self.sim.mapping.joints)
