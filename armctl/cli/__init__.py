"""The ``armctl`` command line: a thin layer over the Python API.

Every module in this package whose name does not start with ``_`` adds commands: it defines
``ORDER`` (its place in ``armctl --help``) and ``register(subparsers)``, which adds one parser per
command and sets ``func`` on it to a function ``(args) -> int``. Heavy imports happen inside those
functions, so ``armctl --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import re
import sys
from collections.abc import Sequence
from types import ModuleType

from armctl import __version__
from armctl.cli._common import print_error
from armctl.errors import ArmctlError

__all__ = ["build_parser", "main"]

_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def _command_modules() -> list[ModuleType]:
    mods = []
    for info in pkgutil.iter_modules(__path__):
        if not info.name.startswith("_"):
            mods.append(importlib.import_module(f"{__name__}.{info.name}"))
    return sorted(mods, key=lambda m: (getattr(m, "ORDER", 100), m.__name__))


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every command."""
    parser = argparse.ArgumentParser(
        prog="armctl",
        description="Control robot arms built from serial-bus smart servos. CONFIG is an arm "
        "YAML file, a URDF, or the name of a bundled arm (see 'armctl arms').",
        epilog="Exit codes: 0 ok, 1 internal error, 2 bad input, 3 no solution, 4 bus or "
        "hardware error, 5 motion stopped for safety, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"armctl {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in _command_modules():
        mod.register(sub)
    # Negative numbers in exponent notation (-9.2e-06) are values, not options.
    for p in (parser, *sub.choices.values()):
        p._negative_number_matcher = _NEGATIVE_NUMBER
    return parser


#: Commands that run compiled (numba) kernels, which are built on their first use.
_COMPILING = frozenset({"fk", "ik", "move-to-pose", "move-joints", "home", "park", "teach",
                        "play", "render", "workspace", "view", "info", "calibrate"})


def _first_run_notice(command: str | None) -> None:
    """Say so when the compiled kernels are not cached yet (the first run takes ~30 s)."""
    if command not in _COMPILING:
        return
    try:
        from pathlib import Path

        from armctl.kinematics import _kernels

        cache = Path(_kernels.chain_fk._cache._cache_path)  # type: ignore[attr-defined]
        if any(cache.glob("_kernels.chain_fk-*.nbi")):
            return
    except Exception:  # the notice is a courtesy: numba internals may differ between versions
        return
    print("armctl: first run: compiling the numerical kernels (about half a minute, once)...",
          file=sys.stderr, flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line.

    Args:
        argv: Arguments without the program name; ``sys.argv[1:]`` when ``None``.

    Returns:
        The exit code.
    """
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except SystemExit as exc:  # argparse: --help, --version, usage errors
        return int(exc.code or 0) if not isinstance(exc.code, str) else 2
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    _first_run_notice(args.command)
    try:
        return int(args.func(args) or 0)
    except ArmctlError as exc:
        print_error(args, exc, exc.exit_code)
        return exc.exit_code
    except KeyboardInterrupt:
        print("armctl: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # e.g. piped into `head`
        return 0
