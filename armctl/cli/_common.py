"""Helpers shared by the command modules: arguments, JSON output, tables, joint values."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from armctl.errors import ArmctlError, InputError

if TYPE_CHECKING:
    from armctl.arm import Arm

__all__ = [
    "add_config",
    "add_json",
    "emit",
    "fmt",
    "load_arm_arg",
    "parse_angles",
    "print_error",
    "table",
]

JSON_SCHEMA = "armctl/1"


def add_config(parser: argparse.ArgumentParser) -> None:
    """Add the positional CONFIG argument (file path or bundled arm name)."""
    parser.add_argument("config", metavar="CONFIG",
                        help="arm YAML, URDF, or a bundled arm name such as so101")


def add_json(parser: argparse.ArgumentParser) -> None:
    """Add ``--json``: print one JSON object (schema in docs/cli.md) instead of text."""
    parser.add_argument("--json", action="store_true",
                        help="print machine-readable JSON (see docs/cli.md)")


def load_arm_arg(args: argparse.Namespace) -> Arm:
    """Load the arm named by ``args.config`` (and ``args.tip`` when the command has it)."""
    from armctl.arm import load_arm

    return load_arm(args.config, getattr(args, "tip", None))


def _jsonable(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        f = float(value)
        return f if math.isfinite(f) else (None if math.isnan(f) else ("inf" if f > 0 else "-inf"))
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    return value


def emit(args: argparse.Namespace, data: dict[str, Any], text: str) -> None:
    """Print ``data`` as JSON when ``--json`` was given, else the human-readable ``text``."""
    if getattr(args, "json", False):
        payload = {"schema": JSON_SCHEMA, "command": args.command, "ok": True, **data}
        print(json.dumps(_jsonable(payload), indent=2))
    else:
        print(text)


def print_error(args: argparse.Namespace, exc: ArmctlError, code: int) -> None:
    """Report an error on stderr, and as a JSON object on stdout with ``--json``."""
    if getattr(args, "json", False):
        error: dict[str, Any] = {"type": type(exc).__name__, "message": str(exc),
                                 "exit_code": code}
        extra = getattr(exc, "details", None)
        if isinstance(extra, dict):
            error["details"] = extra
        payload = {"schema": JSON_SCHEMA, "command": getattr(args, "command", None), "ok": False,
                   "error": error}
        print(json.dumps(_jsonable(payload), indent=2))
    print(f"armctl: error: {exc}", file=sys.stderr)


def parse_angles(values: Sequence[str], deg: bool, arm: Arm,
                 what: str = "joint values") -> np.ndarray:
    """Joint values from the command line, converted to SI (degrees only for rotary joints).

    Raises:
        InputError: For a wrong count or a value that is not a number.
    """
    from armctl.config.schema import JointType

    if len(values) != arm.dof:
        raise InputError(f"{what}: expected {arm.dof} values ({', '.join(arm.joint_names)}), "
                         f"got {len(values)}")
    out = np.empty(arm.dof)
    for i, raw in enumerate(values):
        try:
            out[i] = float(raw)
        except ValueError:
            raise InputError(
                f"{what}: {raw!r} (joint {arm.joint_names[i]!r}) is not a number") from None
        if deg and arm.joint_types[i] is not JointType.PRISMATIC:
            out[i] = math.radians(out[i])
    return out


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
