"""Checksums, stuffing and value encodings against the manuals' and SDKs' numbers."""

from __future__ import annotations

import pytest

from armctl.servo.codec import crc16, decode, encode, stuff, sum_checksum, unstuff
from armctl.servo_tables import Register, table_for


def test_crc16_check_value_and_manual_packets() -> None:
    # CRC-16/BUYPASS check value; e-Manual P2 ping and read packets end with these CRCs.
    assert crc16(b"123456789") == 0xFEE8
    ping = bytes.fromhex("FFFFFD0001030001")
    assert crc16(ping) == 0x4E19
    read = bytes.fromhex("FFFFFD000107000284000400")
    assert crc16(read) == 0x151D


def test_crc16_matches_sdk_table() -> None:
    import dynamixel_sdk as dxl

    pk = dxl.PacketHandler(2.0)
    data = bytes(range(256)) * 2
    assert crc16(data) == pk.updateCRC(0, list(data), len(data))


def test_stuffing_round_trip_and_example() -> None:
    body = bytes.fromhex("5500FFFFFD00")
    stuffed = stuff(body)
    assert stuffed == bytes.fromhex("5500FFFFFDFD00")
    assert unstuff(stuffed) == body
    assert stuff(b"\x55\x00\x01\x02") == b"\x55\x00\x01\x02"


def test_feetech_checksum_golden() -> None:
    # SDK-FT 1.0.0 ping of id 1: FF FF 01 02 01 FB
    assert sum_checksum(bytes([1, 2, 1])) == 0xFB
    assert sum_checksum(bytes.fromhex("0104000903")) == 0xEE


@pytest.mark.parametrize(("value", "bit", "raw"), [(-5, 15, 0x8005), (-5, 11, 0x805),
                                                     (2047, 11, 2047), (-2047, 11, 0xFFF)])
def test_sign_magnitude(value: int, bit: int, raw: int) -> None:
    table = table_for("sts3215")
    reg = Register.HOMING_OFFSET if bit == 11 else Register.GOAL_POSITION
    spec = table.spec(reg)
    assert spec.sign_bit == bit
    assert encode(spec, value) == raw
    assert decode(spec, raw) == value


def test_sign_magnitude_overflow_refused() -> None:
    spec = table_for("sts3215").spec(Register.HOMING_OFFSET)
    with pytest.raises(OverflowError):
        encode(spec, 2114)  # lerobot#1296: magnitude 2114 exceeds bit 11


def test_twos_complement() -> None:
    spec = table_for("xm430-w350").spec(Register.PRESENT_POSITION)
    assert encode(spec, -1) == 0xFFFFFFFF
    assert decode(spec, 0xFFFFFFFE) == -2
    load = table_for("xl430-w250").spec(Register.PRESENT_LOAD)
    assert decode(load, 0xFC18) == -1000
