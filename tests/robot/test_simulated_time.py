"""The clock: simulated time makes motion on the simulated bus deterministic and load-proof.

The robot tests run in simulated time (``tests/robot/conftest.py``); the tests marked
``realtime`` check the wall-clock path end to end.
"""

from __future__ import annotations

import re
import threading
import time
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.clock import Clock, SimulatedClock, WallClock, default_clock, set_default_clock
from armctl.config.motion import ExitPolicy
from armctl.motion import load_keyframes
from armctl.robot import Robot, StreamStats
from armctl.robot.teach import TeachSession

GOAL = np.array([0.5, -0.4, 0.6, 0.3, -0.2, 0.1])


@pytest.fixture(scope="module")
def so101() -> Arm:
    return load_arm("so101")


def test_simulated_time_passes_only_by_sleeping() -> None:
    clock = SimulatedClock(start=2.0)
    assert clock.now() == 2.0
    time.sleep(0.01)
    assert clock.now() == 2.0  # wall time does not count
    clock.sleep_until(2.5)
    assert clock.now() == 2.5
    clock.sleep_until(1.0)  # in the past: returns at once, time never goes back
    assert clock.now() == 2.5
    clock.advance(0.25)
    assert clock.now() == 2.75
    with pytest.raises(ValueError, match="cannot go back"):
        clock.advance(-0.1)
    assert isinstance(clock, Clock) and isinstance(WallClock(), Clock)


def test_simulated_clock_is_thread_safe() -> None:
    clock = SimulatedClock()
    n = 2000

    def sleeper(k: int) -> None:
        for i in range(n):
            clock.sleep_until(i * 4 + k)
            clock.advance(0.0)

    threads = [threading.Thread(target=sleeper, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert clock.now() == (n - 1) * 4 + 3  # the latest wake-up time of any thread


def test_wall_clock_sleeps_until_the_time() -> None:
    clock = WallClock()
    t0 = clock.now()
    clock.sleep_until(t0 + 0.02)
    assert clock.now() >= t0 + 0.02
    before = clock.now()
    clock.sleep_until(before - 1.0)  # in the past: at once
    assert clock.now() - before < 0.5


def test_set_default_clock_returns_the_previous_one(simulated_time: SimulatedClock) -> None:
    assert default_clock() is simulated_time  # the robot tests' fixture installed it
    mine = SimulatedClock()
    previous = set_default_clock(mine)
    try:
        assert previous is simulated_time and default_clock() is mine
    finally:
        set_default_clock(previous)
    assert default_clock() is simulated_time


def _traced_move(so101: Arm) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[int, int],
                                      float, StreamStats]:
    clock = SimulatedClock()
    with Robot.open(so101, speed=0.9, exit_policy=ExitPolicy.HOLD, clock=clock) as robot:
        assert robot.executor.clock is clock and robot.bus.simulator.clock is clock
        plan = robot.plan_joints(GOAL)
        res = robot.execute(plan, record=True)
        ticks = robot.bus.simulator.positions
        now = clock.now()
    return res.log_t, res.log_cmd, res.log_meas, ticks, now, res.stats


def test_the_same_move_twice_gives_identical_traces(so101: Arm) -> None:
    t1, cmd1, meas1, ticks1, end1, stats1 = _traced_move(so101)
    t2, cmd2, meas2, ticks2, end2, stats2 = _traced_move(so101)
    assert len(t1) > 20  # a real move, not a one-cycle one
    np.testing.assert_array_equal(t1, t2)
    np.testing.assert_array_equal(cmd1, cmd2)
    np.testing.assert_array_equal(meas1, meas2)  # the servos' readings, bit for bit
    assert ticks1 == ticks2 and end1 == end2
    # jitter, I/O time, settle time: all in simulated time
    for f in fields(stats1):
        np.testing.assert_array_equal(getattr(stats1, f.name), getattr(stats2, f.name))
    # the servos moved (the readings are not just the commands)
    assert not np.array_equal(meas1, cmd1)
    assert np.max(np.abs(meas1[-1] - GOAL)) < 0.01


def test_a_move_in_simulated_time_keeps_every_deadline(so101: Arm,
                                                      simulated_time: SimulatedClock) -> None:
    with Robot.open(so101, speed=0.9, exit_policy=ExitPolicy.HOLD) as robot:
        assert robot.clock is simulated_time  # from the fixture's default
        start = simulated_time.now()
        plan = robot.plan_joints(GOAL)
        report = robot.execute(plan)
    stats = report.stats
    dt = 1.0 / stats.rate_hz
    assert stats.overruns == 0 and stats.jitter_max == 0.0 and stats.io_time_mean == 0.0
    assert stats.elapsed == pytest.approx((stats.cycles - 1) * dt)
    assert simulated_time.now() - start >= plan.trajectory.duration


def test_the_simulated_servos_move_only_as_simulated_time_passes(
        so101: Arm, simulated_time: SimulatedClock) -> None:
    with Robot.open(so101, exit_policy=ExitPolicy.HOLD) as robot:
        before = robot.joints()
        goal = before.copy()
        goal[0] += 0.3
        robot.bus.write_joints(goal)
        time.sleep(0.05)  # wall time: the servos stand still
        assert np.array_equal(robot.joints(), before)
        simulated_time.advance(0.02)
        moved = robot.joints()
        assert 0.0 < moved[0] - before[0] < 0.3
        simulated_time.advance(2.0)
        assert robot.joints()[0] == pytest.approx(goal[0], abs=0.01)


def test_continuous_teaching_samples_on_the_clock(so101: Arm, tmp_path: Path,
                                                  simulated_time: SimulatedClock) -> None:
    with Robot.open(so101, speed=0.7, exit_policy=ExitPolicy.HOLD) as robot:
        session = TeachSession(robot, tmp_path / "rec.yaml")
        assert session.clock is simulated_time
        session.start()
        n = session.record_continuous(50.0, threading.Event(), duration=0.2)
        session.finish()
    prog = load_keyframes(tmp_path / "rec.yaml", so101)
    assert n == len(prog.keyframes) == 11  # 0, 20, ..., 200 ms: none lost to a slow machine
    assert np.allclose([k.time for k in prog.keyframes], 0.02 * np.arange(11))


@pytest.mark.realtime
def test_a_move_in_real_time_takes_its_planned_duration(so101: Arm) -> None:
    """End to end in wall-clock time: the loop paces itself by the real clock."""
    assert isinstance(default_clock(), WallClock)
    with Robot.open(so101, speed=0.9, exit_policy=ExitPolicy.HOLD) as robot:
        assert isinstance(robot.executor.clock, WallClock)
        plan = robot.plan_joints(GOAL)
        t0 = time.perf_counter()
        res = robot.execute(plan)
        took = time.perf_counter() - t0
        assert np.max(np.abs(robot.joints()[:5] - GOAL[:5])) < 0.02
    assert took >= plan.trajectory.duration  # never faster than planned
    assert res.stats.elapsed >= plan.trajectory.duration - 1.0 / res.stats.rate_hz


def test_the_clock_example_in_the_motion_docs_runs(capsys: pytest.CaptureFixture[str],
                                                   simulated_time: SimulatedClock) -> None:
    doc = Path(__file__).parent.parent.parent / "docs" / "motion.md"
    found = re.search(r"^### Clock: real and simulated time\n.*?^```python\n(.*?)^```",
                      doc.read_text(encoding="utf-8"), re.S | re.M)
    assert found, f"no python block in the Clock section of {doc}"
    exec(compile(found.group(1), str(doc), "exec"), {})
    took = float(capsys.readouterr().out.split()[-1])
    assert 0.2 < took < 5.0  # simulated seconds of a real move
    assert default_clock() is simulated_time  # the example restored the default
