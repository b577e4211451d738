"""The command line's argument parser: a bad value is one error line, like every other error."""

from __future__ import annotations

import argparse
import re
from typing import NoReturn

__all__ = ["ArgumentParser"]

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
    """

    def error(self, message: str) -> NoReturn:
        """Report a usage error and exit with code 2."""
        m = _VALUE_ERROR.fullmatch(message)
        if m is not None and not m.group("why").startswith(_SHAPE):
            self.exit(2, f"armctl: error: {message}; see '{self.prog} --help'\n")
        super().error(message)

