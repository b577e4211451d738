"""The command line's argument parser: a bad value is one error line, like every other error."""

from __future__ import annotations

import argparse
import copy
import difflib
import re
import sys
from collections.abc import Callable, Sequence
from typing import NoReturn

from armctl.errors import InputError

__all__ = ["ArgumentParser", "add_later"]

#: argparse's messages about the shape of the command line (not about one value): these keep
#: the usage block, which shows the expected shape.
_SHAPE = ("expected ", "ignored explicit argument")

#: Two options that exclude each other (``--scene FILE --no-scene``): one line saying so.
_EXCLUSIVE = "not allowed with argument"
_VALUE_ERROR = re.compile(r"argument (?P<arg>[^:]+): (?P<why>.*)", re.DOTALL)


class _Refused(InputError):
    """A trial parse that failed (the command line is then parsed as given; never shown)."""


class ArgumentParser(argparse.ArgumentParser):
    """An :class:`argparse.ArgumentParser` that reports a bad value on one line.

    A value refused by an argument's type or choices (``--speed nan``, ``--loop 0``,
    ``--tol-pos 0``, ``--exit-policy x``) prints ``armctl: error: argument --speed: ...`` and
    exits with code 2, as errors found after parsing do; so do two options that exclude each
    other (``--scene FILE --no-scene``). Missing or unknown arguments and a wrong number of
    values still print the usage, which shows what is expected. Sub-command parsers are of the
    same class.

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
        """Parse, after adding any deferred arguments.

        Options may come anywhere among the positionals: ``reboot CONFIG --port P JOINT`` gives
        the joints to ``JOINT...`` (argparse alone gives an optional positional its empty value
        at ``CONFIG`` already and refuses ``JOINT``), and ``move-to-pose --relative CONFIG``
        leaves ``CONFIG`` to the positional (an option with an optional value takes the next
        word only when it is one of its choices, or a near miss of one, which is refused).
        """
        self._build()
        args = list(sys.argv[1:] if args is None else args)
        fixed = self._no_value_where_no_choice(args)
        if fixed != args:  # kept when the word then fits as a positional, else refused
            self.__dict__["_trial"] = True
            try:
                ns, extras = self._parse(fixed, copy.copy(namespace))
                if not extras:
                    return ns, extras
            except _Refused:
                pass
            finally:
                self.__dict__["_trial"] = False
        return self._parse(args, namespace)

    def _parse(self, args: list[str], namespace: argparse.Namespace | None
               ) -> tuple[argparse.Namespace, list[str]]:
        if self.__dict__.get("_intermixing") or not self._optional_positionals():
            return super().parse_known_args(args, namespace)
        self.__dict__["_intermixing"] = True  # the two passes below call this method again
        try:
            return super().parse_known_intermixed_args(args, namespace)
        finally:
            self.__dict__["_intermixing"] = False

    def _optional_positionals(self) -> bool:
        """Whether a positional takes a variable number of words and no sub-command follows.

        ``*``, ``?`` and ``+``: ``move-joints CONFIG 0 -30 --deg 60 ...`` keeps every value.
        """
        nargs = [a.nargs for a in self._get_positional_actions()]
        return (any(n in (argparse.ZERO_OR_MORE, argparse.OPTIONAL, argparse.ONE_OR_MORE)
                    for n in nargs)
                and not any(n in (argparse.PARSER, argparse.REMAINDER) for n in nargs))

    def _no_value_where_no_choice(self, args: list[str]) -> list[str]:
        """``--opt WORD`` as ``--opt=CONST WORD`` when ``WORD`` is no value of ``--opt``.

        For options with an optional value and choices (``--relative [base|tool]``). A word
        close to a choice (``--relative tol``) stays the option's value, so that it is refused
        with the choices.
        """
        takes = {s: a for a in self._actions if a.nargs == argparse.OPTIONAL
                 and a.option_strings and a.choices is not None and a.const is not None
                 for s in a.option_strings}
        if not takes:
            return args
        out = list(args)
        for i, word in enumerate(args[:-1]):
            if word == "--":
                break
            action = takes.get(word) or _unique_prefix(word, self._option_string_actions)
            if action not in takes.values():
                continue
            assert action is not None  # mypy: one of takes'
            nxt = args[i + 1]
            choices = [str(c) for c in action.choices]  # type: ignore[union-attr]
            if nxt.startswith("-") or nxt in choices or \
                    difflib.get_close_matches(nxt, choices, n=1, cutoff=0.6):
                continue
            out[i] = f"{word}={action.const}"
        return out

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
        if self.__dict__.get("_trial"):
            raise _Refused(message)
        m = _VALUE_ERROR.fullmatch(message)
        if m is not None and m.group("why").startswith(_EXCLUSIVE):
            self.exit(2, f"armctl: error: {message}: they exclude each other, give one or the "
                         f"other; see '{self.prog} --help'\n")
        if m is not None and not m.group("why").startswith(_SHAPE):
            self.exit(2, f"armctl: error: {message}; see '{self.prog} --help'\n")
        super().error(message)


def _unique_prefix(word: str, actions: dict[str, argparse.Action]) -> argparse.Action | None:
    """The action of the one long option that ``word`` abbreviates, if exactly one."""
    if not word.startswith("--") or "=" in word:
        return None
    hits = {a for s, a in actions.items() if s.startswith(word)}
    return hits.pop() if len(hits) == 1 else None


def add_later(parser: argparse.ArgumentParser,
              build: Callable[[argparse.ArgumentParser], None]) -> None:
    """Add arguments with ``build(parser)`` when the parser is first used.

    See :meth:`ArgumentParser.defer`; a plain :class:`argparse.ArgumentParser` gets them now.
    """
    if isinstance(parser, ArgumentParser):
        parser.defer(build)
    else:
        build(parser)
