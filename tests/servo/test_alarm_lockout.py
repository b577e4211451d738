"""After a servo reports an alarm, nothing more is sent to it until the user clears it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from armctl.cli import main
from armctl.config import load_spec
from armctl.robot import Robot
from armctl.robot.errors import MotionStopped, StopReason
from armctl.servo import Alarm, ArmBus, HardwareAlarm, Register, simulated_bus
from armctl.servo.errors import ServoAlarmError

pytestmark = pytest.mark.timeout(60)
SO_SIM = Path(__file__).parent / "data" / "so_sim.yaml"
SYNC_WRITE = 0x83


def _written_ids(trace: list[tuple[str, bytes]]) -> set[int]:
    """Servo ids addressed by the Feetech write instructions received (sync or unicast)."""
    ids: set[int] = set()
    for direction, pkt in trace:
        if direction != "rx":
            continue
        sid, inst, params = pkt[2], pkt[4], pkt[5:-1]
        if inst == SYNC_WRITE:
            n = params[1]
            ids.update(params[i] for i in range(2, len(params), n + 1))
        elif inst in (0x03, 0x04):  # write, reg write
            ids.add(sid)
    return ids


def test_goal_writes_to_an_overloaded_servo_are_refused() -> None:
    with ArmBus.from_spec(load_spec(SO_SIM)) as ab:
        sim = ab.simulator
        assert sim is not None
        ab.set_torque(True)
        q = ab.read_joints()
        sim.inject(HardwareAlarm(3, Alarm.OVERLOAD))
        assert ab.read_state().errors[2] == (Alarm.OVERLOAD,)
        assert ab.alarmed == {"elbow_flex": (Alarm.OVERLOAD,)}
        trace = sim.start_trace()
        with pytest.raises(ServoAlarmError) as info:
            ab.write_joints(q)
        text = str(info.value)
        assert info.value.servo_id == 3 and "elbow_flex" in text and "overload" in text
        assert "--clear-alarms" in text and "clear_alarms" in text
        with pytest.raises(ServoAlarmError):
            ab.set_torque(True, ["elbow_flex"])
        with pytest.raises(ServoAlarmError):
            ab.write_eeprom(3, [(Register.RETURN_DELAY, 0)])
        assert not _written_ids(trace)  # nothing at all was sent
        step = np.array([0.05, 0.05, 0.05, 0.05, 0.05, 0.0])
        ab.write_joints(q + step, skip_alarmed=True)  # a stop: the others still get goals
        ab.set_torque(False, ["elbow_flex"])  # torque off is always allowed
        assert _written_ids(trace) == {1, 2, 4, 5, 6} | {3}
        assert 3 not in _written_ids(trace[:-2])  # only the torque-off write reached it
        assert ab.clear_alarms() == ["elbow_flex"]  # reboot: cleared, torque comes back off
        assert ab.alarmed == {} and ab.read_state().ok
        ab.set_torque(True)
        ab.write_joints(q)


def test_a_stop_after_an_alarm_sends_nothing_more_to_that_servo() -> None:
    with Robot.open(SO_SIM) as robot:
        sim = robot.bus.simulator  # type: ignore[attr-defined]
        assert sim is not None
        trace = sim.start_trace()
        seen: list[object] = []

        def on_cycle(info: object) -> None:
            seen.append(info)
            if len(seen) == 6:
                sim.inject(HardwareAlarm(3, Alarm.OVERLOAD))
        with pytest.raises(MotionStopped) as info:
            robot.execute(robot.plan_joints(np.array([0.4, 0.3, 0.3, 0, 0, 0.01]), 1.0),
                          on_cycle=on_cycle)
        assert info.value.reason is StopReason.SERVO_ERROR and info.value.servo_id == 3
        # the first status packet of servo 3 with the overload bit (0x20)...
        first = next(i for i, (d, p) in enumerate(trace)
                     if d == "tx" and p[2] == 3 and p[4] & 0x20)
        after = _written_ids(trace[first:])
        assert 3 not in after  # ...and no goal or write to servo 3 after it
        assert {1, 2} <= after  # while the others decelerated
        with pytest.raises(ServoAlarmError):
            robot.hold()  # torque on for the alarmed servo is refused too


def test_cli_torque_refuses_an_alarmed_servo_until_cleared(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    sim = simulated_bus(load_spec(SO_SIM))
    sim.start()
    try:
        cfg = tmp_path / "arm.yaml"
        cfg.write_text(SO_SIM.read_text().replace("port: sim", f"port: {sim.port}"))
        sim.inject(HardwareAlarm(3, Alarm.OVERLOAD))
        code = main(["torque", str(cfg), "on"])
        err = capsys.readouterr().err
        assert code == 4 and "elbow_flex" in err and "--clear-alarms" in err
        assert not sim.servo(3).torque
        code = main(["torque", str(cfg), "on", "--clear-alarms"])
        out = capsys.readouterr().out
        assert code == 0 and "alarms cleared" in out and "elbow_flex" in out
        assert sim.servo(3).torque and sim.servo(3).alarm_bits == 0
    finally:
        sim.stop()
