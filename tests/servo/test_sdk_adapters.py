"""The vendor adapters send the SDKs' own packets, read ahead safely and read error bytes right.

The adapters keep each sync packet and patch data and checksum into it; every packet they put on
the line must equal, byte for byte, what the vendor SDK's own builders (``GroupSyncWrite``,
``syncReadTx``) make for the same request, for random data, ids and addresses, including data
that needs Dynamixel byte stuffing (the packet is then the SDK's again: ``dynamixel_sdk`` 4.1.0
builds it without the stuffing byte, and armctl sends what the SDK builds). The line is a real
pseudo-terminal: the bytes are read at its other end.
"""

from __future__ import annotations

import os
import random
import select
import threading
import time
import tty
from collections.abc import Iterator
from typing import Any

import dynamixel_sdk
import pytest
import scservo_sdk

from armctl.servo.dynamixel.sdk import Dxl1Sdk, DxlSdk
from armctl.servo.feetech.sdk import FeetechSdk
from armctl.servo.sdk import Sdk
from armctl.servo_tables import Alarm

ADAPTERS = [DxlSdk, Dxl1Sdk, FeetechSdk]
_GROUPS = {DxlSdk: dynamixel_sdk.GroupSyncWrite, Dxl1Sdk: dynamixel_sdk.GroupSyncWrite,
           FeetechSdk: scservo_sdk.GroupSyncWrite}
IDS = ["dynamixel2", "dynamixel1", "feetech"]


class _Capture:
    """A stand-in port for the SDK's builders: keeps what they write."""

    is_using = False
    tx_time_per_byte = 0.01

    def __init__(self) -> None:
        self.written: list[bytes] = []
        self.timeout_bytes: int | None = None

    def clearPort(self) -> None:
        pass

    def writePort(self, packet: list[int]) -> int:
        self.written.append(bytes(packet))
        return len(packet)

    def setPacketTimeout(self, n: int) -> None:
        self.timeout_bytes = n


def _sdk_sync_write(adapter: Sdk, addr: int, n: int, items: dict[int, bytes]) -> bytes:
    port = _Capture()
    group = _GROUPS[type(adapter)](port, adapter.pk, addr, n)
    for sid, data in items.items():
        assert group.addParam(sid, list(data))
    group.txPacket()
    return port.written[-1]


def _sdk_sync_read(adapter: Sdk, addr: int, n: int, ids: list[int]) -> tuple[bytes, int | None]:
    port = _Capture()
    if isinstance(adapter, DxlSdk):
        adapter.pk.syncReadTx(port, addr, n, ids, len(ids), False)
    else:
        adapter.pk.syncReadTx(port, addr, n, ids, len(ids))
    return port.written[-1], port.timeout_bytes


@pytest.fixture(params=ADAPTERS, ids=IDS)
def line(request: pytest.FixtureRequest) -> Iterator[tuple[Sdk, int]]:
    """An open adapter on a pseudo-terminal, and the terminal's other end."""
    master, slave = os.openpty()
    tty.setraw(master)
    tty.setraw(slave)
    adapter = request.param(os.ttyname(slave), 1.0)
    assert adapter.open(1_000_000)
    try:
        yield adapter, master
    finally:
        adapter.close()
        os.close(master)
        os.close(slave)


def _sent(master: int, size: int) -> bytes:
    """What arrived at the line's other end: ``size`` bytes, and nothing more within 1 ms."""
    out = b""
    while len(out) < size and select.select([master], [], [], 1.0)[0]:
        out += os.read(master, 4096)
    if select.select([master], [], [], 0.001)[0]:
        out += os.read(master, 4096)
    return out


def _random_data(rng: random.Random, n: int, stuffing: bool) -> bytes:
    if stuffing and n >= 3:  # a Protocol 2.0 header inside the data
        at = rng.randrange(n - 2)
        raw = bytearray(rng.randbytes(n))
        raw[at:at + 3] = b"\xff\xff\xfd"
        return bytes(raw)
    return rng.randbytes(n)


def test_sync_writes_are_the_sdks_packets_for_random_requests(line: tuple[Sdk, int]) -> None:
    adapter, master = line
    rng = random.Random(18)
    stuffed = 0
    for case in range(300):
        n = rng.choice([1, 2, 4, 3, 6])
        ids = rng.sample(range(0, 253), rng.randint(1, 8))
        addr = rng.randrange(0, 200)
        # the same request many times (the kept packet is patched), now and then a new one
        if case % 50:
            ids, addr, n = [1, 2, 3, 4, 5, 6], 116 if isinstance(adapter, DxlSdk) else 42, 4
        items = {sid: _random_data(rng, n, stuffing=case % 7 == 0) for sid in ids}
        want = _sdk_sync_write(adapter, addr, n, items)
        if b"\xff\xff\xfd" in want[7:-2]:
            stuffed += 1  # a header inside the data: the kept packet cannot simply be patched
        assert adapter.sync_write(addr, n, items) == adapter.SUCCESS
        assert _sent(master, len(want)) == want, (case, addr, n, items)
        assert not adapter.port.is_using  # no reply: the port is free again
    assert stuffed > 10


def test_a_kept_sync_write_is_patched_not_built_again(line: tuple[Sdk, int],
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    adapter, master = line
    built = []
    real = adapter._sync_write_cls

    def counting(*args: Any) -> Any:
        built.append(args[2:])
        return real(*args)
    monkeypatch.setattr(adapter, "_sync_write_cls", counting)
    items = {1: b"\x00\x08", 2: b"\x10\x07"}
    for k in range(20):
        items[2] = bytes([k, 7])
        adapter.sync_write(42, 2, items)
        want = _sdk_sync_write(adapter, 42, 2, items)
        assert _sent(master, len(want)) == want
    assert built == [(42, 2)]  # once, for the template
    adapter.sync_write(42, 2, {1: b"\x00\x08", 3: b"\x00\x08"})  # other ids: a new template
    assert built == [(42, 2), (42, 2)]


def test_sync_reads_are_the_sdks_packets_with_its_timeout(line: tuple[Sdk, int]) -> None:
    adapter, master = line
    if not adapter.has_sync_read:
        assert adapter.sync_read_tx(56, 2, [1, 2]) == adapter.NOT_AVAILABLE
        return
    rng = random.Random(14)
    for _ in range(50):
        ids = rng.sample(range(0, 253), rng.randint(1, 10))
        addr, n = rng.randrange(0, 250), rng.randint(1, 20)
        want, timeout_bytes = _sdk_sync_read(adapter, addr, n, ids)
        assert adapter.sync_read_tx(addr, n, ids) == adapter.SUCCESS
        assert _sent(master, len(want)) == want
        port = adapter.port
        assert port.packet_timeout == pytest.approx(
            port.tx_time_per_byte * timeout_bytes + 2 * port.latency_ms + 2.0)
        adapter.flush_input()


def test_a_packet_the_sdk_refuses_to_build_is_not_sent(line: tuple[Sdk, int]) -> None:
    adapter, master = line
    too_many = {sid: bytes(4) for sid in range(250)}  # longer than the SDK's packet buffer
    want = _GROUPS[type(adapter)](_Capture(), adapter.pk, 42, 4)
    for sid, data in too_many.items():
        want.addParam(sid, list(data))
    try:
        refused = want.txPacket()
    except IndexError:  # dynamixel_sdk 4.1.0 overruns its stuffing buffer instead
        with pytest.raises(IndexError):
            adapter.sync_write(42, 4, too_many)
    else:
        assert refused != adapter.SUCCESS
        assert adapter.sync_write(42, 4, too_many) == refused
    assert adapter.sync_write(42, 4, {}) == adapter.NOT_AVAILABLE
    if adapter.has_sync_read:
        try:
            result: int | None = adapter.sync_read_tx(42, 4, list(range(250)) * 5)
        except IndexError:  # dynamixel_sdk 4.1.0, as above
            result = None
        assert result != adapter.SUCCESS
    assert not select.select([master], [], [], 0.05)[0]  # nothing was sent


def test_a_sync_packet_waits_for_a_busy_port(line: tuple[Sdk, int]) -> None:
    adapter, master = line
    adapter.port.is_using = True  # a transaction is awaiting its reply
    assert adapter.sync_write(42, 2, {1: b"\x00\x08"}) == adapter.PORT_BUSY
    assert not select.select([master], [], [], 0.05)[0]  # nothing was sent


def _status(adapter: Sdk, sid: int, error: int, data: bytes) -> bytes:
    """A status packet built from the maker's framing (independent of the adapter)."""
    if type(adapter) is DxlSdk:  # e-Manual Protocol 2.0: header, ID, LEN, 0x55, ERR, data, CRC
        from armctl.servo.codec import crc16

        body = b"\xff\xff\xfd\x00" + bytes([sid]) + (len(data) + 4).to_bytes(2, "little") \
            + bytes([0x55, error]) + data
        return body + crc16(body).to_bytes(2, "little")
    body = bytes([sid, len(data) + 2, error]) + data  # Protocol 1.0 / SCS: FF FF ID LEN ERR
    return b"\xff\xff" + body + bytes([~sum(body) & 0xFF])


def test_replies_arriving_together_are_read_ahead_and_flushed_before_a_transmit(
        line: tuple[Sdk, int]) -> None:
    adapter, master = line
    packets = [_status(adapter, sid, 0, bytes([sid, 8])) for sid in (1, 2, 3)]
    os.write(master, b"".join(packets))
    time.sleep(0.02)
    adapter.port.setPacketTimeoutMillis(50)
    rx, result = adapter.receive()
    assert result == adapter.SUCCESS and adapter.status(rx) == (1, 0, [1, 8])
    # the rest was read in the same call and is still counted as waiting input
    assert adapter.port.unread() == len(packets[1]) + len(packets[2])
    assert adapter.waiting() == adapter.port.unread()
    assert [s[0] for s in adapter.drain()] == [2, 3]
    os.write(master, packets[0])
    time.sleep(0.02)
    assert adapter.waiting() == len(packets[0])
    adapter.port.setPacketTimeoutMillis(50)
    adapter.port.readPort(3)  # part of it read (and more read ahead) ...
    assert adapter.port.unread() == len(packets[0]) - 3
    adapter.sync_write(42, 2, {1: b"\x00\x08"})  # ... and flushed by the next transmit
    assert adapter.waiting() == 0


def test_a_reply_split_across_reads_is_waited_for_until_its_timeout(
        line: tuple[Sdk, int]) -> None:
    adapter, master = line
    packet = _status(adapter, 7, 0, bytes([1, 2, 3, 4]))
    os.write(master, packet[:5])
    adapter.port.setPacketTimeoutMillis(200)
    t0 = time.monotonic()
    later = threading.Timer(0.05, lambda: os.write(master, packet[5:]))
    later.start()
    try:
        rx, result = adapter.receive()
    finally:
        later.join()
    assert result == adapter.SUCCESS and adapter.status(rx) == (7, 0, [1, 2, 3, 4])
    assert 0.04 < time.monotonic() - t0 < 0.19
    adapter.port.setPacketTimeoutMillis(30)  # nothing comes: a timeout, after 30 ms
    t0 = time.monotonic()
    _, result = adapter.receive()
    assert result == adapter.TIMEOUT and 0.025 < time.monotonic() - t0 < 0.2


# ---- the error byte, per the makers' documents ----------------------------------------------

def test_protocol2_error_numbers_and_alert_bit() -> None:
    # e-Manual Protocol 2.0, Status Packet "Error": bits 0-6 the error number, bit 7 Alert
    assert DxlSdk.refusal(0) is None and DxlSdk.refusal(0x80) is None
    assert DxlSdk.refusal(7) == ("access error", True)
    assert DxlSdk.refusal(0x84) == ("data range error (value outside the register's range)",
                                    False)
    assert DxlSdk.alarms_in(0x80) is None  # read Hardware Error Status for the cause
    assert DxlSdk.alarms_in(0x07) == ()
    assert DxlSdk.access_errors and not Dxl1Sdk.access_errors


def test_protocol1_error_bits() -> None:
    # e-Manual Protocol 1.0, Status Packet "Error": bit 0 input voltage, 1 angle limit,
    # 2 overheating, 3 range, 4 checksum, 5 overload, 6 instruction
    assert Dxl1Sdk.alarms_in(0x01 | 0x04 | 0x20) == (Alarm.INPUT_VOLTAGE, Alarm.OVERHEATING,
                                                     Alarm.OVERLOAD)
    assert Dxl1Sdk.refusal(0x25) is None  # alarms only
    assert Dxl1Sdk.refusal(0x08) == ("range error", True)
    assert Dxl1Sdk.refusal(0x02 | 0x40) == ("angle limit error, instruction error", False)


def test_feetech_status_byte_is_alarms_only() -> None:
    # SDK-FT ERRBIT_VOLTAGE 1, ERRBIT_ANGLE 2, ERRBIT_OVERHEAT 4, ERRBIT_OVERELE 8,
    # ERRBIT_OVERLOAD 32
    assert all(FeetechSdk.refusal(b) is None for b in range(256))
    assert FeetechSdk.alarms_in(0) == ()
    assert FeetechSdk.alarms_in(1 | 32) == (Alarm.INPUT_VOLTAGE, Alarm.OVERLOAD)
    assert FeetechSdk.alarms_in(4) == (Alarm.OVERHEATING,)
