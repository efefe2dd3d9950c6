"""Per-message checksums, pluggable by name in the binding (``checksum = "toyota"``).

Each kind is a pure function of the frame id, the payload length and the payload with the
checksum's own bits set to zero; it returns the checksum value. The codec computes it when
encoding and compares it when decoding.

* ``pacc_crc8`` — pacc's own CRC-8 SAE J1850 over the 16-bit data id and the payload
  (:mod:`dbc.e2e`; the codec unrolls it per message). A whole byte.
* ``autosar_p01`` — AUTOSAR E2E profile 1 with data id mode BOTH: CRC-8 with the J1850
  polynomial 0x1D, start value 0x00 and no final XOR, over the data id (low byte, high byte;
  the frame id) and every payload byte but the CRC byte; its alive counter counts 0…14.
  Checked against the ``autosar-e2e`` package (tests/dbc/test_checksums.py).
* ``toyota`` — the sum of the payload bytes but the last, the bytes of the frame id and the
  length, modulo 256, in the last byte (the scheme of Toyota's powertrain network as opendbc
  describes it: opendbc/car/toyota/toyotacan.py, MIT licence; written here from that
  description).
* ``honda`` — 4 bits in the low nibble of the last byte: 8 minus the sum of every nibble of
  the frame id and of the payload (the checksum nibble excluded), plus 3 for an extended id,
  modulo 16 (opendbc/car/honda/hondacan.py, likewise).
* ``none`` — no checksum.
"""

from __future__ import annotations

from collections.abc import Callable

from dbc.e2e import crc8_update, e2e_crc
from dbc.errors import DbcError

#: a checksum bound to one message: payload (checksum bits zero) -> checksum value
Checksum = Callable[[bytes], int]

KINDS: tuple[str, ...] = ("pacc_crc8", "autosar_p01", "toyota", "honda", "none")

#: table CRC-8 kinds the codec unrolls: kind -> (register start value, final XOR)
TABLE_CRCS: dict[str, tuple[int, int]] = {"pacc_crc8": (0xFF, 0xFF), "autosar_p01": (0x00, 0x00)}
#: alive counter period of kinds that fix it (AUTOSAR E2E profile 1: 0..14)
COUNTER_MODULO: dict[str, int] = {"autosar_p01": 15}


def toyota(frame_id: int, length: int) -> Checksum:
    """Toyota's 8-bit sum checksum of a message (it must sit in the last byte)."""
    base = length
    addr = frame_id
    while addr:
        base += addr & 0xFF
        addr >>= 8

    def checksum(payload: bytes) -> int:
        return (base + sum(payload)) & 0xFF  # the last byte is zero here

    return checksum


def honda(frame_id: int, length: int) -> Checksum:
    """Honda's 4-bit nibble-sum checksum of a message (low nibble of the last byte)."""
    base = 0
    addr = frame_id
    while addr:
        base += addr & 0xF
        addr >>= 4
    extra = 3 if frame_id > 0x7FF else 0

    def checksum(payload: bytes) -> int:
        s = base + sum((b & 0xF) + (b >> 4) for b in payload)  # checksum nibble is zero
        return (8 - s + extra) & 0xF

    return checksum


def pacc_crc8(frame_id: int, length: int, crc_byte: int) -> Checksum:
    """pacc's E2E CRC-8 (reference form; the codec unrolls the same computation)."""
    data_id = frame_id & 0xFFFF

    def checksum(payload: bytes) -> int:
        return e2e_crc(data_id, payload, crc_byte)

    return checksum


def autosar_p01(frame_id: int, length: int, crc_byte: int) -> Checksum:
    """AUTOSAR E2E profile 1 CRC (data id mode BOTH, data id = frame id), reference form."""
    data_id = frame_id & 0xFFFF
    start = crc8_update(0x00, bytes((data_id & 0xFF, data_id >> 8)))

    def checksum(payload: bytes) -> int:
        return crc8_update(crc8_update(start, payload[:crc_byte]), payload[crc_byte + 1 :])

    return checksum


def make(kind: str, frame_id: int, length: int, byte: int) -> Checksum | None:
    """The checksum function of ``kind`` for one message (None for ``none``); ``byte`` is the
    index of the byte holding the checksum.

    Raises:
        ValueError: unknown kind.
    """
    if kind == "toyota":
        return toyota(frame_id, length)
    if kind == "honda":
        return honda(frame_id, length)
    if kind == "pacc_crc8":
        return pacc_crc8(frame_id, length, byte)
    if kind == "autosar_p01":
        return autosar_p01(frame_id, length, byte)
    if kind == "none":
        return None
    raise DbcError(f"unknown checksum {kind!r} (one of {', '.join(KINDS)})")


__all__ = [
    "COUNTER_MODULO",
    "KINDS",
    "TABLE_CRCS",
    "Checksum",
    "autosar_p01",
    "honda",
    "make",
    "pacc_crc8",
    "toyota",
]
