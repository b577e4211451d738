"""Writes the ``collision:`` section of an existing arm YAML file, leaving the rest as it was.

``armctl collisions CONFIG --generate --write`` stores the allowed-collision matrix it found
with :func:`replace_collision_section`: the old section (from its key to the end of its last
value) is replaced by the new one, or the new one is appended when the file has none. Every other
byte of the file, comments included, stays as it was; comments inside the old section go with
it. The new text is read back as an arm before it is written (atomically), so a file that would
not load, or would load a different matrix, is never written.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from armctl.atomic_write import write_atomic
from armctl.config.arm_yaml import parse_arm
from armctl.config.scene import CollisionSpec
from armctl.config.scene_yaml import check_collision
from armctl.config.source import parse_yaml, read_text
from armctl.config.writer import collision_section
from armctl.errors import ConfigError, KeyPath

__all__ = ["replace_collision_section", "with_collision_section"]

_log = logging.getLogger(__name__)

_KEY = "collision"


@dataclass(frozen=True)
class _Span:
    """Where the top-level ``collision:`` key and its value are in the text (characters)."""

    start: int  # the start of the key's line
    end: int  # just past the line end after the value's last character


def replace_collision_section(path: str | Path, spec: CollisionSpec) -> Path:
    """Write ``spec`` as the ``collision:`` section of an arm YAML file, atomically.

    Args:
        path: The arm YAML file.
        spec: The allowed-collision matrix; its links must be links of the arm (or ``table``).

    Returns:
        The path written.

    Raises:
        ConfigError: If the file does not load as an arm, a pair names an unknown link or is
            listed twice, the file's layout does not allow the section to be replaced (a
            flow-style top level), or the file cannot be written; the file is then unchanged.
    """
    p = Path(path)
    text = with_collision_section(read_text(p), spec, p)
    write_atomic(p, text)
    _log.info("wrote the collision section of %s (%d allowed pairs)", p, len(spec.allowed))
    return p


def with_collision_section(text: str, spec: CollisionSpec, file: Path | None = None) -> str:
    """``text`` (an arm YAML file) with its ``collision:`` section replaced by ``spec``.

    Args:
        text: The file's text.
        spec: The allowed-collision matrix.
        file: The file's name, for error messages.

    Returns:
        The new text: the same characters outside the section, which is replaced in place or
        appended at the end.

    Raises:
        ConfigError: As :func:`replace_collision_section`.
    """
    arm = parse_arm(parse_yaml(text, file))  # the file as it is must load
    try:
        check_collision(spec, [lk.name for lk in arm.links])
    except ConfigError as exc:
        raise ConfigError(f"{exc.problem} in the collision matrix to write; the file was not "
                          "changed", KeyPath(file, (_KEY,)), exc.fix) from exc
    newline = "\r\n" if "\r\n" in text else "\n"
    block = newline.join(collision_section(spec)) + newline
    span = _find_section(text, file)
    if span is None:
        head = text if not text or text.endswith(("\n", "\r")) else text + newline
        new_text = head + block
    else:
        new_text = text[:span.start] + block + text[span.end:]
    try:
        written = parse_arm(parse_yaml(new_text, file))
    except ConfigError as exc:
        raise ConfigError(f"the file would not load with the new collision section "
                          f"({exc.problem}); it was not changed", KeyPath(file),
                          "check the file's layout around its 'collision:' section") from exc
    if written.collision != spec:
        raise ConfigError("the new collision section does not read back as written; the file "
                          "was not changed", KeyPath(file),
                          "check the file's layout around its 'collision:' section")
    return new_text


def _find_section(text: str, file: Path | None) -> _Span | None:
    """The span of the top-level ``collision:`` key and its value, ``None`` if there is none."""
    depth = 0
    is_key = True  # at depth 1: the next node is a key of the top-level mapping
    key_start: int | None = None  # set once the collision key is found
    last = -1  # end of the last character of its value seen so far
    flow: list[bool] = []  # flow style of the open collections below the top level
    for event in yaml.parse(text, Loader=yaml.SafeLoader):
        start, line = _mark(event.start_mark)
        end = _mark(event.end_mark)[0]
        if isinstance(event, yaml.CollectionStartEvent):
            if depth == 0 and event.flow_style:
                raise ConfigError("the top level of the file is written in flow style "
                                  "('{...}'); the collision section cannot be replaced in it",
                                  KeyPath(file, (), line),
                                  "write the top level as 'key: value' lines")
            if depth > 0:
                flow.append(bool(event.flow_style))
            depth += 1
            continue
        if isinstance(event, yaml.CollectionEndEvent):
            if depth == 1:
                break
            depth -= 1
            if flow.pop() and key_start is not None:
                last = max(last, end)
            if depth > 1:
                continue
        elif isinstance(event, (yaml.ScalarEvent, yaml.AliasEvent)):
            if key_start is not None:
                last = max(last, end)
            if depth > 1:
                continue
            if is_key and isinstance(event, yaml.ScalarEvent) and event.value == _KEY:
                line_start = text.rfind("\n", 0, start) + 1
                if text[line_start:start].strip():
                    raise ConfigError("the 'collision:' key does not start its line",
                                      KeyPath(file, (_KEY,), line),
                                      "put 'collision:' at the start of a line")
                key_start, last = line_start, end
        else:
            continue
        # a node of the top-level mapping is complete
        if not is_key and key_start is not None:
            return _Span(key_start, _line_end(text, last))
        is_key = not is_key
    return None


def _mark(mark: Any) -> tuple[int, int]:
    """The character index and the 1-based line of a parser mark (always set here)."""
    assert mark is not None
    return mark.index, mark.line + 1


def _line_end(text: str, index: int) -> int:
    """Just past the line end of the last non-blank character before ``index``."""
    while index > 0 and text[index - 1] in " \t\r\n":
        index -= 1
    nl = text.find("\n", index)
    return len(text) if nl < 0 else nl + 1
