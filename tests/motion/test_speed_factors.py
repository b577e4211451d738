"""Speed factors: one check for every entry point, the valid range in the message, and
playback speeds that fit how a program is timed."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.errors import InputError
from armctl.motion import (
    Keyframe,
    KeyframeProgram,
    LimitViolation,
    MotionLimits,
    PlaybackOptions,
    check_speed,
    plan_joint_move,
    plan_program,
)
from armctl.motion.limits import MAX_RECORDED_SPEED, MIN_SPEED

JOINTS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll")


@pytest.fixture(scope="module")
def so101() -> Arm:
    return load_arm("so101")


@pytest.mark.parametrize(("speed", "words"), [
    (0.0, "must be positive"), (-1.0, "must be positive"), (float("nan"), "not a finite"),
    (float("inf"), "not a finite"), (1e-9, "too slow"), (0.009, "too slow"),
    (1.0001, "too fast"), (7.0, "too fast")])
def test_check_speed_refuses_with_the_range(speed: float, words: str) -> None:
    with pytest.raises(InputError) as info:
        check_speed(speed)
    assert words in str(info.value) and "0.01 to 1" in str(info.value)


def test_check_speed_accepts_the_range_ends() -> None:
    assert check_speed(MIN_SPEED) == MIN_SPEED and check_speed(1.0) == 1.0
    assert check_speed(MAX_RECORDED_SPEED, MAX_RECORDED_SPEED) == MAX_RECORDED_SPEED
    with pytest.raises(InputError, match="use 4 or lower"):
        check_speed(4.5, MAX_RECORDED_SPEED)


def test_every_planner_uses_the_check(so101: Arm) -> None:
    limits = MotionLimits.from_model(so101)
    for bad in (0.0, float("nan"), 1e-6, 2.0):
        with pytest.raises(InputError, match="speed factor"):
            plan_joint_move(np.zeros(6), np.full(6, 0.1), limits, bad)
        with pytest.raises(InputError, match="speed factor"):
            limits.scaled(bad)
    for bad in (0.0, float("nan"), 1e-6, 4.5):
        with pytest.raises(InputError, match="speed factor"):
            PlaybackOptions(speed=bad)
    slowest = plan_joint_move(np.zeros(6), np.full(6, 0.1), limits, MIN_SPEED)
    assert math.isfinite(slowest.duration) and slowest.duration < 600  # minutes, not hours


def _untimed(so101: Arm) -> KeyframeProgram:
    return KeyframeProgram(so101.name, JOINTS, (Keyframe(q=(0.0, 0.0, 0.0, 0.0, 0.0)),
                                                Keyframe(q=(0.3, -0.2, 0.3, 0.1, 0.0))))


def _recording(so101: Arm, step: float) -> KeyframeProgram:
    kfs = tuple(Keyframe(q=(-0.9 + step * k, 0.0, 0.0, 0.0, 0.0), time=0.1 * k)
                for k in range(8))
    return KeyframeProgram(so101.name, JOINTS, kfs)


def test_a_speed_above_1_on_an_untimed_program_is_refused(so101: Arm) -> None:
    limits = MotionLimits.from_model(so101)
    for options, why in ((PlaybackOptions(speed=4.0), "no time stamps"),):
        with pytest.raises(InputError, match="try --speed 1 or lower") as info:
            plan_program(_untimed(so101), so101, limits, np.zeros(6), options)
        assert why in str(info.value)
    recorded = _recording(so101, 0.02)
    for options, why in ((PlaybackOptions(speed=2.0, reverse=True), "reverse"),
                         (PlaybackOptions(speed=2.0, use_times=False), "ignored")):
        with pytest.raises(InputError, match=why):
            plan_program(recorded, so101, limits, np.array([-0.9, 0, 0, 0, 0, 0]), options)
    plan = plan_program(_untimed(so101), so101, limits, np.zeros(6), PlaybackOptions(speed=1.0))
    assert plan.duration > 0


def test_a_too_fast_recording_names_a_speed_that_works(so101: Arm) -> None:
    limits = MotionLimits.from_model(so101)
    program = _recording(so101, 0.25)  # 2.5 rad/s recorded; the limit is 4.7 rad/s
    start = np.array([-0.9, 0.0, 0.0, 0.0, 0.0, 0.0])
    options = PlaybackOptions(speed=4.0, ease_in=False)
    with pytest.raises(LimitViolation) as info:
        plan_program(program, so101, limits, start, options)
    m = re.search(r"try --speed (\d+\.\d+) or lower", str(info.value))
    assert m, str(info.value)
    suggested = float(m.group(1))
    assert 0.1 < suggested < 4.0
    plan = plan_program(program, so101, limits, start,
                        PlaybackOptions(speed=suggested, ease_in=False))
    assert plan.duration > 0
