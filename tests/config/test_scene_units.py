"""Scene files: values that can only be degrees or millimetres are refused with the fix."""

from __future__ import annotations

from pathlib import Path

import pytest

from armctl.config.scene_yaml import load_scene
from armctl.errors import ConfigError


@pytest.mark.parametrize(("origin", "size", "problem", "fix"), [
    ("{xyz: [0.3, 0, 0.05], rpy: [0, 0, 45]}", "[0.1, 0.1, 0.1]",
     "rpy[2] is 45 rad, more than a full turn", '"45 deg" or 0.7854'),
    ("{xyz: [0.27, 0.27, 0.15]}", "[50, 50, 300]", "300 m is more than 20 m",
     "300 mm is 0.3 m"),
    ("{xyz: [270, 270, 150]}", "[0.05, 0.05, 0.3]", "270 m is more than 20 m",
     "270 mm is 0.27 m"),
])
def test_unit_mistakes_are_refused(tmp_path: Path, origin: str, size: str, problem: str,
                                   fix: str) -> None:
    f = tmp_path / "scene.yaml"
    f.write_text(f"obstacles:\n  - {{name: box1, shape: box, size: {size}, origin: {origin}}}\n")
    with pytest.raises(ConfigError) as err:
        load_scene(f)
    text = str(err.value)
    assert f"{f}:2:" in text and "obstacles[0] (box1)" in text
    assert problem in text and fix in text


def test_degrees_written_as_degrees_and_metres_are_accepted(tmp_path: Path) -> None:
    f = tmp_path / "scene.yaml"
    f.write_text("obstacles:\n  - {name: box1, shape: box, size: [0.05, 0.05, 0.3], "
                 "origin: {xyz: [0.27, 0.27, 0.15], rpy: [0, 0, \"45 deg\"]}}\n")
    scene = load_scene(f)
    assert scene.obstacles[0].shape.origin.rpy[2] == pytest.approx(0.7853981634)
