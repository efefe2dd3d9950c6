"""The compiled codec: round trips, agreement with cantools, E2E detection, malformed input."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import cantools
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dbc import BINDING_PATH, DBC_PATH
from dbc.checksums import table_crc
from dbc.codec import load_codec
from dbc.endpoint import Outbox
from dbc.errors import (
    CodecError,
    CrcError,
    DbcError,
    DecodeError,
    DlcError,
    EncodeError,
    RangeError,
)
from dbc.message import MessageCodec

CODEC = load_codec()
ROLES = sorted(CODEC.by_role)
#: cantools, the independent reader (Any: its load_file returns a union of database kinds)
DB: Any = cantools.database.load_file(str(DBC_PATH), strict=True)


@st.composite
def frames(draw: st.DrawFn, role: str | None = None) -> tuple[MessageCodec, dict[str, Any], int]:
    """A message codec, physical values on its raw grid (boundaries included), a counter."""
    mc = CODEC.by_role[draw(st.sampled_from(ROLES)) if role is None else role]
    values: dict[str, Any] = {}
    for f in mc.layouts:
        raw = draw(
            st.one_of(st.sampled_from([f.raw_min, f.raw_max]), st.integers(f.raw_min, f.raw_max))
        )
        values[f.key] = raw * f.scale + f.offset if not f.integral else raw
    return mc, values, draw(st.integers(0, 15))


@given(frames())
def test_round_trip_every_message(frame: tuple[MessageCodec, dict[str, Any], int]) -> None:
    mc, values, counter = frame
    data = mc.encode(values, counter)
    assert len(data) == mc.length
    decoded = CODEC.by_id[mc.frame_id].decode(data)
    assert decoded.role == mc.role
    assert decoded.counter == counter
    assert decoded.values.keys() == values.keys()
    for key, value in values.items():
        assert math.isclose(decoded.values[key], value, rel_tol=1e-12, abs_tol=1e-9), key


@given(frames())
def test_agrees_with_cantools(frame: tuple[MessageCodec, dict[str, Any], int]) -> None:
    """An independent implementation reads our frames the same way."""
    mc, values, counter = frame
    data = mc.encode(values, counter)
    theirs = DB.get_message_by_name(mc.name).decode(data, decode_choices=False)
    part = CODEC.binding.roles[mc.role].parts[0]
    assert part.counter is not None
    assert theirs[part.counter] == counter
    for key, fb in part.fields.items():
        assert math.isclose(theirs[fb.signal], values[key], rel_tol=1e-9, abs_tol=1e-9), key


@settings(max_examples=50)
@given(frames())
def test_every_single_bit_flip_is_detected(frame: tuple[MessageCodec, dict[str, Any], int]) -> None:
    mc, values, counter = frame
    data = mc.encode(values, counter)
    for bit in range(8 * len(data)):
        flipped = bytearray(data)
        flipped[bit // 8] ^= 1 << (bit % 8)
        with pytest.raises(CrcError):
            mc.decode(bytes(flipped))


def test_frame_under_another_id_fails_crc() -> None:
    ego = CODEC.by_role["ego"].encode({"speed_mps": 10, "accel_mps2": 0, "speed_valid": 1}, 0)
    with pytest.raises(CrcError):
        CODEC.by_id[CODEC.by_role["pedals"].frame_id].decode(ego)


def test_physical_rounding_to_resolution() -> None:
    mc = CODEC.by_role["ego"]
    out = mc.decode(mc.encode({"speed_mps": 12.3449, "accel_mps2": -0.004, "speed_valid": 1}, 0))
    assert out.values["speed_mps"] == pytest.approx(12.34)
    assert out.values["accel_mps2"] == 0


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"speed_mps": 90.5, "accel_mps2": 0.0, "speed_valid": 1}, "speed_mps=90.5 outside"),
        ({"speed_mps": -1.0, "accel_mps2": 0.0, "speed_valid": 1}, "speed_mps=-1.0 outside"),
        ({"speed_mps": float("nan"), "accel_mps2": 0.0, "speed_valid": 1}, "not a finite"),
        ({"speed_mps": float("inf"), "accel_mps2": 0.0, "speed_valid": 1}, "not a finite"),
        ({"speed_mps": "fast", "accel_mps2": 0.0, "speed_valid": 1}, "not a finite"),
        ({"accel_mps2": 0.0, "speed_valid": 1}, "missing field 'speed_mps'"),
    ],
)
def test_encode_refuses_bad_values(values: dict[str, Any], message: str) -> None:
    with pytest.raises(EncodeError, match=message):
        CODEC.by_role["ego"].encode(values, 0)


def test_encode_unknown_role() -> None:
    with pytest.raises(EncodeError, match="no role"):
        Outbox(CODEC).encode("wipers", {})


def _with_crc(mc: MessageCodec, payload: bytearray) -> bytes:
    assert mc.crc_byte is not None
    payload[mc.crc_byte] = table_crc(mc.checksum, mc.frame_id, mc.crc_byte)(bytes(payload))
    return bytes(payload)


def test_decode_out_of_range_is_typed() -> None:
    mc = CODEC.by_role["ego"]
    raw = bytearray(8)
    raw[2:4] = (9001).to_bytes(2, "little")  # 90.01 m/s > DBC maximum 90
    with pytest.raises(RangeError, match="speed_mps=90.01"):
        mc.decode(_with_crc(mc, raw))
    gap = CODEC.by_role["hmi"]
    with pytest.raises(RangeError, match="gap_setting=0"):  # GapSetting is 1..3
        gap.decode(_with_crc(gap, bytearray(8)))


@given(st.sampled_from(sorted(CODEC.by_id)), st.binary(max_size=16))
def test_garbage_never_escapes_the_exception_root(frame_id: int, data: bytes) -> None:
    try:
        decoded = CODEC.by_id[frame_id].decode(data)
    except DecodeError:
        return
    # a random frame can pass only with a matching CRC (1 in 256): then it must be sane
    mc = CODEC.by_id[frame_id]
    assert decoded.role == mc.role and len(data) == mc.length


def test_malformed_kinds() -> None:
    mc = CODEC.by_role["radar"]
    good = mc.encode(
        {
            "lead_valid": 1,
            "gap_m": 20,
            "rel_speed_mps": 0,
            "lead_accel_mps2": 0,
            "lead_accel_valid": 0,
        },
        1,
    )
    with pytest.raises(DlcError, match="DLC 7, expected 8"):
        CODEC.by_id[mc.frame_id].decode(good[:7])
    with pytest.raises(DlcError):
        CODEC.by_id[mc.frame_id].decode(good + b"\0")
    assert issubclass(DecodeError, CodecError) and issubclass(DbcError, CodecError)


def test_load_is_cached() -> None:
    assert load_codec() is CODEC
    assert load_codec(DBC_PATH, BINDING_PATH) is CODEC


def test_missing_dbc(tmp_path: Path) -> None:
    with pytest.raises(DbcError, match="not found"):
        load_codec(tmp_path / "nope.dbc")


def test_wrong_dbc_is_refused(tmp_path: Path) -> None:
    bad = tmp_path / "bad.dbc"
    bad.write_text(
        DBC_PATH.read_text().replace("BO_ 176 ESC_Speed: 8 ESC", "BO_ 176 ESC_Speed: 8 ESC garbage")
    )
    with pytest.raises(DbcError, match="cannot load DBC"):
        load_codec(bad)


def test_dbc_without_cycle_time_refused_at_load(tmp_path: Path) -> None:
    """Receivers time out by the DBC period: a bound message without GenMsgCycleTime is a
    wrong DBC for this network, refused when the codec is loaded (a DbcError)."""
    bad = tmp_path / "nocycle.dbc"
    bad.write_text(DBC_PATH.read_text().replace('BA_ "GenMsgCycleTime" BO_ 288 50;\n', ""))
    with pytest.raises(DbcError, match="RADAR_Lead.*GenMsgCycleTime"):
        load_codec(bad)


def test_overlapping_signals_refused_strictly(tmp_path: Path) -> None:
    bad = tmp_path / "overlap.dbc"
    bad.write_text(
        DBC_PATH.read_text().replace("SG_ LongAccel : 32|16@1-", "SG_ LongAccel : 24|16@1-")
    )
    with pytest.raises(DbcError):
        load_codec(bad)


def test_other_vehicle_dbc_with_renamed_message_needs_matching_binding(tmp_path: Path) -> None:
    renamed = tmp_path / "other.dbc"
    renamed.write_text(DBC_PATH.read_text().replace("ESC_Speed", "VehSpd"))
    with pytest.raises(DbcError, match="no message 'ESC_Speed'"):
        load_codec(renamed)
    binding = tmp_path / "other.binding.toml"
    binding.write_text(BINDING_PATH.read_text().replace('"ESC_Speed"', '"VehSpd"'))
    other = load_codec(renamed, binding)
    assert other.by_role["ego"].name == "VehSpd"
    data = other.by_role["ego"].encode({"speed_mps": 5, "accel_mps2": 1, "speed_valid": 1}, 0)
    assert other.by_role["ego"].decode(data).values["speed_mps"] == 5


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda s: s.replace('crc = "CRC8"\n', "", 1), "CRC8.*unbound"),
        (lambda s: s.replace('counter = "AliveCounter"\n', "", 1), "both crc and counter"),
        (lambda s: s.replace('speed_valid = "SpeedValid"', 'speed_valid = "Nope"'), "no signal"),
        (lambda s: s.replace(', speed_valid = "SpeedValid"', ""), "unbound"),
        (lambda s: s.replace("[roles.status]", "[roles.statusx]"), "unknown role"),
        (lambda s: s.replace("[roles.radar]", "[roles.status2]"), "unknown role"),
        (lambda s: s.replace('gap_m = "LeadDistance", ', ""), "required fields"),
        (lambda s: s.replace("speed_valid = ", "speed_ok = "), "unknown fields"),
        (lambda s: s + "\n[[[", "not valid TOML"),
    ],
)
def test_bad_binding_is_refused(tmp_path: Path, edit, message: str) -> None:  # type: ignore[no-untyped-def]
    binding = tmp_path / "b.toml"
    binding.write_text(edit(BINDING_PATH.read_text()))
    with pytest.raises(DbcError, match=message):
        load_codec(DBC_PATH, binding)


def test_motorola_signals(tmp_path: Path) -> None:
    """A big-endian (Motorola) layout, as many OEM DBCs use, decodes like cantools."""
    text = (
        DBC_PATH.read_text()
        .replace("SG_ VehicleSpeed : 16|16@1+", "SG_ VehicleSpeed : 23|16@0+")
        .replace("SG_ LongAccel : 32|16@1-", "SG_ LongAccel : 39|16@0-")
    )
    path = tmp_path / "moto.dbc"
    path.write_text(text)
    codec = load_codec(path)
    db: Any = cantools.database.load_file(str(path), strict=True)
    values = {"speed_mps": 27.81, "accel_mps2": -3.33, "speed_valid": 1}
    data = codec.by_role["ego"].encode(values, 9)
    theirs = db.get_message_by_name("ESC_Speed").decode(data, decode_choices=False)
    assert theirs["VehicleSpeed"] == pytest.approx(27.81)
    assert theirs["LongAccel"] == pytest.approx(-3.33)
    assert codec.by_id[0xB0].decode(data).values["accel_mps2"] == pytest.approx(-3.33)
