"""Framing of the two wire protocols, as the simulated servos see them.

:class:`Protocol2Wire` frames Protocol 2.0 instruction packets (ROBOTIS e-Manual "Protocol
2.0") by header and LEN, checks the CRC over the bytes as received and removes byte stuffing only
where ``FF FF FD FD`` occurs (the SDK never stuffs what it sends). Status packets are stuffed.
:class:`Protocol1Wire` frames ``FF FF ID LEN INST P.. CHK`` packets with the Protocol 1.0
checksum (also the SCS/STS framing). Both resynchronise on garbage by dropping one byte at a
time.
"""

from __future__ import annotations

from dataclasses import dataclass

from armctl.servo.codec import crc16, stuff, sum_checksum, to_le, unstuff

__all__ = ["Instruction", "Protocol1Wire", "Protocol2Wire", "Wire"]

BROADCAST = 0xFE


@dataclass(frozen=True)
class Instruction:
    """A framed instruction packet.

    Attributes:
        servo_id: Target id (0xFE broadcast).
        inst: Instruction code.
        params: Parameters with stuffing removed.
        size: Bytes it occupied on the wire.
        valid: Whether its CRC/checksum was right.
        raw: The packet's bytes as received.
    """

    servo_id: int
    inst: int
    params: bytes
    size: int
    valid: bool = True
    raw: bytes = b""


class Protocol2Wire:
    """Protocol 2.0 framing."""

    addr_size = 2
    header = b"\xff\xff\xfd"

    def frame(self, buf: bytearray) -> list[Instruction]:
        """Take every complete instruction from the front of ``buf`` (consumed in place)."""
        out: list[Instruction] = []
        while True:
            i = buf.find(self.header)
            while i >= 0 and i + 3 < len(buf) and buf[i + 3] == 0xFD:
                i = buf.find(self.header, i + 1)
            if i < 0:
                del buf[:max(0, len(buf) - 2)]
                return out
            del buf[:i]
            if len(buf) < 7:
                return out
            length = buf[5] | (buf[6] << 8)
            if buf[3] != 0 or length < 3 or length > 1024:
                del buf[0]
                continue
            total = 7 + length
            if len(buf) < total:
                return out
            pkt = bytes(buf[:total])
            del buf[:total]
            ok = crc16(pkt[:-2]) == (pkt[-2] | (pkt[-1] << 8))
            out.append(Instruction(pkt[4], pkt[7], unstuff(pkt[8:-2]), total, ok, pkt))

    def status(self, servo_id: int, error: int, params: bytes) -> bytes:
        """A stuffed status packet."""
        body = stuff(bytes([0x55, error]) + params)
        head = b"\xff\xff\xfd\x00" + bytes([servo_id]) + to_le(len(body) + 2, 2)
        pkt = head + body
        return pkt + to_le(crc16(pkt), 2)

    def fast_status(self, segments: list[tuple[int, int, bytes]]) -> bytes:
        """A Fast Sync Read or Fast Bulk Read reply: one packet, no stuffing.

        Each servo's segment is ``error, id, data, CRC``, the CRC running over the packet so
        far (e-Manual Protocol 2.0 "Fast Sync Read", "Fast Bulk Read").

        Args:
            segments: ``(id, error byte, data)`` per servo, in the instruction's order.
        """
        length = 1 + sum(len(data) + 4 for _, _, data in segments)
        pkt = bytearray(b"\xff\xff\xfd\x00\xfe" + to_le(length, 2) + b"\x55")
        for sid, err, data in segments:
            pkt += bytes([err, sid]) + data
            pkt += to_le(crc16(pkt), 2)
        return bytes(pkt)

    def addr_len(self, params: bytes) -> tuple[int, int, bytes]:
        """``(address, length, rest)`` of a read-type parameter block."""
        return params[0] | params[1] << 8, params[2] | params[3] << 8, params[4:]


class Protocol1Wire:
    """Protocol 1.0 framing (SCS/STS: the same, plus Sync Read)."""

    addr_size = 1

    def frame(self, buf: bytearray) -> list[Instruction]:
        """Take every complete instruction from the front of ``buf`` (consumed in place)."""
        out: list[Instruction] = []
        while True:
            i = buf.find(b"\xff\xff")
            while i >= 0 and i + 2 < len(buf) and buf[i + 2] == 0xFF:
                i += 1
            if i < 0:
                del buf[:max(0, len(buf) - 1)]
                return out
            del buf[:i]
            if len(buf) < 4:
                return out
            length = buf[3]
            if buf[2] > BROADCAST or length < 2 or length > 250:
                del buf[0]
                continue
            total = 4 + length
            if len(buf) < total:
                return out
            pkt = bytes(buf[:total])
            del buf[:total]
            ok = sum_checksum(pkt[2:-1]) == pkt[-1]
            out.append(Instruction(pkt[2], pkt[4], pkt[5:-1], total, ok, pkt))

    def status(self, servo_id: int, error: int, params: bytes) -> bytes:
        """A status packet; the error byte never has bit 7 set."""
        body = bytes([servo_id, len(params) + 2, error & 0x7F]) + params
        return b"\xff\xff" + body + bytes([sum_checksum(body)])

    def addr_len(self, params: bytes) -> tuple[int, int, bytes]:
        """``(address, length, rest)`` of a read-type parameter block."""
        return params[0], params[1], params[2:]

    def fast_status(self, segments: list[tuple[int, int, bytes]]) -> bytes:
        """Protocol 1.0 has no fast group reads.

        Raises:
            ValueError: Always.
        """
        raise ValueError("Protocol 1.0 has no combined group read reply")


#: The framing of one protocol.
Wire = Protocol2Wire | Protocol1Wire
