"""Every reply is matched to its request: a late reply is never returned as a later answer."""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Iterator

import numpy as np
import pytest

from armctl.config import load_spec
from armctl.config.bus import Protocol
from armctl.errors import BusError
from armctl.servo import (
    ArmBus,
    LatencySpike,
    LateReply,
    Register,
    ServoBus,
    SimServoSpec,
    SimulatedBus,
)
from armctl.servo.errors import LateReplyError, NoReplyError
from armctl.servo.replies import ReplyLedger, Window

pytestmark = pytest.mark.timeout(60)

MODELS = {Protocol.FEETECH: "sts3215", Protocol.DYNAMIXEL: "xl430-w250",
          Protocol.DYNAMIXEL1: "xl430-w250"}
# Registers of the same width with different values: a stale reply of one is a plausible
# (wrong) answer to the other. Present position is set to 1234 by the fixture.
REGISTERS = (Register.PRESENT_POSITION, Register.MIN_POSITION_LIMIT,
             Register.MAX_POSITION_LIMIT, Register.ID, Register.PRESENT_TEMPERATURE,
             Register.RETURN_DELAY)


@pytest.fixture(params=list(MODELS), ids=[p.value for p in MODELS])
def pair(request: pytest.FixtureRequest) -> Iterator[tuple[SimulatedBus, ServoBus]]:
    protocol: Protocol = request.param
    model = MODELS[protocol]
    sim = SimulatedBus([SimServoSpec(i, model) for i in (1, 2, 3)], protocol)
    sim.start()
    bus = ServoBus(sim.port, protocol, models={i: model for i in (1, 2, 3)}, latency_ms=8.0)
    bus.open()
    sim.servo(2).set_present_position(1234)
    sim.servo(2).set(Register.MIN_POSITION_LIMIT, 100)
    sim.servo(2).set(Register.MAX_POSITION_LIMIT, 3900)
    sim.servo(2).set(Register.RETURN_DELAY, 7)
    yield sim, bus
    bus.close()
    sim.stop()


def _truth(bus: ServoBus) -> dict[Register, int]:
    return {r: bus.read(2, r) for r in REGISTERS}


def _reads(bus: ServoBus, truth: dict[Register, int], n: int
           ) -> tuple[int, int, Counter[tuple[str, int | None]]]:
    """``(wrong values, right values, errors by (class, servo))`` of ``n`` reads of servo 2."""
    wrong = right = 0
    errors: Counter[tuple[str, int | None]] = Counter()
    for i in range(n):
        reg = REGISTERS[i % len(REGISTERS)]
        try:
            value = bus.read(2, reg)
        except BusError as exc:
            errors[(type(exc).__name__, getattr(exc, "servo_id", None))] += 1
            continue
        if value == truth[reg]:
            right += 1
        else:
            wrong += 1
    return wrong, right, errors


@pytest.mark.parametrize("fault", [LateReply(2, count=None, delay=0.06),
                                   LatencySpike(count=None, delay=0.05)],
                         ids=["one servo 60 ms late", "every reply 50 ms late"])
def test_persistent_latency_gives_errors_never_wrong_values(
        pair: tuple[SimulatedBus, ServoBus], fault: object) -> None:
    sim, bus = pair
    truth = _truth(bus)
    assert truth[Register.PRESENT_POSITION] == 1234 and truth[Register.ID] == 2
    sim.inject(fault)  # type: ignore[arg-type]
    wrong, right, errors = _reads(bus, truth, 20)
    assert wrong == 0, f"{wrong} stale values returned as answers"
    assert right + sum(errors.values()) == 20
    assert {sid for _, sid in errors} == {2}  # the late servo is named
    assert errors[("LateReplyError", 2)] >= 15  # and said to be late, once late replies came
    assert bus.ledger.late[2] > 0
    # group reads too: every servo's reply is checked against the request
    if bus.protocol is not Protocol.DYNAMIXEL1:
        for _ in range(5):
            try:
                fb = bus.read_feedback([1, 2, 3])
            except BusError:
                continue
            assert fb[2].position == 1234 and fb[1].position == 2048


def test_the_bus_recovers_when_the_latency_ends(pair: tuple[SimulatedBus, ServoBus]) -> None:
    sim, bus = pair
    truth = _truth(bus)
    sim.inject(LateReply(2, count=None, delay=0.06))
    with pytest.raises(NoReplyError):
        bus.read(2, Register.PRESENT_POSITION)
    sim.clear_faults()
    time.sleep(0.15)  # the late replies still in flight arrive
    wrong, right, errors = _reads(bus, truth, len(REGISTERS))
    assert (wrong, right, sum(errors.values())) == (0, len(REGISTERS), 0)


def test_a_late_reply_arriving_during_the_next_read_is_not_its_answer(
        pair: tuple[SimulatedBus, ServoBus]) -> None:
    """The sequence that returned a wrong value: read A times out, its reply comes during B."""
    sim, bus = pair
    truth = _truth(bus)
    for _ in range(5):
        bus.retries = 0
        sim.inject(LateReply(2, count=1, delay=0.025))
        with pytest.raises(NoReplyError):
            bus.read(2, Register.MIN_POSITION_LIMIT)  # 2 bytes; its reply arrives late
        bus.retries = 3
        late = bus.ledger.late[2]
        assert bus.read(2, Register.MAX_POSITION_LIMIT) == truth[Register.MAX_POSITION_LIMIT]
        if bus.ledger.late[2] > late:  # the late reply did arrive during that read
            return
    pytest.fail("the late reply never arrived during the next read")


def test_late_replies_of_one_servo_are_reported_with_its_id() -> None:
    """OMX sync reads: servo 13 answers late, which holds up 11 and 12 behind it."""
    with ArmBus.from_spec(load_spec("omx")) as ab:
        sim = ab.simulator
        assert sim is not None
        q0 = ab.read_joints()
        sim.inject(LateReply(13, count=None, delay=0.06))
        named: Counter[int | None] = Counter()
        values = 0
        for _ in range(12):
            try:
                ab.read_joints()
                values += 1
            except NoReplyError as exc:
                named[exc.servo_id] += 1
        assert values == 0 and set(named) == {13}
        with pytest.raises(LateReplyError) as info:
            ab.read_joints()
        assert info.value.servo_id == 13 and "late" in str(info.value)
        sim.clear_faults()
        time.sleep(0.15)
        np.testing.assert_allclose(ab.read_joints(), q0)


@pytest.mark.parametrize("protocol", list(MODELS), ids=[p.value for p in MODELS])
def test_a_late_reply_while_the_bus_opens_is_no_crash(protocol: Protocol) -> None:
    """Ping + model read on open: a late ping status must not be read as the model number.

    (SDK-FT's ping reads the model number right after the ping; a late ping status arriving
    then has no data, and the SDK indexed into it: IndexError.)
    """
    model = MODELS[protocol]
    with SimulatedBus([SimServoSpec(1, model), SimServoSpec(2, model)], protocol) as sim:
        for delay in (0.025, 0.04):
            sim.inject(LateReply(1, count=1, delay=delay))
            with ServoBus(sim.port, protocol, models={1: model, 2: model},
                          latency_ms=8.0) as bus:
                found = bus.verify()
                assert [f.model for f in found] == [model, model]
                assert set(bus.retry_counts()) == {1}  # the late reply cost retries of servo 1
            time.sleep(0.1)
        sim.inject(LateReply(2, count=None, delay=0.04))
        with ServoBus(sim.port, protocol, models={1: model, 2: model}, latency_ms=8.0) as bus:
            with pytest.raises(NoReplyError) as info:
                bus.verify()
            assert info.value.servo_id == 2


def test_ledger_windows_avoid_pending_lengths() -> None:
    ledger = ReplyLedger()
    assert ledger.window([2], 56, 2, 87) == Window(56, 2)
    ledger.sent(2, 2)  # unanswered
    ledger.sent(2, 3)
    win = ledger.window([2, 3], 56, 2, 87)
    assert win is not None and win.length == 4 and win.start <= 56 <= 58 <= win.start + 4
    assert win.slice(list(range(win.start, win.start + win.length)), 56, 2) == [56, 57]
    near_end = ledger.window([2], 85, 2, 87)  # no room after: extends before
    assert near_end == Window(83, 4)
    assert ledger.take_late(2, 3) and not ledger.take_late(2, 3)  # a late reply, counted once
    assert ledger.late[2] == 1 and ledger.pending(2) == {2}
    assert not ledger.take_late(3, 2)  # nothing pending for servo 3: not a late reply of it
    ledger.matched(2)  # a matched reply settles every earlier request of the servo
    assert ledger.pending(2) == frozenset()
    for n in range(1, 88):
        ledger.sent(5, n)
    assert ledger.window([5], 0, 1, 87) is None  # no free length: the caller resyncs


def test_many_unanswered_requests_resynchronise_the_line(
        pair: tuple[SimulatedBus, ServoBus]) -> None:
    from armctl.servo import DroppedReply
    from armctl.servo.driver import MAX_PENDING

    sim, bus = pair
    truth = _truth(bus)
    sim.inject(DroppedReply(2, count=None))
    for _ in range(MAX_PENDING // 3 + 2):  # 3 attempts each: past MAX_PENDING
        with pytest.raises(NoReplyError):
            bus.read(2, Register.PRESENT_POSITION)
    assert bus.ledger.count_pending(2) < MAX_PENDING  # the line was drained and forgotten
    sim.clear_faults()
    assert [bus.read(2, r) for r in REGISTERS] == [truth[r] for r in REGISTERS]


def test_persistent_latency_during_a_motion_stops_it_naming_the_servo() -> None:
    from pathlib import Path

    from armctl.robot import Robot
    from armctl.robot.errors import MotionStopped, StopReason

    with Robot.open(Path(__file__).parent / "data" / "so_sim.yaml") as robot:
        sim = robot.bus.simulator  # type: ignore[attr-defined]
        assert sim is not None
        cycles: list[object] = []

        def on_cycle(info: object) -> None:
            cycles.append(info)
            if len(cycles) == 3:
                sim.inject(LateReply(3, count=None, delay=0.06))
        with pytest.raises(MotionStopped) as info:  # never a reported success
            robot.execute(robot.plan_joints(np.array([0.3, 0.2, 0.2, 0, 0, 0.01]), 1.0),
                          on_cycle=on_cycle)
        assert info.value.reason is StopReason.LOST_SERVO and info.value.servo_id == 3
        assert "late" in str(info.value)
        sim.clear_faults()
