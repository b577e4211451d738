"""YAML documents that remember where each value came from, and a reader that validates them.

Every config file armctl reads (arm, keyframes, goals, calibration, fault scenarios) goes through
:func:`load_yaml` and is then taken apart with :class:`Section`, so that every error names the file,
the key path, the line, what was found and what is expected.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import yaml

from armctl.errors import ConfigError, KeyPath

__all__ = ["Document", "Section", "load_yaml", "parse_yaml", "read_text"]

T = TypeVar("T")
Keys = tuple[str | int, ...]

_ANGLE = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(deg|rad)\s*$")


@dataclass(frozen=True)
class Document:
    """A parsed YAML file plus the line of every key path in it.

    Attributes:
        data: The plain Python value (dicts, lists, scalars).
        file: The file it was read from, or ``None``.
        lines: 1-based line of each key path.
    """

    data: Any
    file: Path | None = None
    lines: dict[Keys, int] = field(default_factory=dict)

    def root(self) -> Section:
        """A :class:`Section` over the whole document (which must be a mapping)."""
        return Section(self, (), self.data).mapping()


def _build(node: yaml.Node, keys: Keys, lines: dict[Keys, int], file: Path | None) -> Any:
    lines[keys] = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        out: dict[Any, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                raise ConfigError("a key must be a plain name, not a list or mapping",
                                  KeyPath(file, keys, key_node.start_mark.line + 1))
            key = _scalar(key_node)
            if key in out:
                raise ConfigError(
                    f"key {key!r} appears twice in the same mapping",
                    KeyPath(file, (*keys, str(key)), key_node.start_mark.line + 1),
                    "remove or rename one of them",
                )
            k = key if isinstance(key, (str, int)) else str(key)
            path = (*keys, k)
            out[key] = _build(value_node, path, lines, file)
            lines[path] = key_node.start_mark.line + 1
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_build(item, (*keys, i), lines, file) for i, item in enumerate(node.value)]
    return _scalar(node)


def _scalar(node: yaml.Node) -> Any:
    if node.tag == "tag:yaml.org,2002:str":
        return node.value
    return yaml.safe_load(yaml.serialize(node))


def parse_yaml(text: str, file: Path | None = None) -> Document:
    """Parse YAML text, keeping the line of every key.

    Args:
        text: The YAML source.
        file: The file name used in error messages.

    Returns:
        The parsed :class:`Document`.

    Raises:
        ConfigError: If the text is not valid YAML or repeats a key.
    """
    try:
        node = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        problem = getattr(exc, "problem", None) or str(exc)
        raise ConfigError(
            f"not valid YAML: {problem}", KeyPath(file, (), line),
            "check indentation, colons and quotes near that line",
        ) from exc
    lines: dict[Keys, int] = {}
    data = None if node is None else _build(node, (), lines, file)
    return Document(data, file, lines)


def load_yaml(path: str | Path) -> Document:
    """Read and parse a YAML file.

    Args:
        path: The file.

    Returns:
        The parsed :class:`Document`.

    Raises:
        ConfigError: If the file cannot be read or is not valid YAML.
    """
    p = Path(path)
    return parse_yaml(read_text(p), p)


def read_text(path: str | Path) -> str:
    """The UTF-8 text of a config file.

    Raises:
        ConfigError: If the file is missing or cannot be read as text.
    """
    p = Path(path)
    try:
        return p.read_text(encoding="utf-8")
    except FileNotFoundError as exc:
        raise ConfigError("file not found", KeyPath(p), "check the path") from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"cannot read the file: {exc}", KeyPath(p)) from exc


def _type_name(value: Any) -> str:
    if value is None:
        return "nothing (null)"
    if isinstance(value, bool):
        return f"a boolean ({value})"
    if isinstance(value, (int, float)):
        return f"a number ({value})"
    if isinstance(value, str):
        return f"a string ({value!r})"
    if isinstance(value, list):
        return f"a list of {len(value)} items"
    if isinstance(value, dict):
        return "a mapping"
    return type(value).__name__


@dataclass(frozen=True)
class Section:
    """A value inside a :class:`Document`, with typed accessors that raise :class:`ConfigError`.

    Attributes:
        doc: The document.
        keys: Key path of this value.
        value: The value itself.
        label: Name of the enclosing list item (e.g. a joint name), used in messages.
    """

    doc: Document
    keys: Keys
    value: Any
    label: str | None = None

    # ---- locations and errors -------------------------------------------------------------
    def where(self, *more: str | int) -> KeyPath:
        """The :class:`KeyPath` of this section or of a key below it."""
        keys = (*self.keys, *more)
        line = None
        probe = keys
        while probe and line is None:
            line = self.doc.lines.get(probe)
            probe = probe[:-1]
        if line is None:
            line = self.doc.lines.get(())
        return KeyPath(self.doc.file, keys, line, self.label)

    def error(self, problem: str, *more: str | int, fix: str | None = None) -> ConfigError:
        """A :class:`ConfigError` located at this section or at a key below it."""
        return ConfigError(problem, self.where(*more), fix)

    def child(self, key: str | int, label: str | None = None) -> Section:
        """The section at ``key`` below this one (which must exist)."""
        return Section(self.doc, (*self.keys, key), self.value[key], label or self.label)

    # ---- shape checks ------------------------------------------------------------------------
    def mapping(self) -> Section:
        """This section, checked to be a mapping."""
        if not isinstance(self.value, dict):
            found = _type_name(self.value)
            raise self.error(f"expected a mapping (key: value lines), found {found}")
        return self

    def check_keys(self, required: Iterable[str], optional: Iterable[str] = ()) -> None:
        """Reject unknown keys (suggesting the nearest valid one) and missing required keys.

        Args:
            required: Keys that must be present.
            optional: Keys that may be present.

        Raises:
            ConfigError: For the first unknown or missing key.
        """
        self.mapping()
        req = list(required)
        allowed = [*req, *optional]
        for key in self.value:
            if key not in allowed:
                close = difflib.get_close_matches(str(key), allowed, n=1, cutoff=0.6)
                fix = f"did you mean {close[0]!r}?" if close else None
                valid = ", ".join(allowed)
                raise self.error(f"unknown key {key!r}; valid keys here: {valid}", str(key),
                                 fix=fix)
        for key in req:
            if key not in self.value:
                raise self.error(f"missing required key {key!r}", fix=f"add '{key}: ...' here")

    def has(self, key: str) -> bool:
        """Whether ``key`` is present (and not null)."""
        return isinstance(self.value, dict) and self.value.get(key) is not None

    def items(self) -> Iterator[tuple[str, Section]]:
        """``(key, section)`` pairs of a mapping."""
        self.mapping()
        for key in self.value:
            yield str(key), self.child(key)

    def list_of(self, key: str, label_key: str | None = "name") -> list[Section]:
        """The items of the list at ``key`` (an absent key gives an empty list).

        Args:
            key: Key of the list.
            label_key: Key whose string value names each item in messages.

        Returns:
            One section per item.
        """
        if not self.has(key):
            return []
        value = self.value[key]
        if not isinstance(value, list):
            raise self.error(f"expected a list ('- ' items), found {_type_name(value)}", key)
        out = []
        for i, item in enumerate(value):
            label = None
            if label_key and isinstance(item, dict) and isinstance(item.get(label_key), str):
                label = item[label_key]
            out.append(Section(self.doc, (*self.keys, key, i), item, label))
        return out

    # ---- scalars -------------------------------------------------------------------------------
    def _get(self, key: str, default: Any, required: bool) -> Any:
        if not self.has(key):
            if required:
                raise self.error(f"missing required key {key!r}", fix=f"add '{key}: ...' here")
            return default
        return self.value[key]

    def string(self, key: str, default: str | None = None, *, required: bool = True) -> str:
        """A non-empty string value."""
        v = self._get(key, default, required and default is None)
        if v is None:
            return ""
        if not isinstance(v, str) or not v.strip():
            raise self.error(f"expected a non-empty string, found {_type_name(v)}", key)
        return v

    def boolean(self, key: str, default: bool) -> bool:
        """A boolean value (``true``/``false``)."""
        v = self._get(key, default, False)
        if not isinstance(v, bool):
            raise self.error(f"expected true or false, found {_type_name(v)}", key)
        return v

    def integer(self, key: str, default: int | None = None, *, lo: int | None = None,
                hi: int | None = None) -> int:
        """An integer value inside ``[lo, hi]``."""
        v = self._get(key, default, default is None)
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.error(f"expected a whole number, found {_type_name(v)}", key)
        if (lo is not None and v < lo) or (hi is not None and v > hi):
            raise self.error(f"{v} is out of range; expected {lo} to {hi}", key)
        return v

    def number(self, key: str, default: float | None = None, *, angle: bool = False,
               positive: bool = False, nonnegative: bool = False) -> float:
        """A finite number; with ``angle=True`` also ``"90 deg"`` or ``"1.2 rad"`` strings.

        Args:
            key: The key.
            default: Value when absent; ``None`` makes the key required.
            angle: Accept angle strings with a unit; plain numbers are radians.
            positive: Require a value > 0.
            nonnegative: Require a value >= 0.

        Returns:
            The value in SI units ([rad] for angles).
        """
        v = self._get(key, default, default is None)
        return self._as_number(v, key, angle=angle, positive=positive, nonnegative=nonnegative)

    def _as_number(self, v: Any, *keys: str | int, angle: bool = False, positive: bool = False,
                   nonnegative: bool = False) -> float:
        x = _number_value(v, angle)
        if x is None:
            expect = "a number (radians) or a string like '90 deg'" if angle else "a number"
            raise self.error(f"expected {expect}, found {_type_name(v)}", *keys)
        if positive and not x > 0:
            raise self.error(f"must be greater than zero, found {x}", *keys)
        if nonnegative and not x >= 0:
            raise self.error(f"must not be negative, found {x}", *keys)
        return x

    def vector(self, key: str, size: int, default: Sequence[float] | None = None, *,
               angle: bool = False) -> tuple[float, ...]:
        """A list of exactly ``size`` numbers.

        Args:
            key: The key.
            size: Required length.
            default: Value when absent; ``None`` makes the key required.
            angle: Items may be angle strings (``"90 deg"``).

        Returns:
            The numbers as a tuple.
        """
        v = self._get(key, default, default is None)
        if not isinstance(v, (list, tuple)) or len(v) != size:
            raise self.error(f"expected a list of {size} numbers, found {_type_name(v)}", key,
                             fix=f"write it as [{', '.join(['0'] * size)}]")
        return tuple(self._as_number(x, key, i, angle=angle) for i, x in enumerate(v))

    def as_vector(self, size: int, *, angle: bool = False) -> tuple[float, ...]:
        """This section's own value as a list of exactly ``size`` numbers."""
        v = self.value
        if not isinstance(v, (list, tuple)) or len(v) != size:
            raise self.error(f"expected a list of {size} numbers, found {_type_name(v)}",
                             fix=f"write it as [{', '.join(['0'] * size)}]")
        return tuple(self._as_number(x, i, angle=angle) for i, x in enumerate(v))

    def choice(self, key: str, parse: Callable[[str], T], choices: Sequence[str],
               default: T | None = None) -> T:
        """A string from a fixed set, converted by ``parse`` (e.g. an enum constructor)."""
        if not self.has(key):
            if default is not None:
                return default
            raise self.error(f"missing required key {key!r}",
                             fix=f"use one of: {', '.join(choices)}")
        v = self.value[key]
        if not isinstance(v, str) or v not in choices:
            close = difflib.get_close_matches(str(v), choices, n=1)
            fix = f"did you mean {close[0]!r}?" if close else f"use one of: {', '.join(choices)}"
            raise self.error(f"{v!r} is not one of: {', '.join(choices)}", key, fix=fix)
        return parse(v)


def _number_value(v: Any, angle: bool) -> float | None:
    if isinstance(v, bool):
        return None
    if isinstance(v, (int, float)):
        return float(v) if math.isfinite(v) else None
    if angle and isinstance(v, str):
        m = _ANGLE.match(v)
        if m:
            x = float(m.group(1))
            return math.radians(x) if m.group(2) == "deg" else x
    return None
