"""Motion logs: the CSV text, the round trip, and the refusals before a motion."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from armctl.errors import ConfigError
from armctl.robot.motion_log import (
    MotionLog,
    check_log_target,
    read_log,
    tracking_errors,
    write_log,
)


def _log() -> MotionLog:
    t = np.arange(5) * 0.01
    cmd = np.column_stack([np.linspace(0, 0.5, 5), np.linspace(0.0, 0.02, 5)])
    meas = cmd + np.array([[0.0, 0.0], [0.01, -0.001], [0.02, 0.0], [-0.01, 0.002],
                           [0.0, 0.0]])
    return MotionLog("rig", 100.0, ("hinge", "slide"), (False, True), t, cmd, meas)


def test_the_text_names_each_column_and_its_unit() -> None:
    lines = _log().to_text().splitlines()
    assert lines[0] == ("# armctl motion log; arm=rig; rate_hz=100; units=SI; "
                        "joints=hinge:revolute,slide:prismatic")
    assert lines[1] == "t,hinge_cmd,hinge_meas,slide_cmd,slide_meas"
    assert lines[3].split(",") == ["0.010000", "0.125", "0.135", "0.005", "0.004"]
    assert len(lines) == 2 + 5


def test_round_trip(tmp_path: Path) -> None:
    log = _log()
    path = write_log(tmp_path / "m.csv", log)
    back = read_log(path)
    assert (back.arm, back.rate_hz, back.joints, back.prismatic) == \
        ("rig", 100.0, ("hinge", "slide"), (False, True))
    np.testing.assert_allclose(back.t, log.t)
    np.testing.assert_allclose(back.cmd, log.cmd, rtol=1e-8)
    np.testing.assert_allclose(back.meas, log.meas, rtol=1e-8)


def test_tracking_errors_are_degrees_and_millimetres() -> None:
    errors = tracking_errors(_log())
    assert errors["hinge"]["unit"] == "deg" and errors["slide"]["unit"] == "mm"
    assert errors["hinge"]["max"] == pytest.approx(math.degrees(0.02))
    assert errors["hinge"]["rms"] == pytest.approx(
        math.degrees(math.sqrt((0.01 ** 2 + 0.02 ** 2 + 0.01 ** 2) / 5)))
    assert errors["slide"]["max"] == pytest.approx(2.0)
    assert errors["slide"]["rms"] == pytest.approx(math.sqrt((1.0 + 4.0) / 5))


def test_a_log_target_must_be_new_in_an_existing_folder(tmp_path: Path) -> None:
    assert check_log_target(tmp_path / "new.csv") == tmp_path / "new.csv"
    (tmp_path / "old.csv").write_text("x")
    with pytest.raises(ConfigError, match="already exists"):
        check_log_target(tmp_path / "old.csv")
    with pytest.raises(ConfigError, match="does not exist"):
        check_log_target(tmp_path / "nope" / "new.csv")
    for name in ("run.yaml", "run.txt", "run"):
        with pytest.raises(ConfigError, match=r"does not end in '\.csv'"):
            check_log_target(tmp_path / name)
    assert sorted(f.name for f in tmp_path.iterdir()) == ["old.csv"]  # nothing written


def test_time_going_back_is_refused_with_its_line(tmp_path: Path) -> None:
    text = _log().to_text().splitlines()
    text[4], text[5] = text[5], text[4]
    bad = tmp_path / "back.csv"
    bad.write_text("\n".join(text) + "\n")
    with pytest.raises(ConfigError, match="goes back") as exc:
        read_log(bad)
    assert f"{bad}:6" in str(exc.value)
