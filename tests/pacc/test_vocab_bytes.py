"""Trip logs and DGPT files on bytes; the path functions are thin wrappers."""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pytest

from cloud_sync.service.rules import CloudService, DeferredExecutor
from dbc.vocab.dgpt import DgptError, predefined
from dbc.vocab.dgpt_file import dgpt_from_bytes, dgpt_to_bytes, load_dgpt, save_dgpt
from dbc.vocab.triplog import Trip, TripLogError
from dbc.vocab.triplog_file import read_trip, trip_from_bytes, trip_to_bytes, write_trip


def a_trip() -> Trip:
    n = 30
    t = np.arange(n) * 0.1
    return Trip.manual(
        t, np.full(n, 15.0), 30.0 + t, np.full(n, 16.0), np.zeros(n), {"driver_id": "d1"}
    )


def test_a_trip_round_trips_through_bytes_as_through_a_file(tmp_path: Path) -> None:
    trip = a_trip()
    data = trip_to_bytes(trip)
    write_trip(tmp_path / "t.mcap", trip)
    assert (tmp_path / "t.mcap").read_bytes() == data  # the path is only a wrapper
    assert trip_from_bytes(data) == trip == read_trip(tmp_path / "t.mcap")


def test_damaged_trip_bytes_are_refused_naming_where_they_came_from() -> None:
    data = trip_to_bytes(a_trip())
    with pytest.raises(TripLogError, match="^upload 7: truncated trip log"):
        trip_from_bytes(data[: len(data) // 2], "upload 7")
    with pytest.raises(TripLogError, match="^trip log bytes: corrupt or not MCAP"):
        trip_from_bytes(b"not an mcap file at all")


def test_a_table_round_trips_through_bytes_as_through_a_file(tmp_path: Path) -> None:
    table = predefined(1.5, created_utc="2026-01-01T00:00:00Z")
    data = dgpt_to_bytes(table)
    save_dgpt(table, tmp_path / "t.json")
    assert (tmp_path / "t.json").read_bytes() == data
    assert dgpt_from_bytes(data).to_json_dict() == table.to_json_dict()
    assert load_dgpt(tmp_path / "t.json").to_json_dict() == table.to_json_dict()


def test_bad_table_bytes_name_the_defect_and_the_file_wrapper_adds_the_name(
    tmp_path: Path,
) -> None:
    with pytest.raises(DgptError, match="^not valid JSON"):
        dgpt_from_bytes(b"{")
    with pytest.raises(DgptError, match="^invalid DGPT: format tag"):
        dgpt_from_bytes(b'{"format": "x"}')
    (tmp_path / "bad.json").write_bytes(b"{")
    with pytest.raises(DgptError, match=r"bad\.json: not valid JSON"):
        load_dgpt(tmp_path / "bad.json")


def test_the_cloud_parses_an_upload_without_a_temporary_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # a temporary folder that does not exist: a temporary file would fail the upload
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path / "no-such-folder"))
    cloud = CloudService.open(tmp_path / "cloud", executor=DeferredExecutor())
    cloud.register_vehicle("car")
    cloud.register_driver("car", "d1")
    assert cloud.upload("car", trip_to_bytes(a_trip())).kind == "manual"
