"""``armctl teach``: an existing file is never wiped, ``--append`` adds to it, and a failing
command is reported while the session goes on (simulated bus)."""

from __future__ import annotations

import io
import math
from pathlib import Path

import pytest

from armctl.arm import load_arm
from armctl.cli import main
from armctl.config.motion import ExitPolicy
from armctl.errors import InputError
from armctl.motion import AngleUnit, load_keyframes
from armctl.robot import Robot
from armctl.robot.teach import ExistingFile, TeachSession

OLD = """\
armctl_keyframes: 1
arm: so101
units: {angle: deg, length: m}
joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]
keyframes:
- {name: a, q: [0, -10, 20, 10, 0], gripper: 30}
- {name: b, q: [10, -20, 30, 10, 0]}
"""


def teach(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, path: Path,
          commands: str, *flags: str) -> tuple[int, str, str]:
    monkeypatch.setattr("sys.stdin", io.StringIO(commands))
    code = main(["teach", "so101", "-o", str(path), "--stiff", *flags])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def test_an_existing_file_is_refused_and_kept(capsys: pytest.CaptureFixture[str],
                                              monkeypatch: pytest.MonkeyPatch,
                                              tmp_path: Path) -> None:
    path = tmp_path / "pick.yaml"
    path.write_text(OLD)
    code, _, err = teach(capsys, monkeypatch, path, "k new\nq\n")
    assert code == 2 and "--append" in err and "--force" in err
    assert "SIMULATED BUS" not in err  # refused before the bus opened
    assert path.read_text() == OLD


def test_force_overwrites(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
                          tmp_path: Path) -> None:
    path = tmp_path / "pick.yaml"
    path.write_text(OLD)
    code, _, err = teach(capsys, monkeypatch, path, "k new\nq\n", "--force")
    assert code == 0, err
    prog = load_keyframes(path, load_arm("so101"))
    assert [kf.name for kf in prog.keyframes] == ["new"]
    assert prog.angle_unit is AngleUnit.RAD


def test_append_adds_and_keeps_the_file_units(capsys: pytest.CaptureFixture[str],
                                              monkeypatch: pytest.MonkeyPatch,
                                              tmp_path: Path) -> None:
    path = tmp_path / "pick.yaml"
    path.write_text(OLD)
    code, _, err = teach(capsys, monkeypatch, path, "k c\nq\n", "--append")
    assert code == 0, err
    prog = load_keyframes(path, load_arm("so101"))
    assert [kf.name for kf in prog.keyframes] == ["a", "b", "c"]
    assert prog.angle_unit is AngleUnit.DEG  # the file's unit, although --deg was not given
    assert prog.keyframes[0].gripper == pytest.approx(math.radians(30))
    assert prog.keyframes[1].q == pytest.approx(tuple(math.radians(v)
                                                      for v in (10, -20, 30, 10, 0)))
    assert "{name: b, q: [10.0, -20.0, 30.0, 10.0, 0.0]}" in path.read_text()


def test_a_failing_command_does_not_end_the_session(capsys: pytest.CaptureFixture[str],
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    tmp_path: Path) -> None:
    path = tmp_path / "jog.yaml"
    commands = ("j elbow_flex 500\n"       # far outside the joint's limits
                "x 0 0 900\n"              # unreachable straight line
                "j no_joint 5\n"           # unknown joint
                "j elbow_flex nan\n"       # not a number
                "g 3000\n"                 # gripper value outside its limits
                "c 1000\n"                 # recording rate outside 1-100 Hz
                "k after\nq\n")
    code, out, err = teach(capsys, monkeypatch, path, commands)
    assert code == 0, err
    assert out.count("error:") == 6, out
    prog = load_keyframes(path, load_arm("so101"))
    assert [kf.name for kf in prog.keyframes] == ["after"]


def test_the_python_api_refuses_to_wipe_a_file(tmp_path: Path) -> None:
    path = tmp_path / "pick.yaml"
    path.write_text(OLD)
    with Robot.open("so101", exit_policy=ExitPolicy.HOLD) as robot:
        with pytest.raises(InputError, match="exists already"):
            TeachSession(robot, path)
        session = TeachSession(robot, path, existing=ExistingFile.APPEND)
        assert len(session.program.keyframes) == 2
        with pytest.raises(InputError, match=r"did you mean 0\.5236 rad"):
            session.record(gripper=30.0)
    assert path.read_text() == OLD
