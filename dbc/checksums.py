"""Per-message checksums, pluggable by name in the binding (``checksum = "toyota"``).

Each kind is a pure function of the frame id, the length and the payload with its checksum
bits zero: ``pacc_crc8`` (CRC-8 SAE J1850 over the 16-bit data id and the payload,
:mod:`dbc.e2e`); ``autosar_p01`` (AUTOSAR E2E profile 1, data id mode BOTH: CRC-8 poly 0x1D,
start 0, no final XOR, counter 0..14; checked against the ``autosar-e2e`` package);
``toyota`` (byte sum of payload, frame id and length mod 256, in the last byte); ``honda`` (8
minus the nibble sum of frame id and payload, +3 for an extended id, mod 16, in the last
byte's low nibble; both as opendbc's toyotacan.py/hondacan.py describe them, MIT licence,
written here from that description); ``none``. The codec unrolls the table CRCs inline.
"""

from __future__ import annotations

from collections.abc import Callable

from dbc.e2e import crc8_update
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
    base = length + sum(frame_id.to_bytes(4, "little"))

    def checksum(payload: bytes) -> int:
        return (base + sum(payload)) & 0xFF  # the last byte is zero here

    return checksum


def honda(frame_id: int, length: int) -> Checksum:
    """Honda's 4-bit nibble-sum checksum of a message (low nibble of the last byte)."""
    base = sum((frame_id >> s) & 0xF for s in range(0, 32, 4))
    extra = 3 if frame_id > 0x7FF else 0

    def checksum(payload: bytes) -> int:
        s = base + sum((b & 0xF) + (b >> 4) for b in payload)  # checksum nibble is zero
        return (8 - s + extra) & 0xF

    return checksum


def table_crc(kind: str, frame_id: int, crc_byte: int) -> Checksum:
    """A table CRC-8 kind (:data:`TABLE_CRCS`) over the data id (the frame id's low 16 bits,
    low byte first) and every payload byte but ``crc_byte``."""
    init, xorout = TABLE_CRCS[kind]
    data_id = frame_id & 0xFFFF
    start = crc8_update(init, bytes((data_id & 0xFF, data_id >> 8)))

    def checksum(payload: bytes) -> int:
        crc = crc8_update(crc8_update(start, payload[:crc_byte]), payload[crc_byte + 1 :])
        return crc ^ xorout

    return checksum


def make(kind: str, frame_id: int, length: int, byte: int) -> Checksum | None:
    """The checksum function of ``kind`` for one message (None for ``none``; DbcError for an
    unknown kind); ``byte``: the index of the byte holding the checksum."""
    if kind in TABLE_CRCS:
        return table_crc(kind, frame_id, byte)
    if kind in ("toyota", "honda"):
        return (toyota if kind == "toyota" else honda)(frame_id, length)
    if kind == "none":
        return None
    raise DbcError(f"unknown checksum {kind!r} (one of {', '.join(KINDS)})")
