"""The CLI's shape: thin command modules, loops in their own modules, the Robot API underneath."""

from __future__ import annotations

import ast
import pkgutil
from pathlib import Path
from typing import Any

import pytest

import armctl.cli
import armctl.robot
from armctl.cli import build_parser, main
from armctl.robot import Robot

CLI = Path(armctl.cli.__file__).parent


def _command_modules() -> list[Path]:
    return [CLI / f"{m.name}.py" for m in pkgutil.iter_modules([str(CLI)])
            if not m.name.startswith("_")]


def _imports(path: Path) -> set[str]:
    """Every module named by an import statement in ``path`` (also function-local ones)."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
            out.update(f"{node.module}.{a.name}" for a in node.names)
    return out


def test_command_modules_read_no_input() -> None:
    """Interactive loops (teach, sim, the calibration wizard) live in ``_`` modules."""
    modules = _command_modules()
    assert {p.stem for p in modules} >= {"move", "play", "teach", "bus"}
    for path in modules:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        reads = [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Attribute)
                 and n.attr == "stdin" and isinstance(n.value, ast.Name) and n.value.id == "sys"]
        assert not reads, f"{path.name} reads sys.stdin (lines {reads})"


def test_help_lists_the_commands_in_their_order() -> None:
    commands = list(build_parser()._subparsers._group_actions[0].choices)  # type: ignore[union-attr]
    motion = ["move-to-pose", "move-joints", "home", "park", "teach", "play"]
    bus = ["ports", "scan", "status", "torque", "sim", "calibrate"]
    assert commands[commands.index("move-to-pose"):][:6] == motion
    assert commands[commands.index("ports"):][:6] == bus
    assert commands.index("play") < commands.index("ports") < commands.index("render")


def test_robot_session_does_not_import_teach() -> None:
    session = Path(armctl.robot.__file__).parent / "session.py"
    assert not {m for m in _imports(session) if m.startswith("armctl.robot.teach")}


def test_move_to_pose_goes_through_the_robot_api(monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    calls: list[dict[str, Any]] = []
    original = Robot.move_to_pose

    def spy(self: Robot, *args: Any, **kwargs: Any) -> Any:
        calls.append(kwargs)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Robot, "move_to_pose", spy)
    assert main(["move-to-pose", "so101", "--xyz", "0.25", "0.05", "0.15", "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert len(calls) == 1 and calls[0]["on_plan"] is not None
    assert "plan: move to pose" in out and "dry run: nothing moved" in out
