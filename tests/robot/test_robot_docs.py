"""The examples in docs/motion.md run as written on the bundled simulated SO-101."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from armctl.cli import main
from armctl.robot import MoveReport, Robot

DOC = Path(__file__).parent.parent.parent / "docs" / "motion.md"


def _block(heading: str, language: str) -> str:
    """The first fenced code block of ``language`` after ``heading`` in docs/motion.md."""
    text = DOC.read_text(encoding="utf-8")
    found = re.search(rf"^{re.escape(heading)}\n.*?^```{language}\n(.*?)^```", text,
                      re.S | re.M)
    assert found, f"no {language} block after {heading!r} in {DOC}"
    return found.group(1)


def test_keyframe_file_example_plays(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "pick.yaml"
    path.write_text(_block("### The keyframe file", "yaml"))
    assert main(["play", str(path), "so101", "--dry-run", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    names = [k["name"] for k in data["keyframes"]]
    assert names[:3] == ["start", "grasp", "above_cup"] and "down" in names
    # the pose keyframes are reached: FK of the planned joints at those keyframes
    from armctl.motion import load_keyframes

    with Robot.open("so101") as robot:
        program = load_keyframes(path, robot.arm)
        plan = robot.plan_program(program)
    at = {w.name: w.q for w in plan.waypoints}
    assert robot.arm.fk(at["above_cup"])[:3, 3] == pytest.approx([0.22, 0.0, 0.12], abs=1e-3)
    down = robot.arm.fk(at["down"])
    assert down[:3, 3] == pytest.approx([0.2, 0.0, 0.05], abs=1e-3)
    assert down[:3, 2] == pytest.approx([0.0, 0.0, -1.0], abs=1e-3)


def test_python_api_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                 capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "pick.yaml").write_text(_block("### The keyframe file", "yaml"))
    code = _block("## Python API", "python")
    scope: dict[str, object] = {}
    exec(compile(code, str(DOC), "exec"), scope)
    report, robot = scope["report"], scope["robot"]
    assert isinstance(report, MoveReport) and isinstance(robot, Robot)
    assert report.position_error < 2e-3
    assert robot.arm.fk(report.plan.goal)[:3, 3] == pytest.approx([0.25, 0.05, 0.15], abs=2e-3)
    assert capsys.readouterr().out.startswith("[")  # the reached position was printed
