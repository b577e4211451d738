"""The command line's argument parser: a bad value is one error line, like every other error."""

from __future__ import annotations

import argparse
import re
from collections.abc import Callable, Sequence
from typing import NoReturn

__all__ = ["ArgumentParser", "add_later"]

#: argparse's messages about the shape of the command line (not about one value): these keep
#: the usage block, which shows the expected shape.
_SHAPE = ("expected ", "not allowed with argument", "ignored explicit argument")
_VALUE_ERROR = re.compile(r"argument (?P<arg>[^:]+): (?P<why>.*)", re.DOTALL)


class ArgumentParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` that reports a bad value on one line.

    A value refused by an argument's type or choices (``--speed nan``, ``--loop 0``,
    ``--tol-pos 0``, ``--exit-policy x``) prints ``armctl: error: argument --speed: ...`` and
    exits with code 2, as errors found after parsing do. Missing or unknown arguments and a
    wrong number of values still print the usage, which shows what is expected. Sub-command
    parsers are of the same class.

    A command may add its arguments later (:meth:`defer`): they are added the first time its
    parser parses or formats its help, so arguments that need heavy imports (the goal types'
    flags need NumPy) cost nothing to the commands that are not run.
    """

    def defer(self, build: Callable[[argparse.ArgumentParser], None]) -> None:
        """Add arguments with ``build(self)`` when this parser is first used, not now.

        Args:
            build: Adds the arguments (in the order of the deferred calls).
        """
        self.__dict__.setdefault("_deferred", []).append(build)

    def _build(self) -> None:
        deferred: list[Callable[[argparse.ArgumentParser], None]] = self.__dict__.get(
            "_deferred", [])
        while deferred:
            deferred.pop(0)(self)

    def parse_known_args(  # type: ignore[override]
            self, args: Sequence[str] | None = None,
            namespace: argparse.Namespace | None = None) -> tuple[argparse.Namespace, list[str]]:
        """Parse, after adding any deferred arguments."""
        self._build()
        return super().parse_known_args(args, namespace)

    def format_usage(self) -> str:
        """The usage line, with any deferred arguments."""
        self._build()
        return super().format_usage()

    def format_help(self) -> str:
        """The help text, with any deferred arguments."""
        self._build()
        return super().format_help()

    def error(self, message: str) -> NoReturn:
        """Report a usage error and exit with code 2."""
        m = _VALUE_ERROR.fullmatch(message)
        if m is not None and not m.group("why").startswith(_SHAPE):
            self.exit(2, f"armctl: error: {message}; see '{self.prog} --help'\n")
        super().error(message)


def add_later(parser: argparse.ArgumentParser,
              build: Callable[[argparse.ArgumentParser], None]) -> None:
    """Add arguments with ``build(parser)`` when the parser is first used.

    See :meth:`ArgumentParser.defer`; a plain :class:`argparse.ArgumentParser` gets them now.
    """
    if isinstance(parser, ArgumentParser):
        parser.defer(build)
    else:
        build(parser)
