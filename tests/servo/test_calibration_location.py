"""Where calibrations are written: beside a user's config, outside the installed package."""

from __future__ import annotations

from pathlib import Path

import pytest

from armctl.config import bundled_configs_dir, load_spec
from armctl.servo.calibration import calibration_path, user_calibration_dir


def test_a_bundled_arm_is_calibrated_into_the_user_folder(monkeypatch: pytest.MonkeyPatch,
                                                          tmp_path: Path) -> None:
    monkeypatch.setenv("ARMCTL_HOME", str(tmp_path))
    path = calibration_path(load_spec("koch_follower"))
    assert path == tmp_path / "calibration" / "koch_follower.calibration.yaml"
    assert bundled_configs_dir() not in path.parents


def test_without_armctl_home_the_xdg_config_folder(monkeypatch: pytest.MonkeyPatch,
                                                   tmp_path: Path) -> None:
    monkeypatch.delenv("ARMCTL_HOME", raising=False)
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path))
    assert user_calibration_dir() == tmp_path / "armctl" / "calibration"
    monkeypatch.delenv("XDG_CONFIG_HOME")
    monkeypatch.setenv("HOME", str(tmp_path))
    assert user_calibration_dir() == tmp_path / ".config" / "armctl" / "calibration"


def test_a_users_config_keeps_its_calibration_beside_it(tmp_path: Path) -> None:
    config = tmp_path / "my_arm.yaml"
    config.write_text((bundled_configs_dir() / "so101.yaml").read_text())
    assert calibration_path(load_spec(config)) == tmp_path / "my_arm.calibration.yaml"


def test_a_new_measurement_keeps_the_previous_file(tmp_path: Path) -> None:
    from armctl.cli.bus import keep_previous

    out = tmp_path / "arm.calibration.yaml"
    assert keep_previous(out) is None  # nothing to keep
    out.write_text("first\n")
    kept = keep_previous(out)
    assert kept == tmp_path / "arm.calibration.previous.yaml"
    assert kept.read_text() == "first\n" and out.read_text() == "first\n"
