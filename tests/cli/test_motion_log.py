"""``--log FILE.csv`` on the motion commands and ``armctl plot`` of the log they write."""

from __future__ import annotations

import csv
import itertools
import json
import math
import struct
from pathlib import Path

import pytest

from armctl.cli import main
from armctl.cli._progress import Progress

pytestmark = [pytest.mark.timeout(60), pytest.mark.usefixtures("simulated_time")]

SO_JOINTS = ["shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll",
             "gripper"]
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    return code, out, err


def read_csv(path: Path) -> tuple[str, list[str], list[list[float]]]:
    """The comment line, the column names and the rows, read with the csv module."""
    with path.open(newline="") as fh:
        comment = fh.readline().rstrip("\n")
        reader = csv.reader(fh)
        columns = next(reader)
        rows = [[float(v) for v in row] for row in reader]
    return comment, columns, rows


def png_size(path: Path) -> tuple[int, int]:
    """Width and height from the IHDR chunk of a PNG (the signature checked first)."""
    data = path.read_bytes()
    assert data[:8] == PNG_SIGNATURE
    assert data[12:16] == b"IHDR"
    width, height = struct.unpack(">II", data[16:24])
    return width, height


def test_park_logs_every_cycle_and_plot_reports_its_errors(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "park.csv"
    code, _, err = run(capsys, "park", "so101", "--sim", "--log", str(log))
    assert code == 0
    assert f"cycles written to {log}" in err
    comment, columns, rows = read_csv(log)
    assert comment.startswith("# armctl motion log") and "arm=so101" in comment
    assert "rate_hz=50" in comment and "units=SI" in comment
    assert columns == ["t", *(f"{j}_{w}" for j in SO_JOINTS for w in ("cmd", "meas"))]
    assert len(rows) > 20
    times = [r[0] for r in rows]
    assert times[0] == pytest.approx(0.0)
    steps = {round(b - a, 6) for a, b in itertools.pairwise(times)}
    assert steps == {0.02}  # one row per 50 Hz cycle, planned times
    # the last command is the park pose (radians), and the arm got there
    lift = columns.index("shoulder_lift_cmd")
    assert math.degrees(rows[-1][lift]) == pytest.approx(-99.69, abs=0.05)
    assert abs(rows[-1][lift + 1] - rows[-1][lift]) < math.radians(1.0)

    png = tmp_path / "tracking.png"
    code, out, _ = run(capsys, "plot", str(log), "-o", str(png), "--json")
    assert code == 0
    width, height = png_size(png)
    assert width > 400 and height > 400
    report = json.loads(out)
    assert report["cycles"] == len(rows) and report["arm"] == "so101"
    for joint in SO_JOINTS:  # every joint of the so101 is revolute: degrees
        c, m = columns.index(f"{joint}_cmd"), columns.index(f"{joint}_meas")
        errs = [math.degrees(abs(r[m] - r[c])) for r in rows]
        got = report["tracking_error"][joint]
        assert got["unit"] == "deg"
        assert got["max"] == pytest.approx(max(errs), abs=1e-6)
        assert got["rms"] == pytest.approx(math.sqrt(sum(e * e for e in errs) / len(errs)),
                                           abs=1e-6)
    assert report["tracking_error"]["shoulder_lift"]["max"] > 0.01  # the arm lags a little

    before = png.read_bytes()
    code, _, err = run(capsys, "plot", str(log), "-o", str(png))
    assert code == 2 and "already exists" in err and "--force" in err
    assert png.read_bytes() == before
    assert run(capsys, "plot", str(log), "-o", str(png), "--force")[0] == 0


def test_an_existing_log_or_a_missing_folder_is_refused_before_anything_moves(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    old = tmp_path / "old.csv"
    old.write_text("keep me\n")
    code, _, err = run(capsys, "move-joints", "so101", *["0.1"] * 6, "--sim", "--log", str(old))
    assert code == 2 and "already exists" in err and "nothing was moved" in err
    assert "SIMULATED BUS" not in err  # refused before the bus opened
    assert old.read_text() == "keep me\n"
    missing = tmp_path / "no_such_folder" / "x.csv"
    code, _, err = run(capsys, "home", "so101", "--sim", "--log", str(missing))
    assert code == 2 and "does not exist" in err and "SIMULATED BUS" not in err
    assert not missing.parent.exists()


def test_a_dry_run_writes_no_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "dry.csv"
    code, _, _ = run(capsys, "move-joints", "so101", *["0.1"] * 6, "--sim", "--dry-run",
                     "--log", str(log))
    assert code == 0 and not log.exists()


def test_a_stopped_motion_logs_the_cycles_that_ran(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[float] = []
    plain = Progress.__call__

    def ctrl_c_after_ten(self: Progress, info: object) -> None:
        seen.append(0.0)
        if len(seen) == 10:
            raise KeyboardInterrupt
        plain(self, info)  # type: ignore[arg-type]

    monkeypatch.setattr(Progress, "__call__", ctrl_c_after_ten)
    log = tmp_path / "stopped.csv"
    code, _, err = run(capsys, "park", "so101", "--sim", "--log", str(log))
    assert code != 0 and "stopped" in err.lower()
    _, columns, rows = read_csv(log)
    assert 10 <= len(rows) < 70  # the cycles up to the stop and the deceleration, not the plan
    lift = columns.index("shoulder_lift_cmd")
    assert math.degrees(rows[-1][lift]) > -90.0  # it never got near the park pose


def test_gripper_logs_too(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "grip.csv"
    code, _, _ = run(capsys, "gripper", "so101", "open", "--sim", "--log", str(log))
    assert code == 0
    _, columns, rows = read_csv(log)
    g = columns.index("gripper_cmd")
    assert rows[-1][g] > rows[0][g]


@pytest.mark.parametrize(("text", "where", "what"), [
    ("t,a_cmd,a_meas\n0,0,0\n", ":1:", "not an armctl motion log"),
    ("# armctl motion log; arm=x; rate_hz=50; units=SI; joints=a:revolute\n"
     "t,a_cmd,a_meas\n0,0,0\n0.02,0.1\n", ":4:", "2 values"),
    ("# armctl motion log; arm=x; rate_hz=50; units=SI; joints=a:revolute\n"
     "t,a_cmd,a_meas\n0,0,zero\n", ":3:", "not a number"),
    ("# armctl motion log; arm=x; rate_hz=50; units=SI; joints=a:hinge\n"
     "t,a_cmd,a_meas\n0,0,0\n", ":1:", "NAME:revolute"),
    ("# armctl motion log; arm=x; rate_hz=50; units=SI; joints=a:revolute\n"
     "t,b_cmd,b_meas\n0,0,0\n", ":2:", "column names"),
    ("# armctl motion log; arm=x; rate_hz=50; units=SI; joints=a:revolute\n"
     "t,a_cmd,a_meas\n", ":2:", "no cycles"),
    ("", ":1:", "empty"),
])
def test_plot_refuses_a_garbled_log(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                    text: str, where: str, what: str) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    png = tmp_path / "out.png"
    code, _, err = run(capsys, "plot", str(bad), "-o", str(png))
    assert code == 2
    assert f"{bad}{where}" in err and what in err and "fix:" in err
    assert not png.exists()


def test_plot_refuses_a_missing_log(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = run(capsys, "plot", str(tmp_path / "none.csv"), "-o", str(tmp_path / "o.png"))
    assert code == 2 and "does not exist" in err and "--log" in err
