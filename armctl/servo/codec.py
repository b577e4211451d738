"""Wire-level arithmetic shared by the drivers and the simulated bus.

* Dynamixel Protocol 2.0: CRC-16/BUYPASS (polynomial 0x8005, initial 0, no reflection; check
  value 0xFEE8 for ``b"123456789"``), byte stuffing of ``FF FF FD`` (e-Manual "Packet Process").
* Feetech SCS/STS: ``~sum(ID..last param) & 0xFF`` checksum (Protocol 1.0 framing).
* Register values: two's complement (Dynamixel) and sign-magnitude (Feetech) encodings, and
  little-endian byte order (the low word first for 4-byte Feetech values).
"""

from __future__ import annotations

from armctl.servo_tables import Encoding, RegisterSpec

__all__ = [
    "crc16",
    "decode",
    "encode",
    "from_le",
    "stuff",
    "sum_checksum",
    "to_le",
    "unstuff",
]


def _crc_table() -> tuple[int, ...]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


_CRC_TABLE = _crc_table()


def crc16(data: bytes | bytearray | memoryview, crc: int = 0) -> int:
    """Dynamixel 2.0 CRC-16 of ``data`` (continuing from ``crc``)."""
    for b in data:
        crc = ((crc << 8) ^ _CRC_TABLE[((crc >> 8) ^ b) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Insert ``0xFD`` after every ``FF FF FD`` (applied from the INST byte to the last param)."""
    out = bytearray()
    for b in body:
        out.append(b)
        if b == 0xFD and len(out) >= 3 and out[-3] == 0xFF and out[-2] == 0xFF:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    """Remove the ``0xFD`` that follows ``FF FF FD`` (the inverse of :func:`stuff`)."""
    out = bytearray()
    i = 0
    while i < len(body):
        out.append(body[i])
        if (body[i] == 0xFD and len(out) >= 3 and out[-3] == 0xFF and out[-2] == 0xFF
                and i + 1 < len(body) and body[i + 1] == 0xFD):
            i += 1
        i += 1
    return bytes(out)


def sum_checksum(body: bytes | bytearray | memoryview) -> int:
    """Protocol 1.0-style checksum, ``~sum & 0xFF`` of the bytes from ID to the last param.

    Used by Feetech SCS/STS and Dynamixel Protocol 1.0.
    """
    return (~sum(body)) & 0xFF



def to_le(value: int, size: int) -> bytes:
    """``value`` (already encoded, non-negative) as ``size`` little-endian bytes."""
    return int(value & ((1 << (8 * size)) - 1)).to_bytes(size, "little")


def from_le(data: bytes | bytearray | list[int]) -> int:
    """An unsigned integer from little-endian bytes."""
    return int.from_bytes(bytes(data), "little")


def encode(spec: RegisterSpec, value: int) -> int:
    """A signed value as the raw unsigned word stored in the register.

    Raises:
        OverflowError: If the value cannot be represented.
    """
    bits = 8 * spec.size
    if spec.encoding is Encoding.TWOS_COMPLEMENT:
        if not -(1 << (bits - 1)) <= value < (1 << (bits - 1)):
            raise OverflowError(f"{value} does not fit {bits} signed bits")
        return value & ((1 << bits) - 1)
    if spec.encoding is Encoding.SIGN_MAGNITUDE:
        mag = abs(value)
        if mag >= (1 << spec.sign_bit):
            raise OverflowError(f"magnitude {mag} exceeds bit {spec.sign_bit}")
        return mag | (1 << spec.sign_bit) if value < 0 else mag
    if not 0 <= value < (1 << bits):
        raise OverflowError(f"{value} does not fit {bits} unsigned bits")
    return value


def decode(spec: RegisterSpec, raw: int) -> int:
    """The signed value of the raw register word ``raw``."""
    bits = 8 * spec.size
    raw &= (1 << bits) - 1
    if spec.encoding is Encoding.TWOS_COMPLEMENT:
        return raw - (1 << bits) if raw & (1 << (bits - 1)) else raw
    if spec.encoding is Encoding.SIGN_MAGNITUDE:
        sign = 1 << spec.sign_bit
        return -(raw & (sign - 1)) if raw & sign else raw & (sign - 1)
    return raw
