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
