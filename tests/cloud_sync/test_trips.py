"""Trip reports and the per-trip learning curve: the cloud computes each trip's PoI and
takeovers per minute from the takeover segments it received, over real HTTP on 127.0.0.1;
an index of the older schema is migrated without loss."""

from __future__ import annotations

import csv
import hashlib
import sqlite3
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import httpx
import pytest

from cloud_sync.api import BadBatchError, ForbiddenError
from cloud_sync.service.http import TRIP_REPORT_LIMIT
from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService, DeferredExecutor, ServiceConfig
from cloud_sync.service.store import SCHEMA_VERSION, CloudStore, StoreError
from cloud_sync.service.trips import segment_interventions
from cloud_sync.signing import load_public_key, verify_dgpt
from cloud_sync.vehicle.client import HttpCloud
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import write_trip
from tests.ecu.test_cli_cloud import cloud_table

from .conftest import follower_trip, takeover_segment
from .served import OPERATOR, Served

#: three trips: (presses of each segment, the trip's ACC-on seconds); trip 2 had no takeover
TRIPS: list[tuple[list[list[tuple[int, int, str]]], float]] = [
    ([[(50, 80, "accel")], [(40, 52, "brake"), (120, 130, "accel")]], 240.0),
    ([], 300.0),
    ([[(60, 75, "accel")]], 180.0),
]


def _bytes(trip: Trip, tmp: Path) -> bytes:
    path = tmp / "t.mcap"
    write_trip(path, trip)
    return path.read_bytes()


def test_a_segments_interventions_follow_the_study_definitions() -> None:
    seg = takeover_segment(3, [(10, 25, "accel"), (25, 30, "brake"), (90, 91, "accel")])
    seconds, takeovers = segment_interventions(seg)
    assert seconds == pytest.approx(2.1)  # 15 + 5 + 1 samples of 0.1 s
    assert takeovers == 3  # accel, then the other pedal, then accel again
    # a pedal pressed before the ACC was ever engaged is no intervention
    quiet = takeover_segment(3, [(0, 10, "brake")])
    assert segment_interventions(quiet) == (0.0, 0)


@pytest.fixture(scope="module")
def served(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Served, CloudService]]:
    """The service over HTTP: car-a with driver syn (a learned table), car-b with other."""
    tmp = tmp_path_factory.mktemp("trips")
    pool = ThreadPoolExecutor(max_workers=1)
    service = CloudService.open(tmp / "cloud", executor=pool)
    service.register_vehicle("car-b")
    service.register_driver("car-b", "other")
    s = Served(service)
    yield s, service
    s.stop()
    pool.shutdown(wait=True)
    service.store.close()


def _drive_trips(api: HttpCloud, service: CloudService, tmp: Path) -> list[dict[str, Any]]:
    """Upload each trip's segments, report it with the version the vehicle drove with, and
    download the next version, as the incremental study does; what was sent, per trip."""
    sent = []
    for k, (segments, acc_on_s) in enumerate(TRIPS):
        version = int(_newest(api)["version"])
        digests = [
            api.upload(_bytes(takeover_segment(10 * k + j, presses), tmp)).digest
            for j, presses in enumerate(segments)
        ]
        presses = [p for seg in segments for p in seg]
        report = {
            "driver_id": "syn",
            "trip_id": f"trip-{k + 1}",
            "dgpt_version": version,
            "acc_on_s": acc_on_s,
            "segments": digests,
            "start_utc": f"2026-11-24T10:0{k}:00Z",
        }
        assert not api.report_trip(report).duplicate
        sent.append({**report, "inter_s": 0.1 * sum(e - f for f, e, _ in presses)})
        sent[-1]["takeovers"] = len(presses)
        service.wait_idle(120.0)  # the fine-tune of these takeovers: the next trip's table
    return sent


def _newest(api: HttpCloud) -> dict[str, Any]:
    """The newest table the vehicle downloads, verified with the cloud's key."""
    table = verify_dgpt(api.latest_dgpt("syn"), load_public_key(api.public_key_pem()))
    return {"version": table.version}


def test_the_per_trip_curve_over_http_holds_what_the_trips_contain(
    served: tuple[Served, CloudService], tmp_path: Path
) -> None:
    s, service = served
    token = service.register_vehicle("car-a")
    service.register_driver("car-a", "syn")
    with HttpCloud(s.url, token) as api:
        api.upload(_bytes(follower_trip(0, minutes=2.0), tmp_path))
        service.wait_idle(120.0)
        sent = _drive_trips(api, service, tmp_path)
        points = s.get("/v1/drivers/syn/trips", token).json()
        assert [p["trip_id"] for p in points] == ["trip-1", "trip-2", "trip-3"]
        assert [p["index"] for p in points] == [1, 2, 3]
        for p, want in zip(points, sent, strict=True):
            assert p["dgpt_version"] == want["dgpt_version"]
            assert p["segments"] == want["segments"]
            assert p["start_utc"] == want["start_utc"]
            assert p["takeovers"] == want["takeovers"]
            assert p["intervention_s"] == pytest.approx(want["inter_s"])
            assert p["poi_pct"] == pytest.approx(100.0 * want["inter_s"] / want["acc_on_s"])
            per_min = want["takeovers"] / (want["acc_on_s"] / 60.0)
            assert p["takeovers_per_min"] == pytest.approx(per_min)
        assert points[1]["poi_pct"] == 0.0 and points[1]["takeovers"] == 0
        versions = [p["dgpt_version"] for p in points]
        assert versions == sorted(versions) and versions[-1] > versions[0]  # fine-tuned
        # the token rules: the operator sees the same, another vehicle and no token do not
        assert s.get("/v1/drivers/syn/trips", OPERATOR).json() == points
        assert s.get("/v1/drivers/syn/trips", "nope").status_code == 401
        assert s.get("/v1/drivers/syn/trips", None).status_code == 401
        b_token = service.register_vehicle("car-c")
        assert s.get("/v1/drivers/syn/trips", b_token).status_code == 403
        assert s.get("/v1/drivers/ghost/trips", OPERATOR).status_code == 404
        _refusals(api, s, token, sent)


def _refusals(api: HttpCloud, s: Served, token: str, sent: list[dict[str, Any]]) -> None:
    """Bad reports are refused with a clean 4xx and nothing stored."""
    first = {k: v for k, v in sent[0].items() if k not in ("inter_s", "takeovers")}
    assert api.report_trip(first).duplicate  # the same report again
    bad: list[dict[str, Any]] = [
        {**first, "acc_on_s": 250.0},  # a taken trip id with another content
        {**first, "trip_id": "x1"},  # its segments belong to trip-1
        {**first, "trip_id": "x2", "segments": ["ab" * 32]},  # never uploaded
        {**first, "trip_id": "x3", "segments": [], "dgpt_version": 99},  # unpublished
        {**first, "trip_id": "x4", "segments": sent[2]["segments"][:0] + ["zz"]},
        {**first, "trip_id": "x5", "acc_on_s": 1e9},
        {**first, "trip_id": "x6", "acc_on_s": -1},
        {**first, "trip_id": "../x7"},
        {**first, "trip_id": "x8", "extra": 1},
    ]
    for report in bad:
        with pytest.raises(BadBatchError):
            api.report_trip(report)
    with pytest.raises(ForbiddenError):
        api.report_trip({**first, "driver_id": "other", "trip_id": "x9"})
    answer = httpx.post(
        s.url + "/v1/trips",
        content=b"{not json",
        headers={"Authorization": f"Bearer {token}"},
        timeout=30.0,
    )
    assert answer.status_code == 422 and "JSON" in answer.json()["detail"]
    assert httpx.post(s.url + "/v1/trips", json=first, timeout=30.0).status_code == 401
    huge = httpx.post(
        s.url + "/v1/trips",
        content=b" " * (TRIP_REPORT_LIMIT + 1),
        headers={"Authorization": f"Bearer {token}"},
        timeout=30.0,
    )
    assert huge.status_code == 413
    assert len(s.get("/v1/drivers/syn/trips", token).json()) == 3


def test_acc_time_shorter_than_the_segments_interventions_is_refused(tmp_path: Path) -> None:
    service = CloudService.open(tmp_path / "cloud", DeferredExecutor())  # learns when asked
    token = service.register_vehicle("car")
    service.register_driver("car", "syn")
    api = LocalCloud(service, token)
    service.publish(cloud_table(2.5, version=1), [])  # the table the trip drove with
    digest = api.upload(_bytes(takeover_segment(1, [(10, 110, "accel")]), tmp_path)).digest
    report = {"driver_id": "syn", "trip_id": "t", "dgpt_version": 1, "segments": [digest]}
    with pytest.raises(BadBatchError, match="shorter"):
        api.report_trip({**report, "acc_on_s": 5.0})  # 10 s of override in the segment
    with pytest.raises(BadBatchError, match="outside"):
        api.report_trip({**report, "acc_on_s": float("nan")})
    manual = api.upload(_bytes(follower_trip(1, minutes=0.5), tmp_path)).digest
    with pytest.raises(BadBatchError, match="not a takeover"):
        api.report_trip({**report, "acc_on_s": 60.0, "segments": [manual]})
    assert not api.report_trip({**report, "acc_on_s": 10.0}).duplicate
    service.store.close()


def test_an_index_of_the_older_schema_is_migrated_without_loss(tmp_path: Path) -> None:
    """A store written before trip reports (no trips tables, user_version 0) opens with every
    vehicle, batch and version kept, and takes trip reports."""
    service = CloudService.open(tmp_path / "cloud", DeferredExecutor())  # learns when asked
    token = service.register_vehicle("car")
    service.register_driver("car", "syn")
    api = LocalCloud(service, token)
    manual = api.upload(_bytes(follower_trip(0, minutes=2.0), tmp_path)).digest
    service.publish(cloud_table(2.5, version=1), [manual])  # as if learned from it
    signed = api.latest_dgpt("syn")
    digest = api.upload(_bytes(takeover_segment(1, [(10, 20, "accel")]), tmp_path)).digest
    service.store.close()
    index = tmp_path / "cloud" / "index.sqlite"
    with sqlite3.connect(index) as db:  # back to the schema of version 1
        db.executescript("DROP TABLE trip_segments; DROP TABLE trips; PRAGMA user_version = 0;")
        before = {t: db.execute(f"SELECT * FROM {t}").fetchall() for t in _OLD_TABLES}  # noqa: S608
    db.close()
    assert all(before.values())
    store = CloudStore(tmp_path / "cloud")
    with sqlite3.connect(index) as db:
        after = {t: db.execute(f"SELECT * FROM {t}").fetchall() for t in _OLD_TABLES}  # noqa: S608
        assert db.execute("PRAGMA user_version").fetchone()[0] == SCHEMA_VERSION
    db.close()
    assert after == before
    store.close()
    service = CloudService.open(tmp_path / "cloud", DeferredExecutor())
    api = LocalCloud(service, token)
    assert service.store.read_version(service.store.versions("syn", "default")[0]) == signed
    assert hashlib.sha256(service.store.read_blob(digest)).hexdigest() == digest
    report = {"driver_id": "syn", "trip_id": "t1", "dgpt_version": 1, "acc_on_s": 60.0}
    assert not api.report_trip({**report, "segments": [digest]}).duplicate
    service.store.close()
    with sqlite3.connect(index) as db:  # a newer pacc's index is not ours to touch
        db.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    db.close()
    with pytest.raises(StoreError, match="newer"):
        CloudStore(tmp_path / "cloud")


_OLD_TABLES = ("vehicles", "drivers", "batches", "dgpt_versions")


@pytest.mark.slow
def test_an_incremental_study_against_a_served_cloud_draws_its_per_trip_curve(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``pacc study --incremental 3 --cloud URL``: the study waits for the served cloud's
    learning, reports each trip, and the cloud's curve has one point per trip, marked with the
    version the study says it drove, its PoI and NIM close to the study's own. With a settle
    window (``pacc cloud serve``'s default) the four manual trips learn one first version, as
    an embedded cloud's do (without it: one from the first trip, then one from all)."""
    from pacc.commands.study import main  # noqa: PLC0415 - the study is only this test's

    pool = ThreadPoolExecutor(max_workers=1)
    config = ServiceConfig(settle_s=0.5)
    service = CloudService.open(tmp_path / "cloud", executor=pool, config=config)
    token = service.register_vehicle("lab")
    service.register_driver("lab", "d3")
    (tmp_path / "lab.token").write_text(token + "\n", encoding="utf-8")
    s = Served(service)
    try:
        argv = ["--drivers", "d3", "--incremental", "3", "--duration", "40", "--seed", "2"]
        argv += ["--cloud", s.url, "--token-file", str(tmp_path / "lab.token")]
        argv += ["--trust", str(tmp_path / "cloud" / "keys" / "cloud.pub")]
        assert main([*argv, "--out", str(tmp_path / "out"), "-q"]) == 0
        capsys.readouterr()
        with (tmp_path / "out" / "incremental.csv").open() as fh:
            rows = list(csv.DictReader(fh))
        points = s.get("/v1/drivers/d3/trips", OPERATOR).json()
        first = service.store.versions("d3", "default")[0]
    finally:
        s.stop()
        pool.shutdown(wait=True)
        service.store.close()
    assert first.n_batches == 4 and rows[0]["dgpt_version"] == "1"  # one learn of the burst
    assert [p["index"] for p in points] == [1, 2, 3]
    assert [p["dgpt_version"] for p in points] == [int(r["dgpt_version"]) for r in rows]
    assert points[-1]["dgpt_version"] > points[0]["dgpt_version"]  # fine-tuned on the way
    for p, r in zip(points, rows, strict=True):
        assert len(p["segments"]) == int(r["uploaded"])
        assert p["poi_pct"] == pytest.approx(float(r["poi_pct"]), abs=1.0)
        assert p["takeovers_per_min"] == pytest.approx(float(r["nim_per_min"]), abs=0.5)
