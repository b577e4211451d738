"""A corrupt write acknowledgement settles nothing: a late acknowledgement never stands in for
the retry's, whose error byte it would hide.

The line is scripted (no simulator can order it so): line noise arrives in place of the
acknowledgement of a goal write, the real acknowledgement follows with the next request's
replies, and the servo overloads in between.
"""

from __future__ import annotations

import pytest

from armctl.config.bus import Protocol
from armctl.servo import Alarm, Register, ServoBus
from armctl.servo.errors import ServoAlarmError

OVERLOAD = Alarm.OVERLOAD.feetech_bit
NOISE = None


class NoisyLine:
    """A Feetech servo 2 behind a scripted line, in place of the SDK."""

    SUCCESS, TIMEOUT, CORRUPT = 0, -3001, -3002
    has_sync_read = True

    def __init__(self, ack_late: bool):
        self.ack_late = ack_late
        self.line: list[tuple[int, int, list[int]] | None] = []  # what the host reads next
        self.held: list[tuple[int, int, list[int]]] = []  # on its way: comes with the next
        self.memory: dict[int, int] = {}
        self.error = 0
        self.writes = 0

    def _deliver(self) -> None:
        self.line.extend(self.held)
        self.held.clear()

    def drain(self) -> list[tuple[int, int, list[int]]]:
        return []  # nothing is waiting when the host drains

    def send_write(self, sid: int, addr: int, data: bytes) -> int:
        self.writes += 1
        self._deliver()
        self.memory.update({addr + i: b for i, b in enumerate(data)})
        if self.writes == 1:
            self.line.append(NOISE)  # read as a corrupt packet
            if self.ack_late:
                self.held.append((sid, self.error, []))  # the acknowledgement, late
            self.error = OVERLOAD  # and the servo overloads right after the write
        else:
            self.line.append((sid, self.error, []))
        return self.SUCCESS

    def send_read(self, sid: int, addr: int, n: int) -> int:
        self._deliver()
        self.line.append((sid, self.error, [self.memory.get(addr + i, 0) for i in range(n)]))
        return self.SUCCESS

    def receive(self) -> tuple[object, int]:
        if not self.line:
            return [], self.TIMEOUT
        packet = self.line.pop(0)
        return ([], self.CORRUPT) if packet is NOISE else (packet, self.SUCCESS)

    def status(self, rx: tuple[int, int, list[int]]) -> tuple[int, int, list[int]]:
        return rx

    def result_text(self, result: int) -> str:
        return {self.SUCCESS: "success", self.TIMEOUT: "timeout", self.CORRUPT: "corrupt"}[result]

    def close(self) -> None:
        pass


def _bus(line: NoisyLine) -> ServoBus:
    bus = ServoBus("scripted", Protocol.FEETECH, models={2: "sts3215"})
    bus._sdk = line  # type: ignore[assignment]
    return bus


@pytest.mark.parametrize("ack_late", [True, False],
                         ids=["noise, then the real acknowledgement", "a corrupt acknowledgement"])
def test_the_servos_state_after_the_write_is_never_hidden(ack_late: bool) -> None:
    line = NoisyLine(ack_late)
    bus = _bus(line)
    with pytest.raises(ServoAlarmError) as info:
        bus.write(2, Register.GOAL_POSITION, 2100)
    assert info.value.servo_id == 2 and "overload" in str(info.value)
    assert line.writes == 1  # checked by reading it back: never a second, ambiguous write
    assert bus.retry_counts() == {2: 1}
    if ack_late:
        assert bus.ledger.late[2] == 1  # the late acknowledgement was recognised as such


def test_a_write_that_did_not_arrive_is_sent_again() -> None:
    line = NoisyLine(ack_late=False)
    bus = _bus(line)
    original = line.send_write

    def lost_first(sid: int, addr: int, data: bytes) -> int:
        result = original(sid, addr, data)
        if line.writes == 1:
            line.memory.clear()  # the servo never got it: only noise came back
            line.error = 0
        return result

    line.send_write = lost_first  # type: ignore[method-assign]
    bus.write(2, Register.GOAL_POSITION, 2100)
    assert line.writes == 2 and line.memory
    assert bus.ledger.pending(2) == frozenset()
