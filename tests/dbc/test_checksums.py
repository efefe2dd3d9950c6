"""The pluggable checksums against opendbc's own functions (an independent implementation)."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

import cantools
import numpy as np
import pytest
from e2e import p01

from dbc import checksums
from dbc.binding import FieldBinding, PartBinding
from dbc.e2e import crc8_update
from dbc.errors import DbcError
from dbc.message import MessageCodec

#: opendbc's wheel exists for Python < 3.13 only (the dev dependency's marker): the tests
#: against it are skipped there, and fail (not skip) where it should be but is missing
needs_opendbc = pytest.mark.skipif(
    sys.version_info >= (3, 13), reason="opendbc's wheel supports Python < 3.13"
)
if sys.version_info < (3, 13):
    from opendbc.car.honda.hondacan import honda_checksum
    from opendbc.car.toyota.toyotacan import toyota_checksum

RNG = np.random.default_rng(3)
IDS = [0x0B4, 0x1D2, 0x2E6, 0x343, 0x7FF, 0x18DAF110, 0x1FFFFFFF]


@needs_opendbc
@pytest.mark.parametrize("frame_id", IDS)
@pytest.mark.parametrize("length", [1, 5, 8])
def test_toyota_matches_opendbc(frame_id: int, length: int) -> None:
    fn = checksums.toyota(frame_id, length)
    for _ in range(200):
        payload = bytearray(RNG.integers(0, 256, length, dtype=np.uint8).tobytes())
        zeroed = bytes(payload[:-1]) + b"\0"
        assert fn(zeroed) == toyota_checksum(frame_id, None, payload)


@needs_opendbc
@pytest.mark.parametrize("frame_id", IDS)
@pytest.mark.parametrize("length", [1, 4, 8])
def test_honda_matches_opendbc(frame_id: int, length: int) -> None:
    fn = checksums.honda(frame_id, length)
    for _ in range(200):
        payload = bytearray(RNG.integers(0, 256, length, dtype=np.uint8).tobytes())
        zeroed = bytes(payload[:-1]) + bytes([payload[-1] & 0xF0])
        assert fn(zeroed) == honda_checksum(frame_id, None, payload)


def test_make_dispatches_by_name() -> None:
    payload = bytes([1, 2, 3, 0])
    assert checksums.make("none", 0x100, 4, 3) is None
    toyota = checksums.make("toyota", 0x100, 4, 3)
    assert toyota is not None and toyota(payload) == (1 + 2 + 3 + 0x01 + 0x00 + 4) & 0xFF
    crc = checksums.make("pacc_crc8", 0x100, 4, 3)
    assert crc is not None and crc(payload) == crc8_update(0xFF, b"\x00\x01" + payload[:3]) ^ 0xFF
    with pytest.raises(DbcError, match="unknown checksum"):
        checksums.make("crc32", 0x100, 4, 3)


def test_autosar_p01_matches_autosar_e2e() -> None:
    """pacc's AUTOSAR E2E profile 1 CRC against the autosar-e2e package's (data id mode
    BOTH, CRC in byte 0)."""
    for _ in range(500):
        length = int(RNG.integers(2, 9))
        data = bytearray(RNG.integers(0, 256, length, dtype=np.uint8).tobytes())
        data_id = int(RNG.integers(0, 0x10000))
        p01.e2e_p01_protect(data, data_id, increment_counter=False)
        fn = checksums.table_crc("autosar_p01", data_id, 0)
        assert fn(bytes(data)) == data[0]


@needs_opendbc
def test_honda_message_with_its_2_bit_counter_matches_opendbcs_packer(tmp_path: Path) -> None:
    """A Honda message (opendbc's Civic ENGINE_DATA: kph speed, a 2-bit COUNTER, the 4-bit
    checksum) bound with ``checksum = "honda"``: our frames are byte for byte the ones
    opendbc's CANPacker makes, counters wrapping at 4."""
    from opendbc import get_generated_dbcs  # noqa: PLC0415 - present: needs_opendbc
    from opendbc.can.packer import CANPacker  # noqa: PLC0415

    text = get_generated_dbcs()["honda_civic_touring_2016_can_generated"]
    # cantools cannot parse opendbc's signal comments without a signal name: drop them
    path = tmp_path / "honda_civic_touring_2016_can_generated.dbc"
    path.write_text(re.sub(r'^CM_ SG_ \d+ ".*\n', "", text, flags=re.MULTILINE))
    db: Any = cantools.database.load_file(str(path), strict=False)
    part = PartBinding(
        message="ENGINE_DATA",
        fields={"speed_mps": FieldBinding("speed_mps", "XMISSION_SPEED")},
        checksum="honda",
        checksum_signal="CHECKSUM",
        counter="COUNTER",
        unused=("ENGINE_RPM", "XMISSION_SPEED2", "ODOMETER"),
        cycle_ms=10,
    )
    mc = MessageCodec(db.get_message_by_name("ENGINE_DATA"), part, "ego")
    assert mc.counter_modulo == 4
    packer = CANPacker(str(path))
    for k in range(10):
        kph = 3.6 * 0.5 * k
        ours = mc.encode({"speed_mps": kph / 3.6}, k % mc.counter_modulo)  # the Outbox's count
        theirs = bytes(packer.pack(0x158, {"XMISSION_SPEED": kph}))
        assert ours == theirs, k
        assert mc.decode(theirs).values["speed_mps"] == pytest.approx(kph / 3.6)
        assert mc.decode(theirs).counter == k % 4
