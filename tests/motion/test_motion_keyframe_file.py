"""The keyframe file: round trip, units, clear errors, atomic writes."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.errors import ConfigError
from armctl.motion import (
    AngleUnit,
    Interpolation,
    Keyframe,
    KeyframeProgram,
    load_keyframes,
    save_keyframes,
)
from armctl.motion.keyframe_file import parse_keyframes
from armctl.spatial import make_transform, rpy_to_matrix

ARM3G = Path(__file__).parent / "data" / "arm3g.yaml"  # planar 3R + prismatic gripper


@pytest.fixture(scope="module")
def arm3g() -> Arm:
    return load_arm(ARM3G)


HEAD = "armctl_keyframes: 1\narm: arm3g\njoints: [j1, j2, j3]\n"


def test_round_trip_in_degrees_and_radians(arm3g: Arm, tmp_path: Path) -> None:
    pose = make_transform(rpy_to_matrix([0.1, -0.2, 0.3]), [0.4, 0.1, 0.0])
    kfs = (Keyframe(q=(0.1, -0.5, 1.0), name="a", dwell=0.25, gripper=0.02),
           Keyframe(pose=pose, name="b"), Keyframe(q=(0.0, 0.2, -0.3), time=1.5))
    for unit in AngleUnit:
        prog = KeyframeProgram("arm3g", ("j1", "j2", "j3"), kfs, calibration="sha256:ab12",
                               angle_unit=unit)
        path = save_keyframes(prog, tmp_path / f"p_{unit.value}.yaml", arm3g)
        back = load_keyframes(path, arm3g)
        assert back.calibration == "sha256:ab12" and back.angle_unit is unit
        assert np.allclose(back.keyframes[0].q, kfs[0].q, atol=1e-6)
        assert back.keyframes[0].dwell == 0.25 and back.keyframes[0].gripper == 0.02
        assert np.allclose(back.keyframes[1].pose, pose, atol=1e-6)
        assert back.keyframes[2].time == 1.5 and back.keyframes[1].name == "b"
    text = (tmp_path / "p_deg.yaml").read_text()
    assert "angle: deg" in text and f"{math.degrees(0.1):.5f}" in text


def test_degrees_apply_to_rotary_joints_only(arm3g: Arm) -> None:
    doc = ("armctl_keyframes: 1\narm: arm3g\nunits: {angle: deg}\njoints: [j1, finger]\n"
           "keyframes:\n  - {q: [90, 0.02]}\n  - {q: ['1 rad', 0.01]}\n")
    prog = parse_keyframes(doc, arm3g)
    assert prog.keyframes[0].q == pytest.approx((math.pi / 2, 0.02))
    assert prog.keyframes[1].q == pytest.approx((1.0, 0.01))


@pytest.mark.parametrize(("body", "where", "message"), [
    ("keyframes:\n  - {q: [0, 0]}\n", "keyframes[0].q", "expected a list of 3 numbers"),
    ("keyframes:\n  - {q: [0, 0, 0], dwel: 1}\n", "keyframes[0].dwel", "did you mean 'dwell'"),
    ("keyframes:\n  - {name: x}\n", "keyframes[0] (x)", "exactly one of 'q'"),
    ("keyframes:\n  - {q: [0, 0, 0], dwell: -1}\n", "keyframes[0].dwell", "must not be negative"),
    ("keyframes:\n  - {q: [0, 0, 0], time: 2}\n  - {q: [0, 0, 1], time: 1}\n", "keyframes",
     "times must increase"),
    ("keyframes:\n  - {pose: {xyz: [0, 0], rpy: [0, 0, 0]}}\n", "keyframes[0].pose.xyz",
     "list of 3 numbers"),
    ("keyframes:\n  - {q: [0, 0, 0]}\n  - {q: [0, 0, 1], interpolation: spline}\n",
     "keyframes[1].interpolation", "unknown interpolation 'spline'"),
])
def test_errors_name_file_key_and_line(arm3g: Arm, tmp_path: Path, body: str, where: str,
                                       message: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(HEAD + body)
    with pytest.raises(ConfigError) as info:
        load_keyframes(path, arm3g)
    text = str(info.value)
    assert str(path) in text and where in text and message in text
    assert info.value.where.line is not None


def test_header_errors(arm3g: Arm) -> None:
    with pytest.raises(ConfigError, match="taught on arm 'so100'"):
        parse_keyframes("armctl_keyframes: 1\narm: so100\njoints: [j1]\nkeyframes: []\n", arm3g)
    with pytest.raises(ConfigError, match="newer than this armctl"):
        parse_keyframes("armctl_keyframes: 7\narm: arm3g\njoints: [j1]\nkeyframes: []\n", arm3g)
    with pytest.raises(ConfigError, match=r"(?s)unknown joint 'j4'.*joints of 'arm3g': j1, j2"):
        parse_keyframes("armctl_keyframes: 1\narm: arm3g\njoints: [j4]\nkeyframes: []\n", arm3g)
    with pytest.raises(ConfigError, match="missing required key 'arm'"):
        parse_keyframes("armctl_keyframes: 1\njoints: [j1]\nkeyframes: []\n", arm3g)


def test_failed_write_keeps_the_previous_file(arm3g: Arm, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    path = tmp_path / "prog.yaml"
    prog = KeyframeProgram("arm3g", ("j1", "j2", "j3"), (Keyframe(q=(0.0, 0.1, 0.2)),))
    save_keyframes(prog, path, arm3g)
    before = path.read_text()

    def crash(src: str, dst: str) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(ConfigError, match="cannot write"):
        save_keyframes(prog.append(Keyframe(q=(1.0, 1.0, 1.0))), path, arm3g)
    assert path.read_text() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["prog.yaml"]  # no temp file left


def test_per_keyframe_interpolation_round_trips_and_is_optional(arm3g: Arm,
                                                                tmp_path: Path) -> None:
    kfs = (Keyframe(q=(0.0, 0.0, 0.0)),
           Keyframe(q=(0.3, 0.1, 0.0), interpolation=Interpolation.LINEAR),
           Keyframe(q=(0.5, 0.2, 0.1), interpolation=Interpolation.CUBIC))
    prog = KeyframeProgram("arm3g", ("j1", "j2", "j3"), kfs)
    path = save_keyframes(prog, tmp_path / "interp.yaml", arm3g)
    text = path.read_text()
    assert "interpolation: linear" in text and "interpolation: cubic" in text
    back = load_keyframes(path, arm3g)
    assert [k.interpolation for k in back.keyframes] == [None, Interpolation.LINEAR,
                                                         Interpolation.CUBIC]
    old = parse_keyframes(HEAD + "keyframes:\n  - {q: [0, 0, 0]}\n", arm3g)
    assert old.keyframes[0].interpolation is None  # files without the key mean what they meant
    with pytest.raises(ConfigError, match="linear, cubic, min-jerk"):
        parse_keyframes(HEAD + "keyframes:\n  - {q: [0, 0, 0], interpolation: 3}\n", arm3g)
