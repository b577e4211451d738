"""The ``armctl`` command line: a thin layer over the Python API.

Every module in this package whose name does not start with ``_`` adds commands: it defines
``ORDER`` (its place in ``armctl --help``) and ``register(subparsers)``, which adds one parser per
command and sets ``func`` on it to a function ``(args) -> int``. Heavy imports happen inside those
functions, so ``armctl --help`` stays fast.
"""

from __future__ import annotations

import argparse
import importlib
import logging
import pkgutil
import re
import signal
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING

from armctl import __version__
from armctl.cli._common import print_error
from armctl.cli._parser import ArgumentParser
from armctl.errors import ArmctlError

if TYPE_CHECKING:
    from armctl.robot.stop import SignalGuard

__all__ = ["build_parser", "main"]

#: A negative number, also ``-inf``/``-nan`` (values, refused later with a clear message).
_NEGATIVE_NUMBER = re.compile(r"^-((\d+\.?\d*|\.\d+)([eE][-+]?\d+)?|inf(inity)?|nan)$",
                              re.IGNORECASE)


def _command_modules() -> list[ModuleType]:
    mods = []
    for info in pkgutil.iter_modules(__path__):
        if not info.name.startswith("_"):
            mods.append(importlib.import_module(f"{__name__}.{info.name}"))
    return sorted(mods, key=lambda m: (getattr(m, "ORDER", 100), m.__name__))


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every command."""
    parser = ArgumentParser(
        prog="armctl",
        description="Control robot arms built from serial-bus smart servos. CONFIG is an arm "
        "YAML file, a URDF, or the name of a bundled arm (see 'armctl arms').",
        epilog="Exit codes: 0 ok, 1 internal error, 2 bad input, 3 no solution, 4 bus or "
        "hardware error, 5 motion stopped for safety (a fault, or Ctrl-C/SIGTERM/SIGHUP once "
        "the arm has moved in the command: it holds, the exit policy is not applied), "
        "130/143/129 interrupted by SIGINT/SIGTERM/SIGHUP before anything moved.",
    )
    parser.add_argument("--version", action="version", version=f"armctl {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in _command_modules():
        mod.register(sub)
    # Negative numbers in exponent notation (-9.2e-06) are values, not options.
    for p in (parser, *sub.choices.values()):
        p._negative_number_matcher = _NEGATIVE_NUMBER
    return parser


def _report_compiles() -> None:
    """Report kernel compiles longer than a second on stderr, with progress.

    The first run after installing compiles the kernels that a command needs; later runs load
    them from numba's cache. Nothing is imported here: the report starts when numba is.
    """
    try:
        from armctl.kinematics.compile_progress import report_compiles_once_loaded

        report_compiles_once_loaded(delay=1.0, every=10.0)
    except Exception:  # a courtesy only: numba's event interface may differ between versions
        logging.getLogger(__name__).debug("no compile progress", exc_info=True)


class _StderrLogHandler(logging.Handler):
    """Library warnings as ``armctl: message`` lines on the present ``sys.stderr``."""

    def emit(self, record: logging.LogRecord) -> None:
        try:
            stream = sys.stderr
            clear = "\r\x1b[K" if stream.isatty() else ""  # over a progress bar
            stream.write(f"{clear}armctl: {record.getMessage()}\n")
            stream.flush()
        except Exception:  # a log line must never end a command
            self.handleError(record)


def _setup_logging() -> None:
    """Show the library's warnings (``armctl.*`` loggers) on stderr, once per process."""
    log = logging.getLogger("armctl")
    if not any(isinstance(h, _StderrLogHandler) for h in log.handlers):
        log.addHandler(_StderrLogHandler(logging.WARNING))
    progress = logging.getLogger("armctl.kinematics.compile_progress")  # INFO: kernel compiles
    if not any(isinstance(h, _StderrLogHandler) for h in progress.handlers):
        progress.setLevel(logging.INFO)
        progress.addHandler(_StderrLogHandler(logging.INFO))
        progress.propagate = False


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line (see :func:`_main`).

    A Ctrl-C (or SIGTERM, SIGHUP) that arrives before the command has taken charge of signals,
    while the modules are imported or the arguments parsed, ends it with 128 + the signal's
    number and "interrupted by SIGINT; nothing moved", never a traceback.

    Args:
        argv: Arguments without the program name; ``sys.argv[1:]`` when ``None``.

    Returns:
        The exit code.
    """
    try:
        return _main(argv)
    except KeyboardInterrupt as exc:
        signum = int(getattr(exc, "signum", signal.SIGINT))
        words = list(sys.argv[1:] if argv is None else argv)
        command = next((w for w in words if not w.startswith("-")), None)
        _print_interrupt(argparse.Namespace(json="--json" in words, command=command),
                         signal.Signals(signum).name, 128 + signum, True)
        return 128 + signum


def _main(argv: Sequence[str] | None = None) -> int:
    """Run the command line.

    Commands that move the arm set ``stop_signals``: for them SIGINT, SIGTERM and SIGHUP are
    guarded for the whole command (:class:`armctl.robot.SignalGuard`). A signal gives 128 + its
    number only while nothing has moved; once a motion has run it gives 5 (the arm holds, the
    exit policy is not applied), and a signal after a stopped motion cannot replace its code.

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
    _setup_logging()
    _report_compiles()
    if not getattr(args, "stop_signals", False):
        return _dispatch(args, None)
    from armctl.robot.stop import SignalGuard, signal_name

    guard = SignalGuard()
    args.signal_guard = guard
    with guard.installed():
        code = _dispatch(args, guard)
        signum = guard.signum if guard.signum is not None else guard.stopped_by
        if code == 0 and signum is not None:  # the command ended normally, then a signal
            name = signal_name(signum)
            if guard.moved:  # the arm has moved: it holds; the exit policy was skipped
                print(f"armctl: {name} after the motion had finished: the arm holds where it "
                      "is (exit policy not applied)", file=sys.stderr)
                code = 5
            else:  # its report is out already (a dry run): stderr only
                print(f"armctl: interrupted by {name}; nothing moved", file=sys.stderr)
                code = 128 + signum
        elif guard.signum is not None:
            print(f"armctl: {signal_name(guard.signum)} received while finishing: ignored "
                  "(the arm holds)", file=sys.stderr)
    return code


def _dispatch(args: argparse.Namespace, guard: SignalGuard | None) -> int:
    """Run the command; errors become their exit codes, signals 128 + their number."""
    try:
        try:
            return int(args.func(args) or 0)
        finally:
            if guard is not None:
                guard.defer()  # from here on, signals are only recorded
    except ArmctlError as exc:
        print_error(args, exc, exc.exit_code)
        return exc.exit_code
    except KeyboardInterrupt as exc:  # SIGINT; SIGTERM and SIGHUP for motion commands
        signum = int(getattr(exc, "signum", signal.SIGINT))
        name = signal.Signals(signum).name
        _print_interrupt(args, name, 128 + signum, guard is not None)
        return 128 + signum
    except BrokenPipeError:  # e.g. piped into `head`
        return 0


def _print_interrupt(args: argparse.Namespace, name: str, code: int, motion: bool) -> None:
    """Say that the command was interrupted (JSON too with --json).

    ``motion``: a command that moves the arm, interrupted before its motion started.
    """
    message = f"interrupted by {name}" + ("; nothing moved" if motion else "")
    if getattr(args, "json", False):
        import json

        from armctl.cli._common import JSON_SCHEMA

        print(json.dumps({"schema": JSON_SCHEMA, "command": getattr(args, "command", None),
                          "ok": False, "error": {"type": "Interrupted", "message": message,
                                                 "signal": name, "exit_code": code}}, indent=2))
    print(f"armctl: {message}", file=sys.stderr)
