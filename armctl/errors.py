"""The armctl exception tree: every error armctl raises derives from :class:`ArmctlError`.

Each class builds a message that says what went wrong, where, and how to fix it, carries the same
facts as data in :attr:`ArmctlError.details` (JSON-safe; the command line prints them with
``--json``), and has an ``exit_code`` that the command-line interface returns. Every constructor
passes its message and details to ``ArmctlError.__init__(message, details)``; a subclass that
extends its parent's details adds keys to ``self.details`` after the parent's constructor.

Exit codes (also documented in ``docs/cli.md``):

* 0: success.
* 1: unexpected internal error (a bug: please report it).
* 2: bad input: a config file, a command-line argument, a value outside its range.
* 3: no solution: an IK goal that cannot be reached, a path that cannot be planned.
* 4: hardware or bus failure: port, timeout, checksum, servo error bits.
* 5: a motion was stopped part-way (a fault: tracking error, lost servo, servo alarm; or a stop
  signal during the motion: Ctrl-C, SIGTERM, SIGHUP); the arm holds where it stopped.
* 130, 143, 129: interrupted by SIGINT (Ctrl-C), SIGTERM or SIGHUP while no motion was under
  way (128 + the signal number); a signal after a stopped motion does not change its code 5.

Subpackages define their specialised errors next to their code (for example
``armctl.servo.errors``), always as subclasses of the classes below. The one exception outside
the tree is :class:`armctl.robot.errors.SignalInterrupt`, a :class:`KeyboardInterrupt` on
purpose: SIGTERM and SIGHUP end a command the way Ctrl-C does, past ``except Exception``.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path, PurePath
from typing import Any

__all__ = [
    "ArmctlError",
    "BusError",
    "ConfigError",
    "InputError",
    "JointLimitError",
    "KeyPath",
    "MotionAborted",
    "NoSolutionError",
    "PlanningError",
    "UnknownNameError",
    "json_safe",
]


def json_safe(value: Any) -> Any:
    """``value`` as JSON holds it: dicts with string keys, lists, strings, numbers, ``None``.

    NumPy arrays and tuples become lists, NumPy numbers Python numbers, enums their values, paths
    strings; NaN becomes ``None`` and infinities ``"inf"``/``"-inf"`` (strict JSON has neither);
    any other object its ``str``.
    """
    if value is None or isinstance(value, (str, bool)):
        return value
    np = sys.modules.get("numpy")  # NumPy values exist only once NumPy is imported
    if np is not None and isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, int) or (np is not None and isinstance(value, np.integer)):
        return int(value)
    if isinstance(value, float) or (np is not None and isinstance(value, np.floating)):
        f = float(value)
        return f if math.isfinite(f) else (None if math.isnan(f) else ("inf" if f > 0 else "-inf"))
    if isinstance(value, Mapping):
        return {str(k): json_safe(v) for k, v in value.items()}
    if np is not None and isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, Enum):
        return json_safe(value.value)
    if isinstance(value, PurePath):
        return str(value)
    return str(value)


class ArmctlError(Exception):
    """Root of every exception that armctl raises on purpose.

    Args:
        message: The whole message: what went wrong, where, and how to fix it.
        details: The facts of the error as data (see :attr:`details`); converted by
            :func:`json_safe`.

    Attributes:
        details: The facts of the error as data, for programs: string keys, JSON-safe values
            (:func:`json_safe`), numbers in SI units ([m], [rad], [s]) unless the key says
            otherwise. Each class documents its keys; empty when the message is all there is.
            The command line prints it as ``error.details`` with ``--json``. Code that catches
            an error may add a fact (e.g. ``limit_source``), JSON-safe.
        exit_code: What the command line returns for it (see the module docstring).
    """

    exit_code: int = 1

    def __init__(self, message: str = "", details: Mapping[str, Any] | None = None):
        super().__init__(message)
        self.details: dict[str, Any] = json_safe(details) if details else {}


@dataclass(frozen=True)
class KeyPath:
    """A location inside a config file: the file, the key path and (when known) the line.

    Attributes:
        file: The file the value came from, or ``None`` for data built in memory.
        keys: The path of keys and list indices from the document root, e.g.
            ``("joints", 2, "limits", "upper")``.
        line: 1-based line number in ``file``, or ``None`` when unknown.
        label: Optional human-readable name of the item, such as a joint name, shown after
            the first list index (``joints[2] (elbow)``).
    """

    file: Path | None = None
    keys: tuple[str | int, ...] = ()
    line: int | None = None
    label: str | None = None

    def dotted(self) -> str:
        """The key path as text, e.g. ``joints[2] (elbow).limits.upper``."""
        out = ""
        labelled = False
        for key in self.keys:
            if isinstance(key, int):
                out += f"[{key}]"
                if self.label and not labelled:
                    out += f" ({self.label})"
                    labelled = True
            else:
                out += f".{key}" if out else key
        return out or "<document root>"

    def where(self) -> str:
        """``file:line: key.path`` with the parts that are known."""
        head = str(self.file) if self.file is not None else "<config>"
        if self.line is not None:
            head += f":{self.line}"
        return f"{head}: {self.dotted()}" if self.keys else head


class InputError(ArmctlError, ValueError):
    """A value given to armctl (an argument, an array, a command) is not acceptable."""

    exit_code = 2


class ConfigError(InputError):
    """A config file (arm YAML, URDF, keyframes, goals, calibration) is invalid.

    Args:
        problem: What is wrong, e.g. ``"lower limit 1.2 is greater than upper limit 0.5"``.
        where: Where it is: file, key path and line.
        fix: How to fix it, e.g. ``"swap the two values"``.

    ``details``: ``problem``, ``file``, ``line``, ``key`` (the key path as text, e.g.
    ``joints[2] (elbow).limits.upper``; ``None`` for the whole file) and ``fix``.
    """

    def __init__(self, problem: str, where: KeyPath | None = None, fix: str | None = None):
        self.problem = problem
        self.where = where if where is not None else KeyPath()
        self.fix = fix
        text = f"{self.where.where()}: {problem}"
        if fix:
            text += f"\n  fix: {fix}"
        super().__init__(text, {"problem": problem, "file": self.where.file,
                                "line": self.where.line,
                                "key": self.where.dotted() if self.where.keys else None,
                                "fix": fix})


class UnknownNameError(InputError, KeyError):
    """A name (joint, frame, link, solver, servo register) that does not exist.

    The message lists the valid names, the nearest one first when there is a close match.

    Args:
        kind: What kind of name, e.g. ``"frame"``.
        name: The name that was asked for.
        valid: The names that do exist.
        context: Where the name was looked up, e.g. ``"arm 'so101'"``.

    ``details``: ``kind``, ``name``, ``valid`` (every valid name), ``suggestion`` (the close
    name, or ``None``) and ``context``.
    """

    def __init__(self, kind: str, name: str, valid: Sequence[str], context: str = ""):
        import difflib

        self.kind = kind
        self.name = name
        self.valid = tuple(valid)
        close = difflib.get_close_matches(name, self.valid, n=1) or _word_match(name, self.valid)
        text = f"unknown {kind} {name!r}"
        if context:
            text += f" in {context}"
        if close:
            text += f"; did you mean {close[0]!r}?"
        elif not text.endswith(("?", ".")):
            text += "."
        shown = ", ".join(repr(v) for v in self.valid[:40])
        if len(self.valid) > 40:
            shown += ", ..."
        text += f" Valid {kind} names: {shown}." if self.valid else f" (there are no {kind}s)"
        self.message = text
        super().__init__(text, {"kind": kind, "name": name, "valid": self.valid,
                                "suggestion": close[0] if close else None, "context": context})

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return self.message


def _word_match(name: str, valid: Sequence[str]) -> list[str]:
    """A valid name with a ``_``/``-`` separated word close to ``name``, or nothing.

    For example ``elbw`` -> ``elbow_flex``.
    """
    import difflib

    def score(v: str) -> float:
        words = v.replace("-", "_").split("_")
        return max(difflib.SequenceMatcher(None, name.lower(), w.lower()).ratio() for w in words)

    best = max(valid, key=score, default=None)
    return [best] if best is not None and score(best) >= 0.75 else []


class JointLimitError(InputError):
    """A joint value outside its limits was requested; nothing was commanded.

    Args:
        joint: The joint's name.
        value: The requested value in [rad] or [m].
        lower: Lower limit in the same unit.
        upper: Upper limit in the same unit.
        context: What was being done, e.g. ``"goal of move-joints"``.
        advice: Where the crossed limit comes from and how to fix it; the default advice is
            for a limit of the arm config.

    ``details``: ``joint``, ``value``, ``lower``, ``upper`` (where the limit was enforced may
    add ``limit_source``).
    """

    def __init__(self, joint: str, value: float, lower: float, upper: float, context: str = "",
                 advice: str | None = None):
        self.joint = joint
        self.value = value
        self.lower = lower
        self.upper = upper
        what = f" ({context})" if context else ""
        advice = advice or "Choose a value inside the limits or widen them in the arm config."
        super().__init__(
            f"joint {joint!r}: {value:.6g} is outside its limits [{lower:.6g}, {upper:.6g}]{what};"
            f" nothing was sent. {advice}",
            {"joint": joint, "value": value, "lower": lower, "upper": upper},
        )


class NoSolutionError(ArmctlError):
    """An IK goal or a plan has no solution; the best attempt is attached when there is one."""

    exit_code = 3


class PlanningError(NoSolutionError):
    """A motion cannot be planned (IK fails along a path, limits would be exceeded).

    A failed plan never moves the arm.
    """


class BusError(ArmctlError):
    """Communication with the servos failed (port, timeout, checksum, servo error bits)."""

    exit_code = 4


class MotionAborted(ArmctlError):
    """A motion was stopped for safety; the arm decelerated and holds its position."""

    exit_code = 5
