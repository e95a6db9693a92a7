"""Dynamixel Protocol 2.0 framing, written independently of ``dynamixel_sdk``.

The emulated bus (``xm430.py``) reads the instruction packets the real SDK sends and writes
the status packets it expects with this module, so a test of the SDK against the emulator
compares two implementations of the protocol. Packet layout (little-endian)::

    FF FF FD 00 | ID | LEN_L LEN_H | INST | PARAMS... | CRC_L CRC_H

``LEN`` counts INST + PARAMS + 2 CRC bytes after byte stuffing (an FD inserted after every
FF FF FD in INST/PARAMS). The CRC is CRC-16/BUYPASS over every byte before it. A status
packet has INST = 0x55 and the error byte as its first parameter. More:
``docs/design/rig.md``.
"""

from __future__ import annotations

from dataclasses import dataclass

HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE

# Instructions
PING, READ, WRITE, REG_WRITE, ACTION, FACTORY_RESET, REBOOT = 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x08
CLEAR, STATUS, SYNC_READ, SYNC_WRITE, BULK_READ, BULK_WRITE = 0x10, 0x55, 0x82, 0x83, 0x92, 0x93

# Error byte of a status packet: an error number in bits 0-6 and the alert bit 7
ERR_RESULT_FAIL, ERR_INSTRUCTION, ERR_CRC, ERR_DATA_RANGE = 1, 2, 3, 4
ERR_DATA_LENGTH, ERR_DATA_LIMIT, ERR_ACCESS = 5, 6, 7
ERR_ALERT = 0x80


def _crc_table(poly: int = 0x8005) -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ poly) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


CRC_TABLE = _crc_table()


def crc16(data: bytes) -> int:
    """CRC-16 of ``data`` as Protocol 2.0 computes it (polynomial 0x8005, init 0)."""
    crc = 0
    for b in data:
        crc = ((crc << 8) ^ CRC_TABLE[((crc >> 8) ^ b) & 0xFF]) & 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """Insert an FD after every FF FF FD in ``body`` (instruction + parameters)."""
    out = bytearray()
    for b in body:
        out.append(b)
        if b == 0xFD and out[-3:-1] == b"\xff\xff" and len(out) >= 3:
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    """Remove the FD inserted after every FF FF FD (inverse of :func:`stuff`)."""
    out = bytearray()
    i = 0
    while i < len(body):
        out.append(body[i])
        if (
            body[i] == 0xFD
            and out[-3:-1] == b"\xff\xff"
            and len(out) >= 3
            and i + 1 < len(body)
            and body[i + 1] == 0xFD
        ):
            i += 1  # skip the stuffing byte
        i += 1
    return bytes(out)


def encode(dxl_id: int, instruction: int, params: bytes = b"", *, corrupt_crc: bool = False) -> bytes:
    """A complete packet with header, stuffing and CRC (``corrupt_crc`` flips the CRC)."""
    body = stuff(bytes([instruction]) + bytes(params))
    length = len(body) + 2
    head = HEADER + bytes([dxl_id, length & 0xFF, length >> 8]) + body
    crc = crc16(head) ^ (0xFFFF if corrupt_crc else 0)
    return head + bytes([crc & 0xFF, crc >> 8])


def status(dxl_id: int, error: int, data: bytes = b"", *, corrupt_crc: bool = False) -> bytes:
    """A status packet: error byte then ``data``."""
    return encode(dxl_id, STATUS, bytes([error]) + bytes(data), corrupt_crc=corrupt_crc)


@dataclass(frozen=True)
class Packet:
    """A received packet: ``crc_ok`` False when the CRC did not match (params unusable)."""

    dxl_id: int
    instruction: int
    params: bytes
    crc_ok: bool


class PacketReader:
    """Incremental parser: ``feed(bytes)`` returns the complete packets found so far.

    Bytes before a header are dropped (line noise); a packet is returned once all its
    ``LEN`` bytes have arrived.
    """

    MAX_LENGTH = 1024

    def __init__(self):
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[Packet]:
        self._buf += data
        packets = []
        while True:
            start = self._buf.find(HEADER)
            if start < 0:
                del self._buf[: max(0, len(self._buf) - 3)]  # keep a possible partial header
                return packets
            del self._buf[:start]
            if len(self._buf) < 7:
                return packets
            length = self._buf[5] | (self._buf[6] << 8)
            if length < 3 or length > self.MAX_LENGTH:
                del self._buf[:4]  # not a real header: resynchronise
                continue
            total = 7 + length
            if len(self._buf) < total:
                return packets
            raw = bytes(self._buf[:total])
            del self._buf[:total]
            crc_ok = crc16(raw[:-2]) == (raw[-2] | (raw[-1] << 8))
            body = unstuff(raw[7:-2])
            packets.append(Packet(raw[4], body[0] if body else -1, body[1:], crc_ok))
