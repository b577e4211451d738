"""Messages of the exception tree: suggestions, punctuation, locations, exit codes."""

from __future__ import annotations

from pathlib import Path

import pytest

from armctl.errors import (
    BusError,
    ConfigError,
    JointLimitError,
    KeyPath,
    MotionAborted,
    NoSolutionError,
    UnknownNameError,
)


def test_unknown_name_suggests_a_close_name_or_a_close_word() -> None:
    names = ["shoulder_pan", "elbow_flex", "gripper"]
    err = UnknownNameError("joint", "gripr", names, "arm 'a'")
    assert str(err).startswith("unknown joint 'gripr' in arm 'a'; did you mean 'gripper'? ")
    assert "elbow_flex" in str(UnknownNameError("joint", "elbw", names)).split("?")[0]
    plain = str(UnknownNameError("joint", "zzz", names))
    assert plain.startswith("unknown joint 'zzz'. Valid joint names: 'shoulder_pan'")
    assert ".." not in plain and "?." not in plain
    assert isinstance(err, KeyError) and err.exit_code == 2


def test_config_error_location_and_fix() -> None:
    where = KeyPath(Path("arm.yaml"), ("joints", 2, "limits", "upper"), 14, "elbow")
    err = ConfigError("too big", where, "make it smaller")
    expected = "arm.yaml:14: joints[2] (elbow).limits.upper: too big\n  fix: make it smaller"
    assert str(err) == expected
    assert str(ConfigError("file not found", KeyPath(Path("x.yaml")))) == "x.yaml: file not found"


def test_exit_codes() -> None:
    assert JointLimitError("j", 2.0, -1.0, 1.0).exit_code == 2
    assert NoSolutionError("x").exit_code == 3
    assert BusError("x").exit_code == 4
    assert MotionAborted("x").exit_code == 5
    with pytest.raises(ValueError, match="outside its limits"):
        raise JointLimitError("j", 2.0, -1.0, 1.0)
