"""Helpers shared by the command modules: arguments, JSON output, tables, joint values."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from armctl.errors import ArmctlError, InputError, json_safe

if TYPE_CHECKING:
    import numpy as np

    from armctl.arm import Arm

__all__ = [
    "add_config",
    "add_json",
    "check_rpy",
    "emit",
    "finite",
    "fmt",
    "is_keyframe_file",
    "load_arm_arg",
    "nonnegative",
    "nonnegative_int",
    "parse_angles",
    "positive",
    "positive_int",
    "print_error",
    "table",
]

JSON_SCHEMA = "armctl/1"

_N = TypeVar("_N", int, float)

#: A rotary value beyond this [rad] without ``--deg`` can only be meant in degrees.
_FULL_TURN = 2.0 * math.pi


# ---- argparse types: refused values are usage errors (exit code 2), never NaN or inf ----------
def finite(text: str) -> float:
    """A finite number (an argparse type).

    Raises:
        argparse.ArgumentTypeError: For text that is not a number, NaN or inf.
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number (NaN and infinity "
                                         "are not accepted)")
    return value


def _whole(text: str) -> int:
    """A whole number (for :func:`_at_least`).

    Raises:
        argparse.ArgumentTypeError: For text that is not a whole number.
    """
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None


def _at_least(parse: Callable[[str], _N], low: _N, strict: bool, rule: str, name: str
              ) -> Callable[[str], _N]:
    """An argparse type: ``parse(text)``, refused unless above ``low`` (``strict``) or at least.

    Args:
        parse: Text to number (raises :class:`argparse.ArgumentTypeError` for other text).
        low: The bound.
        strict: Whether ``low`` itself is refused.
        rule: The rule for the message, e.g. ``"greater than zero"``.
        name: The type's name (argparse shows it for other errors).
    """
    def check(text: str) -> _N:
        value = parse(text)
        if value < low or (strict and value == low):
            raise argparse.ArgumentTypeError(f"{text!r} must be {rule}")
        return value

    check.__name__ = check.__qualname__ = name
    check.__doc__ = f"A number, {rule} (an argparse type)."
    return check


#: A finite number greater than zero (an argparse type).
positive = _at_least(finite, 0.0, True, "greater than zero", "positive")
#: A finite number, zero or more (an argparse type).
nonnegative = _at_least(finite, 0.0, False, "zero or more", "nonnegative")
#: A whole number, 1 or more (an argparse type).
positive_int = _at_least(_whole, 1, False, "1 or more", "positive_int")
#: A whole number, 0 or more (an argparse type).
nonnegative_int = _at_least(_whole, 0, False, "zero or more", "nonnegative_int")


def check_rpy(values: Sequence[float] | None, deg: bool, option: str = "--rpy") -> None:
    """Refuse roll-pitch-yaw angles that can only be degrees when ``--deg`` is not given.

    Raises:
        InputError: For a component beyond 2 pi (e.g. 180) without ``--deg``.
    """
    if values is None or deg:
        return
    for name, v in zip(("roll", "pitch", "yaw"), values, strict=False):
        if abs(v) > _FULL_TURN + 1e-9:
            raise InputError(f"{option}: {name} {v:g} is more than a full turn in radians "
                             f"(2 pi = 6.283), so it can only be degrees: did you mean --deg?")


def add_config(parser: argparse.ArgumentParser) -> None:
    """Add the positional CONFIG argument (file path or bundled arm name)."""
    parser.add_argument("config", metavar="CONFIG",
                        help="arm YAML, URDF, or a bundled arm name such as so101")


def add_log_option(p: argparse.ArgumentParser) -> None:
    """Add ``--log FILE.csv`` (the per-cycle motion log) to a motion command."""
    p.add_argument("--log", metavar="FILE.csv", default=None,
                   help="write every streaming cycle's time [s] and each joint's commanded and "
                        "measured value [rad]/[m] to a new CSV file after the motion (also the "
                        "cycles that ran before a stop or a failure); see 'armctl plot'")


def add_json(parser: argparse.ArgumentParser) -> None:
    """Add ``--json``: print one JSON object (schema in docs/cli.md) instead of text."""
    parser.add_argument("--json", action="store_true",
                        help="print machine-readable JSON (see docs/cli.md)")


def load_arm_arg(args: argparse.Namespace) -> Arm:
    """Load the arm named by ``args.config`` (and ``args.tip`` when the command has it).

    Raises:
        ConfigError: As :func:`armctl.arm.load_arm`.
        InputError: For a keyframe file given where the arm config belongs.
    """
    from armctl.arm import load_arm
    from armctl.errors import ConfigError

    try:
        return load_arm(args.config, getattr(args, "tip", None))
    except ConfigError as exc:
        if is_keyframe_file(args.config):
            raise InputError(f"{args.config} is a keyframe file, not an arm config: give the arm "
                             "config (a YAML or URDF file, or a bundled arm name such as so101; "
                             "see 'armctl arms') as CONFIG") from exc
        raise


def is_keyframe_file(path: str) -> bool:
    """Whether ``path`` is a YAML file with a top-level ``armctl_keyframes:`` key.

    A plain text scan of the file's start: nothing is parsed, so a hostile file costs nothing.
    """
    from pathlib import Path

    p = Path(path)
    try:
        if p.suffix.lower() not in (".yaml", ".yml") or not p.is_file():
            return False
        with p.open(encoding="utf-8", errors="replace") as fh:
            head = fh.read(65536)
    except OSError:
        return False
    return any(line.startswith("armctl_keyframes:") for line in head.splitlines())


def emit(args: argparse.Namespace, data: dict[str, Any], text: str) -> None:
    """Print ``data`` as JSON when ``--json`` was given, else the human-readable ``text``."""
    if getattr(args, "json", False):
        payload = {"schema": JSON_SCHEMA, "command": args.command, "ok": True, **data}
        print(json.dumps(json_safe(payload), indent=2))
    else:
        print(text)


def print_error(args: argparse.Namespace, exc: ArmctlError, code: int) -> None:
    """Report an error on stderr, and as a JSON object on stdout with ``--json``."""
    if getattr(args, "json", False):
        error = {"type": type(exc).__name__, "message": str(exc), "exit_code": code,
                 "details": exc.details}
        payload = {"schema": JSON_SCHEMA, "command": getattr(args, "command", None), "ok": False,
                   "error": error}
        print(json.dumps(json_safe(payload), indent=2))
    print(f"armctl: error: {exc}", file=sys.stderr)


def parse_angles(values: Sequence[str], deg: bool, arm: Arm,
                 what: str = "joint values") -> np.ndarray:
    """Joint values from the command line, converted to SI (degrees only for rotary joints).

    Rotary values are radians, or degrees with ``--deg``; prismatic values are metres. A
    universal joint takes its two angles, a ball joint four numbers: its unit quaternion
    ``w x y z`` (never converted by ``--deg``; a norm within 0.001 of 1 is normalised).

    Raises:
        InputError: For a wrong count, a value that is not a finite number, a rotary value
            beyond a full turn (2 pi) without ``--deg`` that the joint cannot take (it can only
            be degrees), or a prismatic value that can only be millimetres.
    """
    import numpy as np

    from armctl.config.schema import JointType

    if len(values) != arm.nq:
        layout = ", ".join(
            f"{n}: 4 (quaternion w x y z)" if t is JointType.BALL else
            (f"{n}: 2 angles" if t is JointType.UNIVERSAL else n)
            for n, t in zip(arm.joint_names, arm.joint_types, strict=True))
        raise InputError(f"{what}: expected {arm.nq} values ({layout}), got {len(values)}")
    out = np.empty(arm.nq)
    owner = [j for j, t in enumerate(arm.joint_types) for _ in range(t.nq)]
    for i, raw in enumerate(values):
        name = arm.joint_names[owner[i]]
        try:
            v = float(raw)
        except ValueError:
            raise InputError(f"{what}: {raw!r} (joint {name!r}) is not a number") from None
        if not math.isfinite(v):
            raise InputError(f"{what}: {raw!r} (joint {name!r}) is not a finite number (NaN "
                             "and infinity are not accepted)")
        lo, hi = float(arm.lower[i]), float(arm.upper[i])
        jtype = arm.joint_types[owner[i]]
        if jtype is JointType.BALL:  # a quaternion component: no unit, no --deg
            out[i] = v
            continue
        if jtype is JointType.PRISMATIC:
            if not lo - 1e-9 <= v <= hi + 1e-9 and abs(v) >= 1.0 and lo <= v / 1000 <= hi:
                raise InputError(
                    f"{what}: {raw} (joint {name!r}) is outside its limits [{lo:g}, {hi:g}] m; "
                    f"prismatic values are in metres: did you mean {v / 1000:g} m ({v:g} mm)?")
        elif deg:
            v = math.radians(v)
        elif abs(v) > _FULL_TURN + 1e-9 and not lo <= v <= hi:
            also = "" if lo <= math.radians(v) <= hi else (
                f"; {v:g} deg is outside its limits [{math.degrees(lo):.6g}, "
                f"{math.degrees(hi):.6g}] deg too")
            raise InputError(
                f"{what}: {v:g} rad (joint {name!r}) is more than a full turn (2 pi = 6.283 "
                f"rad), so it can only be degrees: did you mean --deg?{also}")
        out[i] = v
    if arm.multi_dof_joints:
        for j, t in enumerate(arm.joint_types):  # typed to a few decimals: normalised
            sl = arm.q_index(j)
            norm = float(np.linalg.norm(out[sl]))
            if t is not JointType.BALL:
                continue
            if abs(norm - 1.0) > _TYPED_UNIT_TOLERANCE:
                given = " ".join(values[sl.start:sl.stop])
                raise InputError(
                    f"{what}: ball joint {arm.joint_names[j]!r} (values {sl.start + 1}-{sl.stop}) "
                    f"is '{given}', of norm {norm:.6g}: a ball joint takes its unit quaternion "
                    "w x y z, never angles (--deg does not apply to it); e.g. '1 0 0 0' for no "
                    "rotation, '0.7071 0.7071 0 0' for 90 deg about x")
            out[sl] /= norm
        arm.as_q(out, what)  # a ball joint's quaternion must be of unit norm (names the joint)
    return out


#: How far from 1 the norm of a ball joint's quaternion typed on the command line may be and
#: still be taken (normalised), as in keyframe files: four decimals written by hand.
_TYPED_UNIT_TOLERANCE = 1e-3


def fmt(x: float, digits: int = 4) -> str:
    """A number for tables: fixed precision, ``inf`` spelled out, no ``-0``."""
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    if math.isnan(x):
        return "-"
    s = f"{x:.{digits}f}"
    return s[1:] if s.startswith("-") and float(s) == 0 else s


def table(headers: Sequence[str], rows: Sequence[Sequence[str]], right: Sequence[int] = ()) -> str:
    """An aligned text table; columns listed in ``right`` are right-aligned."""
    widths = [len(h) for h in headers]
    for row in rows:
        widths = [max(w, len(c)) for w, c in zip(widths, row, strict=False)]

    def line(cells: Sequence[str]) -> str:
        parts = [c.rjust(w) if i in right else c.ljust(w)
                 for i, (c, w) in enumerate(zip(cells, widths, strict=False))]
        return "  ".join(parts).rstrip()

    out = [line(headers), line(["-" * w for w in widths])]
    out += [line(r) for r in rows]
    return "\n".join(out)
