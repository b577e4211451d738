"""The calibration file is written atomically: a failed write keeps the previous calibration."""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Any

import pytest

import armctl.atomic_write as atomic
from armctl.errors import ConfigError
from armctl.servo.calibration import Calibration, JointCalibration


def _calibration(zero: float) -> Calibration:
    return Calibration("so_sim", {
        "shoulder_pan": JointCalibration(1, zero, 0.0, zero - 600, zero + 600, 12),
        "gripper": JointCalibration(6, 1070.0, 0.0, 1070.0, 3026.0, -978)})


@pytest.fixture
def saved(tmp_path: Path) -> tuple[Path, bytes]:
    path = _calibration(2048.0).save(tmp_path / "so_sim.calibration.yaml")
    return path, path.read_bytes()


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def test_save_replaces_the_file_and_loads_back(saved: tuple[Path, bytes]) -> None:
    path, first = saved
    new = _calibration(2100.0)
    assert new.save(path) == path
    assert path.read_bytes() != first
    assert Calibration.load(path) == new
    assert _leftovers(path.parent) == []


@pytest.mark.parametrize("failing", ["fsync", "replace"])
def test_a_failed_write_keeps_the_previous_calibration(
        saved: tuple[Path, bytes], monkeypatch: pytest.MonkeyPatch, failing: str) -> None:
    path, before = saved

    def disk_full(*args: Any, **kwargs: Any) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(atomic.os, failing, disk_full)
    with pytest.raises(ConfigError, match="No space left on device") as info:
        _calibration(2100.0).save(path)
    assert str(path) in str(info.value) and "previous file" in str(info.value)
    assert path.read_bytes() == before
    assert Calibration.load(path) == _calibration(2048.0)
    assert _leftovers(path.parent) == []


def test_a_write_killed_half_way_keeps_the_previous_calibration(
        saved: tuple[Path, bytes], monkeypatch: pytest.MonkeyPatch) -> None:
    """The process is interrupted after half the text went out (as by a kill or Ctrl-C)."""
    path, before = saved
    real_fdopen = os.fdopen

    class HalfWriter:
        def __init__(self, fh: Any):
            self.fh = fh

        def __enter__(self) -> HalfWriter:
            return self

        def __exit__(self, *exc: object) -> None:
            self.fh.close()

        def write(self, text: str) -> int:
            self.fh.write(text[: len(text) // 2])
            self.fh.flush()
            raise KeyboardInterrupt

    monkeypatch.setattr(atomic.os, "fdopen", lambda fd, *a, **k: HalfWriter(
        real_fdopen(fd, *a, **k)))
    with pytest.raises(KeyboardInterrupt):
        _calibration(2100.0).save(path)
    assert path.read_bytes() == before
    assert _leftovers(path.parent) == []


def test_permissions_are_kept_and_a_missing_folder_is_a_clear_error(
        saved: tuple[Path, bytes], tmp_path: Path) -> None:
    path, _ = saved
    assert stat.S_IMODE(path.stat().st_mode) == 0o644
    path.chmod(0o600)
    _calibration(2100.0).save(path)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    with pytest.raises(ConfigError, match="cannot write the file"):
        _calibration(2100.0).save(tmp_path / "missing" / "c.yaml")
