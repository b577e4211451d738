"""YAML documents that remember where each value came from, and a reader that validates them.

Every config file armctl reads (arm, keyframes, goals, calibration, fault scenarios) goes through
:func:`load_yaml` and is then taken apart with :class:`Section`, so that every error names the file,
the key path, the line, what was found and what is expected.

Reading is bounded so that no file, however written, can exhaust the stack, the memory or the
time: :data:`MAX_FILE_BYTES`, :data:`MAX_DEPTH`, :data:`MAX_VALUES`, :data:`MAX_ALIASES`,
:data:`MAX_ALIAS_VALUES` and :data:`MAX_NUMBER_CHARS`; YAML tags other than the core types are
refused. Each limit gives a :class:`~armctl.errors.ConfigError` at the line where it is passed.
"""

from __future__ import annotations

import copy
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
        lines: 1-based line of key paths; a path that has none is on the line of its nearest
            parent that has one (see :meth:`Section.where`).
    """

    data: Any
    file: Path | None = None
    lines: dict[Keys, int] = field(default_factory=dict)

    def root(self) -> Section:
        """A :class:`Section` over the whole document (which must be a mapping)."""
        return Section(self, (), self.data).mapping()


#: Largest config file armctl reads [bytes]; bigger files are refused before parsing.
MAX_FILE_BYTES = 8 * 1024 * 1024
#: Deepest nesting of lists and mappings (aliases expanded).
MAX_DEPTH = 64
#: Most values in one file (every number, string, list and mapping counts one; aliases count
#: what they copy): each takes a few microseconds and up to a few hundred bytes to read.
MAX_VALUES = 500_000
#: Most aliases (``*name``) in one file.
MAX_ALIASES = 1000
#: Most values that aliases may add to a file in all, counted expanded (a list of three numbers
#: counts four: the list and its items).
MAX_ALIAS_VALUES = 100_000
#: Longest number literal [characters]: longer ones are typing accidents (or attacks).
MAX_NUMBER_CHARS = 100

_LOADER: Any = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
_RESOLVER = yaml.resolver.Resolver()
_CONSTRUCTOR = yaml.constructor.SafeConstructor()
_CORE = "tag:yaml.org,2002:"
_STR, _INT, _FLOAT = _CORE + "str", _CORE + "int", _CORE + "float"
_MERGE_TAG, _VALUE_TAG = _CORE + "merge", _CORE + "value"
#: Explicit tags accepted on scalars: YAML's core types, which change nothing but the type.
_SCALAR_TAGS = frozenset({_STR, _INT, _FLOAT, _CORE + "bool", _CORE + "null"})
#: ``1e-3``: a number in YAML 1.2 and to a reader, a string to YAML 1.1 (which wants a dot).
_EXP_FLOAT = re.compile(r"^[-+]?(?:\d+\.?\d*|\.\d+)[eE][-+]?\d+$")


class _Merge:
    """The ``<<`` key of a mapping (YAML merge key)."""


_MERGE = _Merge()


@dataclass(frozen=True)
class _Anchor:
    """A value named with ``&name``: the value, its size and its nesting height."""

    value: Any
    size: int
    height: int


@dataclass
class _Open:
    """A list or mapping whose end event has not come yet.

    Attributes:
        value: The list or dict being filled.
        keys: Its key path.
        line: Its first line.
        anchor: Its ``&name``, if any.
        size: Values inside it, itself included, aliases expanded.
        height: Levels of nesting, itself included.
        key: A mapping's last key.
        key_line: The line of that key.
        waiting: Whether that key still waits for its value.
        merges: ``(value, line)`` of the mapping's ``<<`` keys.
        fallback: The line :meth:`Section.where` finds for this value's own key path; lines of
            items and keys on that same line are not stored (a long flow list on one line then
            costs no memory for its lines).
    """

    value: Any
    keys: Keys
    line: int
    anchor: str | None
    fallback: int
    size: int = 1
    height: int = 1
    key: Any = None
    key_line: int = 0
    waiting: bool = False
    merges: list[tuple[Any, int]] = field(default_factory=list)


def _shown_tag(tag: str) -> str:
    return "!!" + tag[len(_CORE):] if tag.startswith(_CORE) else tag


def _tag_error(tag: str, where: KeyPath) -> ConfigError:
    return ConfigError(f"YAML tags like {_shown_tag(tag)} are not supported", where,
                       "remove the tag and write a plain value (quote it to keep it as text)")


class _Composer:
    """Builds plain Python data from the YAML event stream, without recursion.

    PyYAML's own composer recurses once per level of nesting and expands aliases as often as
    they are used; this one counts the nesting depth, the aliases and the values they add, and
    stops at the first limit (see :data:`MAX_DEPTH`, :data:`MAX_ALIASES`,
    :data:`MAX_ALIAS_VALUES`), so that no file can exhaust the stack, the memory or the time.
    """

    def __init__(self, file: Path | None):
        self.file = file
        self.lines: dict[Keys, int] = {}
        self.stack: list[_Open] = []
        self.anchors: dict[str, _Anchor | None] = {}
        self.root: list[Any] = []
        self.aliases = 0
        self.alias_values = 0
        self.values = 0

    # ---- locations -----------------------------------------------------------------------
    def slot(self) -> Keys:
        """Key path of the next value (its mapping's path while a key is awaited)."""
        if not self.stack:
            return ()
        top = self.stack[-1]
        if isinstance(top.value, list):
            return (*top.keys, len(top.value))
        if top.waiting:
            return (*top.keys, _key_part(top.key))
        return top.keys

    def at(self, line: int, keys: Keys | None = None) -> KeyPath:
        """A location, labelled like :meth:`Section.list_of` labels it (``joints[2] (elbow)``)."""
        label = None
        for frame in self.stack:  # the first list item on the path, if its name is known yet
            if frame.keys and isinstance(frame.keys[-1], int) and isinstance(frame.value, dict):
                name = frame.value.get("name")
                label = name if isinstance(name, str) else None
                break
        return KeyPath(self.file, self.slot() if keys is None else keys, line, label)

    def key_expected(self) -> bool:
        return bool(self.stack) and isinstance(self.stack[-1].value, dict) and (
            not self.stack[-1].waiting)

    # ---- events ---------------------------------------------------------------------------
    def feed(self, event: yaml.Event) -> None:
        line = _line_of(event)
        if isinstance(event, (yaml.ScalarEvent, yaml.CollectionStartEvent)):
            self.count(1, line)
        if isinstance(event, yaml.ScalarEvent):
            value = self.scalar(event, line)
            self.add(value, 1, 0, line)
            if event.anchor is not None:
                self.anchors[event.anchor] = _Anchor(value, 1, 0)
        elif isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            self.start(event, line)
        elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
            self.end()
        elif isinstance(event, yaml.AliasEvent):
            self.alias(event, line)

    def scalar(self, event: yaml.ScalarEvent, line: int) -> Any:
        tag, text = event.tag, event.value
        if tag is None or tag == "!":
            tag = _RESOLVER.resolve(yaml.ScalarNode, text, event.implicit)
            if tag == _STR and event.implicit[0] and _EXP_FLOAT.match(text):
                tag = _FLOAT
        elif tag not in _SCALAR_TAGS:
            raise _tag_error(tag, self.at(line))
        if tag == _STR:
            return text
        if tag == _MERGE_TAG:
            return _MERGE if self.key_expected() else text
        if tag == _VALUE_TAG:
            return text
        if tag in (_INT, _FLOAT) and len(text) > MAX_NUMBER_CHARS:
            raise ConfigError(
                f"the number {text[:20]}... has {len(text)} characters; armctl reads numbers of "
                f"up to {MAX_NUMBER_CHARS}", self.at(line), "write the value with fewer digits")
        construct = _CONSTRUCTOR.yaml_constructors.get(tag)
        if construct is None:
            raise _tag_error(tag, self.at(line))
        node = yaml.ScalarNode(tag, text, style=event.style)
        try:
            return construct(_CONSTRUCTOR, node)
        except (ValueError, KeyError, TypeError, OverflowError, yaml.YAMLError):
            shown = text if len(text) <= 40 else text[:40] + "..."
            raise ConfigError(f"{shown!r} is not a valid {_shown_tag(tag)}", self.at(line),
                              "remove the tag, or write a value of that type") from None

    def start(self, event: yaml.CollectionStartEvent, line: int) -> None:
        mapping = isinstance(event, yaml.MappingStartEvent)
        if event.tag not in (None, "!", _CORE + ("map" if mapping else "seq")):
            raise _tag_error(event.tag, self.at(line))
        if self.key_expected():
            raise ConfigError("a key must be a plain name, not a list or mapping", self.at(line))
        if len(self.stack) >= MAX_DEPTH:
            raise ConfigError(f"lists and mappings are nested more than {MAX_DEPTH} levels deep",
                              self.at(line), "a config file never needs this: check the file")
        keys = self.slot()
        if event.anchor is not None:
            self.anchors[event.anchor] = None  # open: an alias to it here would recurse
        parent = self.stack[-1] if self.stack else None
        fallback = parent.key_line if parent is not None and isinstance(parent.value, dict) else (
            line)
        self.stack.append(_Open({} if mapping else [], keys, line, event.anchor, fallback))

    def end(self) -> None:
        done = self.stack.pop()
        if done.merges:
            self.merge(done)
        if done.anchor is not None:
            self.anchors[done.anchor] = _Anchor(done.value, done.size, done.height)
        self.add(done.value, done.size, done.height, done.line)

    def alias(self, event: yaml.AliasEvent, line: int) -> None:
        name = event.anchor
        if name not in self.anchors:
            raise ConfigError(f"alias *{name} has no anchor &{name} before it", self.at(line),
                              f"define '&{name}' on a value above, or fix the name")
        target = self.anchors[name]
        if target is None:
            raise ConfigError(f"alias *{name} is inside the value &{name} it refers to",
                              self.at(line), "a config file cannot contain itself")
        self.aliases += 1
        self.alias_values += target.size
        self.count(target.size, line)
        if self.aliases > MAX_ALIASES or self.alias_values > MAX_ALIAS_VALUES:
            raise ConfigError(
                f"too many aliases: more than {MAX_ALIASES} aliases, or more than "
                f"{MAX_ALIAS_VALUES} values copied by them (at *{name})", self.at(line),
                "write the values out, or use fewer anchors and aliases")
        if len(self.stack) + target.height > MAX_DEPTH:
            raise ConfigError(f"alias *{name} nests lists and mappings more than {MAX_DEPTH} "
                              "levels deep", self.at(line), "a config file never needs this")
        value = copy.deepcopy(target.value) if target.height else target.value
        self.add(value, target.size, target.height, line)

    # ---- building -------------------------------------------------------------------------
    def count(self, values: int, line: int) -> None:
        self.values += values
        if self.values > MAX_VALUES:
            raise ConfigError(f"the file holds more than {MAX_VALUES} values", self.at(line),
                              "a config file never needs this: check the file")

    def add(self, value: Any, size: int, height: int, line: int) -> None:
        if not self.stack:
            self.root.append(value)
            self.lines[()] = line
            return
        top = self.stack[-1]
        top.size += size
        top.height = max(top.height, height + 1)
        if isinstance(top.value, list):
            if line != top.fallback:
                item: Keys = (*top.keys, len(top.value))
                self.lines[item] = line
            top.value.append(value)
            return
        if not top.waiting:  # a key
            if isinstance(value, (list, dict)):
                raise ConfigError("a key must be a plain name, not a list or mapping",
                                  self.at(line))
            if value is not _MERGE and value in top.value:
                raise ConfigError(f"key {value!r} appears twice in the same mapping",
                                  KeyPath(self.file, (*top.keys, str(value)), line),
                                  "remove or rename one of them")
            top.key, top.key_line, top.waiting = value, line, True
            return
        top.waiting = False
        if top.key is _MERGE:
            top.merges.append((value, top.key_line))
            return
        if top.key_line != top.fallback:
            entry: Keys = (*top.keys, _key_part(top.key))
            self.lines[entry] = top.key_line
        top.value[top.key] = value

    def merge(self, done: _Open) -> None:
        """Apply ``<<: *base`` merge keys: their keys where the mapping has none of its own."""
        for merged, line in done.merges:
            for src in merged if isinstance(merged, list) else [merged]:
                if not isinstance(src, dict):
                    raise ConfigError(f"'<<' merges mappings, found {_type_name(src)}",
                                      KeyPath(self.file, (*done.keys, "<<"), line),
                                      "write '<<: *name' with an anchored mapping '&name'")
                for key, value in src.items():
                    if key not in done.value:
                        done.value[key] = value
                        if line != done.fallback:
                            entry: Keys = (*done.keys, _key_part(key))
                            self.lines[entry] = line


def _line_of(event: yaml.Event) -> int:
    """The 1-based line where an event starts."""
    mark = event.start_mark
    return mark.line + 1 if mark is not None else 0


def _key_part(key: Any) -> str | int:
    return key if isinstance(key, (str, int)) and not isinstance(key, bool) else str(key)


def parse_yaml(text: str, file: Path | None = None) -> Document:
    """Parse YAML text, keeping the line of every key.

    Only plain data is read: mappings, lists, strings, numbers, booleans, null (and dates).
    Anchors, aliases and ``<<`` merge keys work within the limits :data:`MAX_DEPTH`,
    :data:`MAX_ALIASES` and :data:`MAX_ALIAS_VALUES`; tags other than YAML's core types are
    refused. ``1e-3`` is read as a number, as YAML 1.2 does.

    Args:
        text: The YAML source.
        file: The file name used in error messages.

    Returns:
        The parsed :class:`Document`.

    Raises:
        ConfigError: If the text is not valid YAML, repeats a key, uses a tag, or passes a limit.
    """
    if len(text) > MAX_FILE_BYTES:
        raise _too_big(len(text), file)
    composer = _Composer(file)
    documents = 0
    try:
        for event in yaml.parse(text, Loader=_LOADER):
            if isinstance(event, yaml.DocumentStartEvent):
                documents += 1
                if documents > 1:
                    raise ConfigError("the file holds more than one YAML document",
                                      KeyPath(file, (), _line_of(event)),
                                      "remove the second '---' and what follows it")
            composer.feed(event)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        position = getattr(exc, "position", None)
        if line is None and isinstance(position, int):  # a reader error: bad characters
            line = text.count("\n", 0, position) + 1
        problem = getattr(exc, "problem", None) or getattr(exc, "reason", None) or str(exc)
        if "nesting depth" in problem:  # libyaml's own bound, above ours
            raise ConfigError(f"lists and mappings are nested more than {MAX_DEPTH} levels deep",
                              KeyPath(file, (), line), "a config file never needs this: check "
                              "the file") from None
        raise ConfigError(
            f"not valid YAML: {problem}", KeyPath(file, (), line),
            "check indentation, colons and quotes near that line",
        ) from None
    except UnicodeError as exc:
        raise ConfigError(f"not valid YAML: {exc}", KeyPath(file)) from None
    data = composer.root[0] if composer.root else None
    return Document(data, file, composer.lines)


def load_yaml(path: str | Path) -> Document:
    """Read and parse a YAML file.

    Args:
        path: The file.

    Returns:
        The parsed :class:`Document`.

    Raises:
        ConfigError: If the file cannot be read, is larger than :data:`MAX_FILE_BYTES` or is
            not valid YAML.
    """
    p = Path(path)
    return parse_yaml(read_text(p), p)


def _too_big(size: int, file: Path | None) -> ConfigError:
    return ConfigError(
        f"the file is larger than {MAX_FILE_BYTES // (1024 * 1024)} MiB ({size} bytes or more); "
        "armctl reads config files up to that size", KeyPath(file),
        "check that this is the right file")


def read_text(path: str | Path) -> str:
    """The UTF-8 text of a config file (at most :data:`MAX_FILE_BYTES`).

    Raises:
        ConfigError: If the file is missing, too large or cannot be read as text.
    """
    p = Path(path)
    try:
        with p.open("rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)  # bounded even for /dev/zero or a pipe
        if len(raw) > MAX_FILE_BYTES:
            raise _too_big(len(raw), p)
        return raw.decode("utf-8")
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
        shown = value if len(value) <= 60 else value[:60] + "..."
        return f"a string ({shown!r})"
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
        if not self.has(key):  # absent, or present with no value (``key:``): the same if optional
            if required:
                raise self._missing(key, f"add '{key}: ...' here")
            return default
        return self.value[key]

    def _missing(self, key: str, fix: str) -> ConfigError:
        if isinstance(self.value, dict) and key in self.value:
            return self.error(f"key {key!r} has no value", key,
                              fix=f"write a value after '{key}:'")
        return self.error(f"missing required key {key!r}", fix=fix)

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
        if not math.isfinite(x):  # .inf, .nan, 1e309, '1e400 deg'
            raise self.error(f"expected a finite number, found {_type_name(v)}", *keys,
                             fix="write a finite value (a joint that turns without end is "
                             "type 'continuous')")
        if positive and not x > 0:
            raise self.error(f"must be greater than zero, found {x:.6g}", *keys)
        if nonnegative and not x >= 0:
            raise self.error(f"must not be negative, found {x:.6g}", *keys)
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
            raise self._missing(key, f"use one of: {', '.join(choices)}")
        v = self.value[key]
        if not isinstance(v, str) or v not in choices:
            close = difflib.get_close_matches(str(v), choices, n=1)
            fix = f"did you mean {close[0]!r}?" if close else f"use one of: {', '.join(choices)}"
            raise self.error(f"{v!r} is not one of: {', '.join(choices)}", key, fix=fix)
        return parse(v)


def _number_value(v: Any, angle: bool) -> float | None:
    """``v`` as a float in SI units (possibly infinite or NaN), ``None`` if it is no number."""
    if isinstance(v, bool):
        return None
    if isinstance(v, (int, float)):
        try:
            return float(v)
        except OverflowError:  # an int beyond the float range
            return math.inf if v > 0 else -math.inf
    if angle and isinstance(v, str):
        m = _ANGLE.match(v)
        if m:
            x = float(m.group(1))
            return math.radians(x) if m.group(2) == "deg" else x
    return None
