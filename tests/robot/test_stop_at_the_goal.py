"""A stop request as a motion reaches its goal (its last cycle, or while the servos settle) is
never lost: the motion ends with ``MotionStopped``, so nothing runs after it in the block; and a
``KeyboardInterrupt`` raised again and again by the callback is one stop request, not two."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.config.motion import ExitPolicy
from armctl.robot import CycleInfo, Executor, MotionStopped, Robot, StopReason

pytestmark = pytest.mark.timeout(60)

GOAL = np.array([0.3, -0.2, 0.2, 0.1, 0.0, 0.0])


@pytest.fixture(scope="module")
def so101() -> Arm:
    return load_arm("so101")


def run_block(so101: Arm, on_cycle: Any) -> tuple[MotionStopped, list[str], dict[str, float]]:
    """A block of two moves (exit policy park); the first ends with a stop request."""
    ran: list[str] = []
    with pytest.raises(MotionStopped) as info:
        with Robot.open(so101, speed=1.0, exit_policy=ExitPolicy.PARK) as robot:
            sim = robot.bus.simulator
            robot.move_joints(GOAL, on_cycle=on_cycle)
            ran.append("the next move")
            robot.move_joints(np.zeros(so101.dof))
    assert sim is not None
    return info.value, ran, sim.joint_positions()


def check_held_at_the_goal(exc: MotionStopped, ran: list[str], q: dict[str, float],
                           so101: Arm) -> None:
    assert not ran  # the block ended with the stop: the next move never started
    assert exc.reason is StopReason.USER and exc.exit_code == 5
    assert "reached its goal; the arm holds there" in str(exc)
    reached = np.array([q[n] for n in so101.joint_names])
    assert np.allclose(reached, GOAL, atol=0.02)  # held at the goal: not parked, not moved on
    assert np.asarray(exc.held).shape == (so101.dof,)
    assert np.allclose(np.asarray(exc.held), GOAL, atol=1e-6)
    assert exc.stopped_at is not None and set(exc.stopped_at["joints"]) == set(so101.joint_names)


def test_ctrl_c_in_the_last_cycle_is_not_lost(so101: Arm) -> None:
    def last_cycle(cyc: CycleInfo) -> None:
        if cyc.t >= cyc.duration:
            raise KeyboardInterrupt

    exc, ran, q = run_block(so101, last_cycle)
    check_held_at_the_goal(exc, ran, q, so101)
    assert isinstance(exc.__cause__, KeyboardInterrupt) and exc.signum == signal.SIGINT


@pytest.fixture
def signal_while_settling(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[int]]:
    """Send SIGINT to this process as the servos start to settle at the end of the motion."""
    sent: list[int] = []
    original = Executor._settle

    def settle(self: Executor, *args: Any, **kwargs: Any) -> Any:
        if not sent:  # the first settle: the end of the motion (nothing stopped it before)
            sent.append(signal.SIGINT)
            os.kill(os.getpid(), signal.SIGINT)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Executor, "_settle", settle)
    yield sent


def test_a_signal_while_the_servos_settle_is_not_lost(so101: Arm,
                                                      signal_while_settling: list[int]) -> None:
    exc, ran, q = run_block(so101, None)
    assert signal_while_settling == [signal.SIGINT]
    check_held_at_the_goal(exc, ran, q, so101)
    assert exc.signum == signal.SIGINT and exc.details["signal"] == "SIGINT"


def test_keyboard_interrupt_raised_every_cycle_is_one_stop_request(so101: Arm) -> None:
    """A callback that keeps raising (as a naive Ctrl-C check does) decelerates the arm."""
    raised: list[float] = []
    with Robot.open(so101, speed=1.0, exit_policy=ExitPolicy.HOLD) as robot:
        plan = robot.plan_joints([0.8, -0.6, 0.6, 0.4, 0.0, 0.0])

        def keeps_raising(cyc: CycleInfo) -> None:
            if cyc.t >= 0.4 * cyc.duration:  # at speed, then on every cycle of the stop
                raised.append(cyc.t)
                raise KeyboardInterrupt

        with pytest.raises(MotionStopped) as info:
            robot.execute(plan, keeps_raising)
    assert len(raised) > 3  # raised during the deceleration too
    text = str(info.value)
    assert "decelerated and holds its position" in text and "at once" not in text
