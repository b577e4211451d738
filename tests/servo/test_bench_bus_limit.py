"""The bus benchmark's wire limit counts the bytes the SDKs really put on the line.

``tools/bench_bus.py`` compares the achieved cycle rate with a limit computed from packet sizes;
here the sizes are checked against the packets the vendor SDKs build for the same cycle (sync
read, one status packet per servo as the maker's framing has it, sync write), not against the
tool's own arithmetic.
"""

from __future__ import annotations

import importlib.util
import sys
from types import ModuleType

import dynamixel_sdk
import pytest
import scservo_sdk
from armctl_testpaths import REPO

from armctl.config.bus import Protocol


def _tool() -> ModuleType:
    sys.path.insert(0, str(REPO / "tools"))
    try:
        spec = importlib.util.spec_from_file_location("bench_bus", REPO / "tools" / "bench_bus.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(REPO / "tools"))


class _Capture:
    is_using = False
    tx_time_per_byte = 0.01

    def __init__(self) -> None:
        self.written: list[bytes] = []

    def clearPort(self) -> None:
        pass

    def writePort(self, packet: list[int]) -> int:
        self.written.append(bytes(packet))
        return len(packet)

    def setPacketTimeout(self, n: int) -> None:
        pass


@pytest.mark.parametrize("protocol", [Protocol.DYNAMIXEL, Protocol.FEETECH])
@pytest.mark.parametrize(("n", "size"), [(6, 4), (6, 2), (1, 1), (12, 2)])
def test_cycle_bytes_are_the_sdk_packets(protocol: Protocol, n: int, size: int) -> None:
    port = _Capture()
    ids = list(range(1, n + 1))
    if protocol is Protocol.DYNAMIXEL:
        pk = dynamixel_sdk.PacketHandler(2.0)
        pk.syncReadTx(port, 132, size, ids, n, False)
        group = dynamixel_sdk.GroupSyncWrite(port, pk, 116, size)
        status = 11 + size  # e-Manual Protocol 2.0 status: FF FF FD 00 ID LEN(2) 55 ERR d CRC(2)
    else:
        pk = scservo_sdk.PacketHandler(0)
        pk.syncReadTx(port, 56, size, ids, n)
        group = scservo_sdk.GroupSyncWrite(port, pk, 42, size)
        status = 6 + size  # Feetech status: FF FF ID LEN ERR d CHK
    for sid in ids:
        group.addParam(sid, [0x11] * size)
    port.is_using = False  # the sync read awaits no reply here
    group.txPacket()
    read, write = port.written
    assert _tool().cycle_bytes(protocol, n, size) == len(read) + n * status + len(write)


def test_limit_is_ten_bit_times_a_byte_plus_the_return_delays() -> None:
    tool = _tool()
    nbytes = tool.cycle_bytes(Protocol.FEETECH, 6, 2)
    assert tool.limit(Protocol.FEETECH, 6, 2, 1_000_000, [0.0] * 6) == pytest.approx(
        1e6 / (10 * nbytes))
    assert 1 / tool.limit(Protocol.FEETECH, 6, 2, 500_000, [1e-4] * 6) == pytest.approx(
        20e-6 * nbytes + 6e-4)
