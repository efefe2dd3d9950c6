"""Trip logs: MCAP round trip, refusal of corrupt / truncated / foreign files, CSV reading."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from mcap.writer import Writer

from cloud_sync.irl.sources.tripfiles import load_trip, read_csv_trip
from dbc.vocab.triplog import Trip, TripLogError
from dbc.vocab.triplog_file import SAMPLE_TOPIC, read_trip, write_trip

# ../shared beside the repository (as on the development machines and in CI)
DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "openacc_astazero"


def make_trip(n: int = 50, seed: int = 0) -> Trip:
    rng = np.random.default_rng(seed)
    v = 20.0 + rng.normal(0, 1, n)
    gap = 30.0 + rng.normal(0, 2, n)
    if n > 3:
        gap[3] = np.nan
    return Trip(
        t_s=np.arange(n) * 0.1,
        v_mps=v,
        gap_m=gap,
        v_lead_mps=v + rng.normal(0, 0.5, n),
        a_mps2=rng.normal(0, 0.3, n),
        accel_pedal=rng.uniform(0, 1, n),
        brake_pedal=np.zeros(n),
        acc_state=rng.integers(0, 5, n),
        meta={"driver_id": "d1", "condition": "dry", "mode": "acc", "seed": seed},
    )


def test_round_trip_preserves_every_sample_and_meta(tmp_path: Path) -> None:
    trip = make_trip(200)
    path = tmp_path / "run.mcap"
    write_trip(path, trip)
    back = read_trip(path)
    assert back == trip
    assert np.isnan(back.gap_m[3])
    assert back.acc_state.dtype == np.int64
    assert back.meta["driver_id"] == "d1"


@settings(max_examples=15, deadline=None)
@given(n=st.integers(0, 40), seed=st.integers(0, 2**16))
def test_round_trip_property(tmp_path_factory: pytest.TempPathFactory, n: int, seed: int) -> None:
    trip = make_trip(n, seed)
    path = tmp_path_factory.mktemp("rt") / "t.mcap"
    write_trip(path, trip)
    assert read_trip(path) == trip


def test_truncated_file_refused_with_clear_message(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    write_trip(path, make_trip(300))
    raw = path.read_bytes()
    for cut in (len(raw) // 2, len(raw) - 9, 20):
        bad = tmp_path / f"cut{cut}.mcap"
        bad.write_bytes(raw[:cut])
        with pytest.raises(TripLogError, match="truncated"):
            read_trip(bad)


def test_corrupt_file_refused(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    write_trip(path, make_trip(300))
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 3] ^= 0xFF
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(raw))
    with pytest.raises(TripLogError, match="bad.mcap"):
        read_trip(bad)
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"this is not an mcap file at all")
    with pytest.raises(TripLogError, match="corrupt or not MCAP"):
        read_trip(junk)
    with pytest.raises(TripLogError, match="no such"):
        read_trip(tmp_path / "missing.mcap")


def test_foreign_mcap_refused(tmp_path: Path) -> None:
    path = tmp_path / "other.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start()
        sid = w.register_schema("x", "jsonschema", b"{}")
        cid = w.register_channel("/other", "json", sid)
        w.add_message(cid, 0, json.dumps({"a": 1}).encode(), 0)
        w.finish()  # type: ignore[no-untyped-call]
    with pytest.raises(TripLogError, match=f"no {SAMPLE_TOPIC} channel"):
        read_trip(path)


def test_failed_write_leaves_no_file(tmp_path: Path) -> None:
    target = tmp_path / "run.mcap"
    target.mkdir()  # a folder in the way: the final rename fails
    with pytest.raises(OSError):
        write_trip(target, make_trip(20))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]  # no run.mcap.part
    assert target.is_dir() and not any(target.iterdir())
    with pytest.raises(OSError):
        write_trip(tmp_path / "missing" / "run.mcap", make_trip(20))


def test_trip_validation() -> None:
    good = make_trip(10)
    with pytest.raises(TripLogError, match="differ in length"):
        Trip(**{**good.__dict__, "v_mps": np.zeros(9)})
    with pytest.raises(TripLogError, match="strictly increasing"):
        Trip(**{**good.__dict__, "t_s": np.zeros(10)})
    with pytest.raises(TripLogError, match="accel_pedal outside"):
        Trip(**{**good.__dict__, "accel_pedal": np.full(10, 2.0)})
    with pytest.raises(TripLogError, match="acc_state outside"):
        Trip(**{**good.__dict__, "acc_state": np.full(10, 7)})
    with pytest.raises(TripLogError, match="1-D"):
        Trip(**{**good.__dict__, "gap_m": np.zeros((10, 2))})
    assert good.v_mps.flags.writeable is False


def test_csv_reader_on_real_pair() -> None:
    files = sorted(DATA.glob("oa_pair_*.csv"))
    if not files:
        pytest.skip("shared data not present")
    trip = read_csv_trip(files[0], driver_id="h1")
    assert len(trip) > 10_000
    assert trip.meta["driver_id"] == "h1" and trip.meta["mode"] == "manual"
    assert np.allclose(np.diff(trip.t_s), 0.1, atol=1e-6)
    assert 5.0 < np.nanmean(trip.v_mps) < 30.0
    assert np.all(trip.acc_state == 0) and np.all(np.isnan(trip.accel_pedal))
    assert load_trip(files[0]).meta["driver_id"] == files[0].stem


def test_csv_reader_refuses_bad_files(tmp_path: Path) -> None:
    p = tmp_path / "a.csv"
    p.write_text("t,v_follower,spacing\n0,1,2\n")
    with pytest.raises(TripLogError, match="lacks column.*v_leader"):
        read_csv_trip(p)
    p.write_text("t,v_follower,spacing,v_leader\n0,1,2,x\n")
    with pytest.raises(TripLogError, match="non-numeric"):
        read_csv_trip(p)
    p.write_text("")
    with pytest.raises(TripLogError, match="empty"):
        read_csv_trip(p)
    p.write_bytes(b"\xff\xfe\xfa\x00,\n")  # not text
    with pytest.raises(TripLogError, match="a.csv: cannot read CSV"):
        read_csv_trip(p)
    p.write_text("t,v_follower,spacing,v_leader\n0,1,2,3\n0.1,1,2\n")  # a short row
    with pytest.raises(TripLogError, match="ragged"):
        read_csv_trip(p)
    q = tmp_path / "a.txt"
    q.write_text("x")
    with pytest.raises(TripLogError, match="unknown trip file type"):
        load_trip(q)


def test_csv_small_file_derives_acceleration(tmp_path: Path) -> None:
    p = tmp_path / "b.csv"
    p.write_text("t,v_follower,spacing,v_leader\n0,10,20,10\n0.1,10.1,20,10\n0.2,10.2,20,10\n")
    trip = read_csv_trip(p)
    assert np.allclose(trip.a_mps2, 1.0)
