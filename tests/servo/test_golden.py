"""Wire bytes of the real SDKs and of the simulated servos against the manuals' examples.

Vectors: the examples of the ROBOTIS e-Manual's Protocol 2.0 page (CRCs checked) and captures
of the Feetech SDK (SDK-FT 1.0.0, ``scservo_sdk``).
"""

from __future__ import annotations

import os
import select
import time

import pytest
import serial

from armctl.config.bus import Protocol
from armctl.servo import Register, ServoBus, SimServoSpec, SimulatedBus, WrongModel

pytestmark = pytest.mark.timeout(20)
H = bytes.fromhex


def _rx(trace: list[tuple[str, bytes]]) -> list[bytes]:
    return [b for d, b in trace if d == "rx"]


def _tx(trace: list[tuple[str, bytes]]) -> list[bytes]:
    return [b for d, b in trace if d == "tx"]


def test_dynamixel_ping_read_write_reboot(dxl_pair: tuple[SimulatedBus, ServoBus]) -> None:
    sim, bus = dxl_pair
    sim.inject(WrongModel(1, 1030))
    sim.servo(1).set(Register.FIRMWARE, 38)
    trace = sim.start_trace()
    res = bus.ping(1)
    assert (res.model_number, res.firmware) == (1030, 38)
    assert _rx(trace) == [H("FFFFFD0001030001194E")]
    assert _tx(trace) == [H("FFFFFD000107005500060426655D")]

    sim.servo(1).set_present_position(166)
    trace.clear()
    assert bus.read(1, Register.PRESENT_POSITION) == 166
    assert _rx(trace) == [H("FFFFFD0001070002840004001D15")]
    assert _tx(trace) == [H("FFFFFD000108005500A60000008CC0")]

    trace.clear()
    bus.write(1, Register.GOAL_POSITION, 512)
    assert _rx(trace) == [H("FFFFFD0001090003740000020000CA89")]
    assert _tx(trace) == [H("FFFFFD000104005500A10C")]

    trace.clear()
    bus.reboot(1)
    assert _rx(trace)[0] == H("FFFFFD00010300082F4E")


def test_dynamixel_sync_read_and_write(dxl_pair: tuple[SimulatedBus, ServoBus]) -> None:
    sim, bus = dxl_pair
    sim.servo(1).set_present_position(166)
    sim.servo(2).set_present_position(2079)
    trace = sim.start_trace()
    got = bus.sync_read([1, 2], [Register.PRESENT_POSITION])
    assert got[2][0][Register.PRESENT_POSITION] == 2079
    assert _rx(trace) == [H("FFFFFD00FE090082840004000102CEFA")]
    assert _tx(trace)[1] == H("FFFFFD0002080055001F080000BABE")

    trace.clear()
    bus.sync_write(Register.GOAL_POSITION, {1: 150, 2: 170})
    time.sleep(0.05)
    assert _rx(trace) == [H("FFFFFD00FE11008374000400019600000002AA0000008287")]
    assert _tx(trace) == []  # a sync write gets no reply
    assert sim.servo(2).get(Register.GOAL_POSITION) == 170


def test_dynamixel_broadcast_ping_packet() -> None:
    sim = SimulatedBus([SimServoSpec(1, "xl330-m288"), SimServoSpec(4, "xm430-w350")])
    with sim:
        trace = sim.start_trace()
        with ServoBus(sim.port, Protocol.DYNAMIXEL, latency_ms=8.0) as bus:
            found = bus.scan()
        assert [(f.servo_id, f.model) for f in found] == [(1, "xl330-m288"), (4, "xm430-w350")]
        assert _rx(trace) == [H("FFFFFD00FE0300013142")]


def _raw_exchange(port: str, packet: bytes, wait: float = 0.05) -> bytes:
    with serial.Serial(port, 1_000_000, timeout=0) as ser:
        ser.write(packet)
        out = b""
        end = time.monotonic() + wait
        while time.monotonic() < end:
            select.select([ser.fileno()], [], [], 0.005)
            out += ser.read(256)
        return out


def test_fast_sync_read_reply_is_manual_example() -> None:
    sim = SimulatedBus([SimServoSpec(3, "xl330-m288", 166), SimServoSpec(7, "xl330-m288", 2079),
                        SimServoSpec(4, "xl330-m288", 1023)])
    with sim:
        reply = _raw_exchange(sim.port, H("FFFFFD00FE0A008A8400040003070420F2"))
    assert reply == H("FFFFFD00FE190055" "0003A60000008408" "00071F08000016CA"
                      "0004FF030000D19E")


def test_bulk_read_manual_instruction_is_answered_in_order() -> None:
    sim = SimulatedBus([SimServoSpec(2, "xl430-w250"), SimServoSpec(1, "xl430-w250")])
    with sim:
        trace = sim.start_trace()
        _raw_exchange(sim.port, H("FFFFFD00FE0D0092019000020002920001001A05"))
    replies = _tx(trace)
    assert [r[4] for r in replies] == [1, 2]
    assert replies[0][5] == 2 + 4 and replies[1][5] == 1 + 4  # LEN = params + 4


def test_stuffed_reply_is_unstuffed_by_the_sdk(dxl_pair: tuple[SimulatedBus, ServoBus]) -> None:
    sim, bus = dxl_pair
    sim.servo(1).set(Register.GOAL_POSITION, 0x00FDFFFF)
    trace = sim.start_trace()
    assert bus.read(1, Register.GOAL_POSITION) == 0x00FDFFFF
    reply = _tx(trace)[0]
    assert b"\xff\xff\xfd\xfd" in reply[7:]  # the servo stuffed its status packet
    assert reply[5] == 4 + 4 + 1  # LEN counts the stuffing byte


def test_unstuffed_instruction_from_sdk_is_accepted(dxl_pair: tuple[SimulatedBus, ServoBus]
                                                    ) -> None:
    # SDK-DXL never stuffs what it sends (reference 1.3); the servo must still act on it.
    sim, bus = dxl_pair
    bus.write(2, Register.HOMING_OFFSET, -3)
    assert sim.servo(2).get(Register.HOMING_OFFSET) == -3


def test_feetech_golden_packets(ft_pair: tuple[SimulatedBus, ServoBus]) -> None:
    sim, bus = ft_pair
    trace = sim.start_trace()
    assert bus.ping(1).model_number == 777
    assert _rx(trace) == [H("FFFF010201FB"), H("FFFF0104020302F3")]
    assert _tx(trace) == [H("FFFF010200FC"), H("FFFF0104000903EE")]

    trace.clear()
    assert bus.read(1, Register.PRESENT_POSITION) == 2048
    assert _rx(trace) == [H("FFFF0104023802BE")]
    assert _tx(trace) == [H("FFFF0104000008F2")]

    trace.clear()
    bus.write(1, Register.GOAL_POSITION, 2048)
    assert _rx(trace) == [H("FFFF0105032A0008C4")]

    trace.clear()
    bus.sync_read([1, 2], [Register.PRESENT_POSITION])
    assert _rx(trace) == [H("FFFFFE0682380201023C")]

    trace.clear()
    bus.sync_write(Register.GOAL_POSITION, {1: 2048, 2: 4095})
    time.sleep(0.05)
    assert _rx(trace) == [H("FFFFFE0A832A0201000802FF0F2F")]
    assert _tx(trace) == []


def test_feetech_broadcast_ping_replies_ascending() -> None:
    sim = SimulatedBus([SimServoSpec(5, "sts3215"), SimServoSpec(2, "sts3215")],
                       Protocol.FEETECH)
    with sim, ServoBus(sim.port, Protocol.FEETECH, latency_ms=8.0) as bus:
        trace = sim.start_trace()
        found = bus.scan()
        assert [f.servo_id for f in found] == [2, 5]
        assert all(f.model == "sts3215" for f in found)
        assert [r[2] for r in _tx(trace)[:2]] == [2, 5]


def test_sync_read_replies_follow_request_order(dxl_pair: tuple[SimulatedBus, ServoBus]) -> None:
    sim, bus = dxl_pair
    trace = sim.start_trace()
    got = bus.sync_read([3, 1, 2], [Register.PRESENT_POSITION])
    assert list(got) == [3, 1, 2]
    assert [r[4] for r in _tx(trace)] == [3, 1, 2]


def test_pty_fds_closed_after_stop() -> None:
    sim = SimulatedBus([SimServoSpec(1, "sts3215")], Protocol.FEETECH)
    sim.start()
    fd = sim._master
    sim.stop()
    with pytest.raises(OSError):
        os.fstat(fd)


def test_sdk_fast_sync_read_bulk_read_and_bulk_write() -> None:
    import dynamixel_sdk as dxl

    sim = SimulatedBus([SimServoSpec(3, "xl330-m288", 166), SimServoSpec(7, "xl330-m288", 2079),
                        SimServoSpec(4, "xl330-m288", 1023)])
    with sim:
        port = dxl.PortHandler(sim.port)
        pk = dxl.PacketHandler(2.0)
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            group = dxl.GroupSyncRead(port, pk, 132, 4)
            for i in (3, 7, 4):
                group.addParam(i)
            assert group.fastSyncRead() == dxl.COMM_SUCCESS
            assert [group.getData(i, 132, 4) for i in (3, 7, 4)] == [166, 2079, 1023]
            bulk = dxl.GroupBulkRead(port, pk)
            bulk.addParam(3, 132, 4)
            bulk.addParam(7, 146, 1)
            assert bulk.txRxPacket() == dxl.COMM_SUCCESS
            assert bulk.getData(3, 132, 4) == 166 and bulk.getData(7, 146, 1) == 31
            write = dxl.GroupBulkWrite(port, pk)
            write.addParam(4, 65, 1, [1])
            assert write.txPacket() == dxl.COMM_SUCCESS
            time.sleep(0.02)
            assert sim.servo(4).get(Register.LED) == 1
        finally:
            port.closePort()


def test_clear_multi_turn_and_factory_reset_packets() -> None:
    import dynamixel_sdk as dxl

    sim = SimulatedBus([SimServoSpec(1, "xm430-w350", 9000, multi_turn=True)])
    with sim:
        trace = sim.start_trace()
        port = dxl.PortHandler(sim.port)
        pk = dxl.PacketHandler(2.0)
        assert port.openPort() and port.setBaudRate(1_000_000)
        try:
            assert pk.read4ByteTxRx(port, 1, 132)[0] == 9000
            assert pk.clearMultiTurn(port, 1) == (dxl.COMM_SUCCESS, 0)
            assert pk.read4ByteTxRx(port, 1, 132)[0] == 9000 % 4096
        finally:
            port.closePort()
        assert _rx(trace)[1] == H("FFFFFD00010800100144584C22B1DC")
        sim.servo(1).set(Register.RETURN_DELAY, 9)
        reply = _raw_exchange(sim.port, H("FFFFFD000104000601A1E6"))
        assert reply == H("FFFFFD000104005500A10C")
        assert sim.servo(1).id == 1 and sim.servo(1).get(Register.RETURN_DELAY) == 250


def test_garbage_and_malformed_packets_do_not_stop_the_simulator() -> None:
    from armctl.servo.codec import crc16

    sim = SimulatedBus([SimServoSpec(1, "xl330-m288")])
    with sim:
        short_read = H("FFFFFD000104000284")  # LEN 4: a Read with one parameter byte
        short_read += crc16(short_read).to_bytes(2, "little")
        assert _raw_exchange(sim.port, short_read) == b""
        # noise before the header is skipped; the ping is answered
        reply = _raw_exchange(sim.port, H("00FF12FFFF") + H("FFFFFD0001030001194E"))
        assert reply[:9] == H("FFFFFD000107005500")
        assert reply[9:11] == (1200).to_bytes(2, "little")  # XL330-M288
        with ServoBus(sim.port, Protocol.DYNAMIXEL, models={1: "xl330-m288"},
                      latency_ms=8.0) as bus:
            assert bus.read(1, Register.ID) == 1
