"""The library logs (``armctl.*`` loggers) and never prints; the command line shows its warnings."""

from __future__ import annotations

import ast
import logging

import pytest
from armctl_testpaths import REPO

from armctl.cli import main

LIBRARY = [p for p in sorted((REPO / "armctl").rglob("*.py"))
           if (REPO / "armctl" / "cli") not in p.parents]


def _prints(source: str, name: str) -> list[str]:
    """``print(...)`` calls and uses of ``sys.stdout``/``sys.stderr`` in a module's source."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and \
                node.func.id == "print":
            found.append(f"{name}:{node.lineno}: print")
        if isinstance(node, ast.Attribute) and node.attr in ("stdout", "stderr") and \
                isinstance(node.value, ast.Name) and node.value.id == "sys":
            found.append(f"{name}:{node.lineno}: sys.{node.attr}")
    return found


def test_the_library_does_not_print() -> None:
    assert len(LIBRARY) > 50 and not any(p.name == "_common.py" for p in LIBRARY)
    found = [hit for path in LIBRARY
             for hit in _prints(path.read_text(encoding="utf-8"), str(path.relative_to(REPO)))]
    assert found == [], "use logging.getLogger(__name__) in the library (print only in cli)"


def test_the_check_sees_a_print() -> None:
    source = "import sys\nprint('x')\nsys.stderr.write('y')\nlog.warning('z')\n"
    assert _prints(source, "m.py") == ["m.py:2: print", "m.py:3: sys.stderr"]


def test_the_command_line_shows_library_warnings_on_stderr(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["arms"]) == 0  # any command sets the command line's logging up
    capsys.readouterr()
    logging.getLogger("armctl.robot.session").warning("releasing torque: %s", "a test")
    logging.getLogger("armctl.robot.session").info("not shown")
    captured = capsys.readouterr()
    assert captured.err == "armctl: releasing torque: a test\n" and captured.out == ""
