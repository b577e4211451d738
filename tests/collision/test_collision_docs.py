"""The Python example of docs/collision.md runs as written and prints what it says."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOC = Path(__file__).parent.parent.parent / "docs" / "collision.md"


def test_python_example_runs(capsys: pytest.CaptureFixture[str]) -> None:
    text = DOC.read_text(encoding="utf-8")
    found = re.search(r"^```python\n(.*?)^```", text, re.S | re.M)
    assert found, f"no python block in {DOC}"
    code = found.group(1)
    exec(compile(code, str(DOC), "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "True False"
    assert "gripper_link" in lines[1] and "table" in lines[1]
    assert lines[2] == "gripper_link table 0.51"
    # the comments in the block say the same
    assert "# True False" in code and "# gripper_link table 0.51" in code


def test_ball_joint_example_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """The arm file and the example of "Arms with universal and ball joints", as printed."""
    text = DOC.read_text(encoding="utf-8")
    section = text[text.index("## Arms with universal and ball joints"):]
    arm = re.search(r"^```yaml\n(.*?)^```", section, re.S | re.M)
    code = re.search(r"^```python\n(.*?)^```", section, re.S | re.M)
    assert arm and code
    (tmp_path / "ball_arm.yaml").write_text(arm.group(1), encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    exec(compile(code.group(1), str(DOC), "exec"), {})
    printed = capsys.readouterr().out.splitlines()
    said = [line.split("# ")[-1] for line in code.group(1).splitlines()
            if line.startswith("print(")]
    assert printed == said
