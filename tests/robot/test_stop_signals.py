"""Stopping inside a ``with Robot.open(...)`` block, measured on the simulator's positions.

A stop signal (SIGINT, SIGTERM, SIGHUP) or a ``KeyboardInterrupt`` during a motion decelerates
within the joint limits and holds; a second one holds at once; leaving the block with the
exception holds the arm where it stopped, even with the ``park`` exit policy.

The tests run in simulated time: the servos' positions are sampled every 2 ms of simulated time
as the clock advances, and "timers" fire between control cycles, where a signal finds the loop
asleep. One test (``realtime``) sends a signal from a real timer thread in wall-clock time.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest

from armctl.arm import Arm, load_arm
from armctl.clock import Clock, SimulatedClock, WallClock
from armctl.config.motion import ExitPolicy
from armctl.robot import CycleInfo, MotionStopped, Robot, StopReason

pytestmark = pytest.mark.timeout(60)

#: Goal of the test moves: the first three joints travel 0.9-1.2 rad.
GOAL = np.array([1.2, -0.9, 0.9, 0.4, 0.0, 0.0])
SPEED = 0.8
#: Deceleration is measured as the change of velocity over 100 ms: longer than the ripple of
#: servos chasing a 50 Hz goal, shorter than a stop.
BRAKE_WINDOW = 0.1


@pytest.fixture(scope="module")
def so101() -> Arm:
    return load_arm("so101")


SAMPLE = 0.002  # [s] between two samples of the servos' positions


class SamplingClock(SimulatedClock):
    """Simulated time that calls ``on_tick`` every :data:`SAMPLE` and fires alarms on time."""

    def __init__(self) -> None:
        super().__init__()
        self.on_tick: Callable[[], None] | None = None
        self.alarms: list[tuple[float, Callable[[], None]]] = []

    def sleep_until(self, t: float) -> None:
        while (now := self.now()) < t:
            step = min(t, (np.floor(now / SAMPLE + 1e-9) + 1) * SAMPLE)
            super().sleep_until(step)
            due = [f for at, f in self.alarms if at <= step]
            self.alarms = [(at, f) for at, f in self.alarms if at > step]
            for f in due:
                f()
            if self.on_tick is not None:
                self.on_tick()


class Recorder:
    """Samples the simulated servos' positions (not the commands) every 2 ms.

    In simulated time on every :data:`SAMPLE` of a :class:`SamplingClock`; in wall-clock time
    in a thread.
    """

    def __init__(self, sim: object, names: tuple[str, ...], clock: Clock):
        self.sim = sim
        self.names = names
        self.clock = clock
        self.t: list[float] = []
        self.q: list[np.ndarray] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def sample(self) -> None:
        pos = self.sim.joint_positions()  # type: ignore[attr-defined]
        self.t.append(self.clock.now())
        self.q.append(np.array([pos[n] for n in self.names]))

    def _run(self) -> None:
        while not self._stop.is_set():
            self.sample()
            time.sleep(SAMPLE)

    def __enter__(self) -> Recorder:
        if isinstance(self.clock, SamplingClock):
            self.sample()
            self.clock.on_tick = self.sample
        else:
            self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        if isinstance(self.clock, SamplingClock):
            self.clock.on_tick = None
        else:
            self._stop.set()
            self._thread.join(2.0)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array(self.t), np.array(self.q)


def velocity(t: np.ndarray, q: np.ndarray, window: float = 0.04) -> tuple[np.ndarray, np.ndarray]:
    """Velocity [rad/s] over ``window`` (two control cycles: the servos chase a 50 Hz goal)."""
    grid = np.arange(t[0], t[-1], 0.005)
    qg = np.stack([np.interp(grid, t, q[:, j]) for j in range(q.shape[1])], axis=1)
    n = max(1, round(window / 0.005))
    v = (qg[n:] - qg[:-n]) / (grid[n:] - grid[:-n])[:, None]
    return grid[n:] - window / 2, v


def braking(t: np.ndarray, q: np.ndarray, after: float) -> np.ndarray:
    """Largest deceleration of each joint after ``after`` [rad/s^2], over :data:`BRAKE_WINDOW`."""
    tv, v = velocity(t, q)
    keep = tv >= after - 0.01
    tv, v = tv[keep], v[keep]
    n = round(BRAKE_WINDOW / 0.005)
    dv = np.abs(v[n:] - v[:-n]) / (tv[n:] - tv[:-n])[:, None]
    return np.max(dv, axis=0)


@pytest.fixture
def clock(simulated_time: SimulatedClock | None) -> Clock:
    """A :class:`SamplingClock`, or the wall clock for a ``realtime`` test."""
    return WallClock() if simulated_time is None else SamplingClock()


def stop_in_block(so101: Arm, trigger: Callable[[CycleInfo, Robot], None], clock: Clock
                  ) -> tuple[MotionStopped, Recorder, dict]:
    """Run a move in a Robot block (exit policy park) until ``trigger`` stops it; record it."""
    state: dict = {}
    with pytest.raises(MotionStopped) as info:
        with Robot.open(so101, speed=SPEED, exit_policy=ExitPolicy.PARK, clock=clock) as robot:
            sim = robot.bus.simulator
            state["sim"] = sim
            state["limits"] = robot.limits
            rec = Recorder(sim, robot.bus.joint_names, clock)
            rec.__enter__()

            def on_cycle(cyc: CycleInfo) -> None:
                if cyc.stopping and "stopping" not in state:  # the stop's first command
                    state["stopping"] = clock.now()
                trigger(cyc, robot)

            state["previous"] = {s: signal.getsignal(s) for s in
                                 (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
            robot.move_joints(GOAL, on_cycle=on_cycle)
    state["closed_at"] = clock.now()
    # anything that follows the stop (a park) would move the arm now
    clock.sleep_until(clock.now() + 0.4)
    rec.__exit__()
    return info.value, rec, state


def check_decelerated(rec: Recorder, t_signal: float, limits: object, idx: np.ndarray) -> None:
    """The servos slowed down within the joint limits after ``t_signal``, to rest.

    ``t_signal`` is when the first cycle of the stop ran (measured in that cycle), not when the
    signal was sent: on a busy computer the signal may wait before the loop sees it.
    """
    t, q = rec.arrays()
    tv, v = velocity(t, q)
    vmax = limits.velocity[idx]  # type: ignore[attr-defined]
    amax = limits.acceleration[idx]  # type: ignore[attr-defined]
    # never faster than the joint limits (a goal jump would run at the servo's top speed)
    assert np.all(np.abs(v) <= vmax * SPEED * 1.1 + 0.05)
    v_signal = v[np.searchsorted(tv, t_signal)]
    assert np.max(np.abs(v_signal)) > 1.0, "the stop must come while the arm is moving fast"
    after = tv >= t_signal
    # no joint speeds up (servos catching up their lag aside) or turns back after the signal
    assert np.all(np.abs(v[after]) <= np.abs(v_signal) + 0.35)
    assert np.all(v[after] * np.sign(v_signal) >= -0.1)
    # it slowed down within the acceleration limit (the servos' lag adds about 12 %; a goal
    # that jumps brakes at the simulated STS3215's own 8 x 4.7 rad/s^2, 1.9 times the 20 rad/s^2)
    assert np.all(braking(t, q, t_signal) <= 1.3 * amax)
    assert np.max(np.abs(v[-1])) < 1e-3


def check_holds_where_it_stopped(exc: MotionStopped, rec: Recorder, state: dict,
                                 so101: Arm) -> None:
    t, q = rec.arrays()
    final = q[-1]
    late = t >= state["closed_at"]
    assert late.sum() > 20
    # after the block the servos at most finish settling (no park, which is far away) ...
    assert np.max(np.abs(q[late] - final)) < 0.015
    # ... and then hold still
    assert np.max(np.abs(q[t >= t[-1] - 0.2] - final)) < 2e-3
    park = so101.named_pose("park")
    assert np.max(np.abs(final - park)) > 0.3
    assert np.max(np.abs(final - GOAL)) > 0.1  # stopped part-way
    sim = state["sim"]
    assert all(s.torque for s in sim.servos)  # holding, not released
    assert exc.stopped_at is not None
    reported = np.array([exc.stopped_at["joints"][n] for n in so101.joint_names])
    assert np.allclose(reported, final, atol=5e-3)
    assert np.allclose(exc.stopped_at["xyz"], so101.fk(reported)[:3, 3], atol=1e-9)
    assert exc.details["stopped_at"] is exc.stopped_at


def test_keyboard_interrupt_in_the_block_decelerates_and_holds_without_parking(
        so101: Arm, clock: Clock) -> None:
    fired: dict[str, float] = {}

    def ctrl_c(cyc: CycleInfo, robot: Robot) -> None:
        if cyc.t >= cyc.duration / 2 and not fired:  # at full speed
            fired["t"] = clock.now()
            raise KeyboardInterrupt

    exc, rec, state = stop_in_block(so101, ctrl_c, clock)
    assert exc.reason is StopReason.USER and exc.exit_code == 5
    assert exc.signum == signal.SIGINT and isinstance(exc.__cause__, KeyboardInterrupt)
    assert "decelerated and holds" in str(exc)
    assert state["stopping"] >= fired["t"]
    idx = np.arange(so101.dof)
    check_decelerated(rec, state["stopping"], state["limits"], idx)
    check_holds_where_it_stopped(exc, rec, state, so101)


def _stop_signal_from_a_timer(so101: Arm, sig: str, clock: Clock) -> None:
    signum = getattr(signal, sig)
    fired: dict[str, float] = {}

    def arm_timer(cyc: CycleInfo, robot: Robot) -> None:
        if not fired:
            fired["armed"] = clock.now()

            def send() -> None:
                fired["t"] = clock.now()
                os.kill(os.getpid(), signum)

            if isinstance(clock, SamplingClock):  # between two cycles, in simulated time
                clock.alarms.append((clock.now() + cyc.duration / 2, send))
            else:  # from another thread, as a terminal or `kill` would
                threading.Timer(cyc.duration / 2, send).start()  # at full speed

    exc, rec, state = stop_in_block(so101, arm_timer, clock)
    assert exc.reason is StopReason.USER and exc.signum == signum
    assert sig in str(exc) and exc.details["signal"] == sig
    assert state["stopping"] >= fired["t"]
    if isinstance(clock, SamplingClock):
        # the velocity profile needs samples exactly every 2 ms: simulated time only (a sampler
        # thread starved of CPU in wall-clock time would see jumps that are not there)
        check_decelerated(rec, state["stopping"], state["limits"], np.arange(so101.dof))
    check_holds_where_it_stopped(exc, rec, state, so101)
    # the handlers in place before the motion are back
    assert {s: signal.getsignal(s) for s in state["previous"]} == state["previous"]


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_a_stop_signal_from_a_timer_decelerates_and_holds(so101: Arm, sig: str,
                                                          clock: Clock) -> None:
    _stop_signal_from_a_timer(so101, sig, clock)


@pytest.mark.realtime
def test_a_stop_signal_from_a_timer_thread_in_real_time_decelerates_and_holds(
        so101: Arm, clock: Clock) -> None:
    """End to end in wall-clock time: a signal sent from another thread during the move."""
    assert isinstance(clock, WallClock)
    _stop_signal_from_a_timer(so101, "SIGTERM", clock)


def test_a_second_signal_during_the_deceleration_holds_at_once(so101: Arm,
                                                               clock: Clock) -> None:
    sent: list[float] = []

    def twice(cyc: CycleInfo, robot: Robot) -> None:
        if cyc.t >= cyc.duration / 2 and len(sent) < 2 and (not sent or cyc.stopping):
            sent.append(clock.now())
            os.kill(os.getpid(), signal.SIGINT)

    exc, rec, state = stop_in_block(so101, twice, clock)
    assert "held it at once" in str(exc) and exc.reason is StopReason.USER
    t, q = rec.arrays()
    tv, v = velocity(t, q)
    at_second = np.abs(v[np.searchsorted(tv, sent[1])])
    assert np.max(at_second) > 1.0
    # the goal became the reading at the next cycle (within 40 ms of the signal): the arm holds
    # there, not at the end of a controlled stop (about 0.3 rad further on at this speed)
    q_second = np.array([np.interp(sent[1], t, q[:, j]) for j in range(q.shape[1])])
    assert np.all(np.abs(q[-1] - q_second) <= at_second * 0.04 + 0.01)
    # the servos braked as hard as they can, harder than the controlled stop is allowed to
    fastest = int(np.argmax(at_second))
    assert braking(t, q, sent[1])[fastest] > 1.5 * state["limits"].acceleration[fastest]
    check_holds_where_it_stopped(exc, rec, state, so101)


def test_an_error_in_the_callback_stops_the_arm_and_is_raised_again(so101: Arm) -> None:
    with Robot.open(so101, speed=SPEED, exit_policy=ExitPolicy.HOLD) as robot:
        sim = robot.bus.simulator

        def broken(cyc: CycleInfo) -> None:
            if cyc.t >= 0.3:
                raise ZeroDivisionError("the caller's bug")

        with pytest.raises(ZeroDivisionError, match="the caller's bug"):
            robot.move_joints(GOAL, on_cycle=broken)
        first = sim.joint_positions()
        robot.clock.sleep_until(robot.clock.now() + 0.2)
        assert sim.joint_positions() == pytest.approx(first, abs=2e-3)  # at rest, holding
        assert abs(first["shoulder_pan"] - GOAL[0]) > 0.1 and all(s.torque for s in sim.servos)


def test_an_explicit_park_after_a_stop_parks(so101: Arm) -> None:
    """The exit policy is not a consequence of a stop, but the user may still ask for it."""
    with Robot.open(so101, speed=SPEED, exit_policy=ExitPolicy.HOLD) as robot:
        sim = robot.bus.simulator

        def ctrl_c(cyc: CycleInfo) -> None:
            if cyc.t >= 0.3:
                raise KeyboardInterrupt

        with pytest.raises(MotionStopped):
            robot.move_joints(GOAL, on_cycle=ctrl_c)
        robot.close(ExitPolicy.PARK)
        got = sim.joint_positions()
    park = so101.named_pose("park")
    assert np.allclose([got[n] for n in so101.joint_names], park, atol=0.02)


def test_an_error_in_the_block_holds_instead_of_parking(so101: Arm,
                                                        caplog: pytest.LogCaptureFixture) -> None:
    with pytest.raises(RuntimeError, match="user code"):
        with Robot.open(so101, speed=SPEED, exit_policy=ExitPolicy.PARK) as robot:
            sim = robot.bus.simulator
            robot.move_joints([0.3, -0.3, 0.3, 0.0, 0.0, 0.0])
            before = sim.joint_positions()
            raise RuntimeError("user code")
    after = sim.joint_positions()
    assert after == pytest.approx(before, abs=2e-3)
    assert "exit policy 'park' not applied" in caplog.text


@pytest.fixture(autouse=True)
def _no_stray_handlers() -> Iterator[None]:
    """Every test leaves the signal handlers as it found them."""
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    yield
    assert {s: signal.getsignal(s) for s in before} == before
