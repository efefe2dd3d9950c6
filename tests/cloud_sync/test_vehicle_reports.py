"""The vehicle's trip reports over real HTTP on 127.0.0.1: ``pacc ecu --cloud URL`` reports
its trip at exit (the cloud table version it started with, its ACC-on time, its takeover
segment; with --manual its manual driving goes up as a manual batch), and a report made
while the cloud is away waits in the spool, behind its segment, until a later pass delivers
both; a report the cloud refuses for good is set aside."""

from __future__ import annotations

import json
import logging
import socket
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from pathlib import Path

import pytest

from cloud_sync.service.rules import CloudService
from cloud_sync.signing import load_public_key
from cloud_sync.vehicle.client import HttpCloud
from cloud_sync.vehicle.connect import write_token
from cloud_sync.vehicle.download import ProfileDownloader
from cloud_sync.vehicle.link import VehicleLink
from cloud_sync.vehicle.spool import Spool
from cloud_sync.vehicle.uploader import ReportError, ReportQueue, Uploader
from pacc.commands.cloud import main as cloud_main
from pacc.commands.ecu import main as ecu_main
from tests.ecu.test_cli import Peers
from tests.ecu.test_cli_cloud import cloud_table

from .conftest import takeover_segment
from .served import Served


@pytest.fixture(scope="module")
def cloud(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Served, CloudService]]:
    """The service over HTTP with vehicle car and driver syn, one published table."""
    tmp = tmp_path_factory.mktemp("reports")
    pool = ThreadPoolExecutor(max_workers=1)
    service = CloudService.open(tmp / "cloud", executor=pool)
    served = Served(service)
    yield served, service
    served.stop()
    pool.shutdown(wait=True)
    service.store.close()


def _dead_url() -> str:
    """A 127.0.0.1 URL nobody listens on."""
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return f"http://127.0.0.1:{sock.getsockname()[1]}"


def _trips(served: Served, token: str) -> list[dict[str, object]]:
    answer = served.get("/v1/drivers/syn/trips", token)
    assert answer.status_code == 200, answer.text
    trips: list[dict[str, object]] = answer.json()
    return trips


def test_a_report_waits_in_the_spool_while_the_cloud_is_away(
    cloud: tuple[Served, CloudService],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
) -> None:
    served, service = cloud
    token = service.register_vehicle("car-away")
    service.register_driver("car-away", "syn")
    version = service.publish(cloud_table(2.5, version=1), [])
    cache = tmp_path / "spool" / "profiles"
    with HttpCloud(served.url, token) as live:
        key = load_public_key(live.public_key_pem())
        assert ProfileDownloader(live, key, cache).fetch("syn") is not None  # a run online

    # a trip offline: the cached table, a takeover spooled, the report queued behind it
    with HttpCloud(_dead_url(), token, timeout_s=1.0) as away:
        link = VehicleLink(
            away,
            Spool(tmp_path / "spool"),
            "car-away",
            downloader=ProfileDownloader(away, key, cache),
            driver_id="syn",
        )
        table = link.initial_table()
        assert table is not None and table.version == version
        link.sink(takeover_segment(7, [(50, 80, "accel")]))
        line = link.end_trip(120.0, "2026-11-24T10:00:00.5Z")
        assert "queued" in line and f"v{version}" in line, line
        link.stop(drain_s=0.1)
        assert "trip reports sent 0, queued 1" in link.report()
    queued = ReportQueue(tmp_path / "spool").pending()
    assert len(queued) == 1
    report = json.loads(queued[0].read_text())
    assert report["segments"] == link.segments and len(link.segments) == 1
    assert [b.digest for b in Spool(tmp_path / "spool").pending()] == link.segments
    assert _trips(served, token) == []

    # a later pass with the cloud back (pacc cloud sync): the segment first, then the report
    write_token(tmp_path / "car.token", token)
    sync = ["sync", "--spool", str(tmp_path / "spool"), "--cloud", served.url]
    assert cloud_main([*sync, "--token-file", str(tmp_path / "car.token")]) == 0
    out = capsys.readouterr().out
    assert "uploaded 1 batch(es)" in out and "trip reports: 1 sent, 0 refused" in out, out
    assert ReportQueue(tmp_path / "spool").pending() == []
    with HttpCloud(served.url, token) as live:
        (point,) = _trips(served, token)
        assert point["trip_id"] == report["trip_id"] and point["dgpt_version"] == version
        assert point["acc_on_s"] == 120.0 and point["segments"] == link.segments
        assert point["intervention_s"] == pytest.approx(3.0)  # the 30 samples pressed
        assert point["poi_pct"] == pytest.approx(2.5) and point["takeovers"] == 1
        assert point["start_utc"] == "2026-11-24T10:00:00.5Z"
        assert Uploader(Spool(tmp_path / "spool"), live).drain() == 0  # nothing twice

    # refused for good (a version the cloud never published): set aside with the reason, and
    # pacc cloud sync exits 1 as for a refused batch
    queue = ReportQueue(tmp_path / "spool")
    queue.put({**report, "trip_id": "bad-version", "dgpt_version": 99, "segments": []})
    with caplog.at_level(logging.ERROR, logger="cloud_sync.vehicle.uploader"):
        assert cloud_main([*sync, "--token-file", str(tmp_path / "car.token")]) == 1
    out = capsys.readouterr().out
    assert "trip reports: 0 sent, 1 refused" in out and "0 still queued" in out, out
    assert queue.pending() == []
    reason = next((queue.root / "rejected").glob("*-bad-version.json.reason")).read_text()
    assert reason.startswith("refused by the cloud (HTTP 422: trip report: ") and "99" in reason
    assert reason.count("HTTP") == 1, reason  # the status said once
    (line,) = [r.getMessage() for r in caplog.records if "bad-version" in r.getMessage()]
    assert "set aside in" in line and "refused by the cloud (HTTP 422" in line, line
    assert len(_trips(served, token)) == 1


@pytest.mark.slow
def test_ecu_reports_its_trip_over_http(
    cloud: tuple[Served, CloudService], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    served, service = cloud
    token = service.register_vehicle("car-ecu")
    service.register_driver("car-ecu", "ecu-syn")
    version = service.publish(replace(cloud_table(2.0, version=1), driver_id="ecu-syn"), [])
    write_token(tmp_path / "car.token", token)
    with HttpCloud(served.url, token) as live:
        (tmp_path / "cloud.pub").write_bytes(live.public_key_pem())
    peers = Peers("ecu-trip-report", 4.2, accel_pct=20.0)  # a real press: 20 % of the pedal
    peers.start()
    args = ["-i", "virtual", "-c", "ecu-trip-report", "--duration", "4.0"]
    args += ["--cloud", served.url, "--vehicle", "car-ecu", "--driver", "ecu-syn"]
    args += ["--token-file", str(tmp_path / "car.token"), "--trust", str(tmp_path / "cloud.pub")]
    args += ["--spool", str(tmp_path / "spool"), "--manual", "--manual-min", "0.5"]
    rc = ecu_main(args)
    peers.join()
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "takeover 1 (accel)" in out and "trip report ecu-" in out, out
    assert "trip reports sent 1, queued 0, refused 0" in out, out
    answer = served.get("/v1/drivers/ecu-syn/trips", token)
    (point,) = answer.json()
    assert point["dgpt_version"] == version and len(point["segments"]) == 1
    batches = service.store.batches("ecu-syn", "default")
    # the manual driving before SET (a lead, ACC in STANDBY) went up too, as a manual batch
    assert sorted(b.kind for b in batches) == ["manual", "takeover"]
    assert "manual trips: 1 of 1 written to the cloud spool" in out, out
    assert point["segments"] == [b.digest for b in batches if b.kind == "takeover"]
    assert 1.5 <= point["acc_on_s"] <= 3.2  # engaged at ~1.3 s until 4.0 s
    assert point["intervention_s"] == pytest.approx(1.4, abs=0.35)  # the press, 1.6..3.0 s
    assert point["takeovers"] == 1


def test_a_damaged_report_file_is_set_aside_and_bad_reports_are_not_queued(
    cloud: tuple[Served, CloudService], tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    served, service = cloud
    token = service.register_vehicle("car-junk")
    queue = ReportQueue(tmp_path)
    queue.root.mkdir()
    (queue.root / "000000000001-junk.json").write_text("[1, 2]\n")
    (queue.root / "000000000002-torn.json").write_text('{"driver_id": "s')
    (queue.root / ".0123.part").write_text("{")  # a write cut short: removed on open
    queue = ReportQueue(tmp_path)
    assert not (queue.root / ".0123.part").exists()
    with (
        HttpCloud(served.url, token) as live,
        caplog.at_level(logging.ERROR, logger="cloud_sync.vehicle.uploader"),
    ):
        assert queue.send(live, set()) == 0
    assert queue.stats.rejected == 2 and queue.pending() == []
    assert sorted(p.name for p in (queue.root / "rejected").glob("*.json")) == [
        "000000000001-junk.json",
        "000000000002-torn.json",
    ]
    # the cloud never saw them: the reason and the log say what is wrong with the file
    reasons = [
        (queue.root / "rejected" / f"{n}.json.reason").read_text()
        for n in ("000000000001-junk", "000000000002-torn")
    ]
    assert reasons[0].startswith("not a trip report") and reasons[1].startswith("not JSON: ")
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2 and all("set aside in" in line for line in lines), lines
    assert not any("cloud" in line.split(": ", 1)[1] for line in lines), lines
    for bad in ({"trip_id": "../x"}, {"trip_id": "t", "acc_on_s": float("nan")}, {}):
        with pytest.raises(ReportError):
            queue.put(bad)
    assert queue.pending() == []


def test_a_report_is_held_on_an_answer_about_the_set_up_and_sent_later(
    cloud: tuple[Served, CloudService],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """A 404 (a URL prefix the cloud does not have, as an older cloud without /v1/trips
    answers) or a 405 keeps the report queued, never set aside: the next pass with the right
    URL delivers it. A report that cannot be queued is said so once."""
    served, service = cloud
    token = service.register_vehicle("car-held")
    service.register_driver("car-held", "held")
    version = service.publish(replace(cloud_table(2.5, version=1), driver_id="held"), [])
    spool = tmp_path / "spool"
    write_token(tmp_path / "car.token", token)
    with HttpCloud(served.url, token) as live:
        key = load_public_key(live.public_key_pem())
        link = VehicleLink(
            live,
            Spool(spool),
            "car-held",
            downloader=ProfileDownloader(live, key, spool / "profiles"),
            driver_id="held",
        )
        assert link.initial_table() is not None
        (spool / "reports").write_text("")  # the queue's folder cannot be made
        line = link.end_trip(60.0, "2026-11-24T11:00:00Z")
        assert line.startswith("cloud: trip report not queued: ") and line.count("trip report") == 1
        (spool / "reports").unlink()
        assert "queued" in link.end_trip(60.0, "2026-11-24T11:00:00Z")
    queue = ReportQueue(spool)
    (path,) = queue.pending()

    for prefix, status in (("/no-such-prefix", 404), ("/v1/drivers", 405)):  # POST .../v1/trips
        with HttpCloud(served.url + prefix, token) as wrong:
            assert queue.send(wrong, set()) == 0
        assert queue.stats.rejected == 0 and queue.pending() == [path], status
        assert queue.stats.last_held.startswith(f"{path.name}: HTTP {status}: ")
        assert queue.stats.last_held.count("HTTP") == 1, queue.stats.last_held
    assert queue.stats.held == 2 and not (queue.root / "rejected").exists()

    # pacc cloud sync against the wrong prefix: kept, said why, exit 1; the right URL: sent
    sync = ["sync", "--spool", str(spool), "--token-file", str(tmp_path / "car.token")]
    assert cloud_main([*sync, "--cloud", served.url + "/no-such-prefix"]) == 1
    out, err = capsys.readouterr()
    assert "trip reports: 0 sent, 0 refused" in out and "1 still queued" in out, out
    assert f"trip reports kept: {path.name}: HTTP 404: " in err and "root URL" in err, err
    assert cloud_main([*sync, "--cloud", served.url]) == 0
    out = capsys.readouterr().out
    assert "trip reports: 1 sent, 0 refused" in out and "0 still queued" in out, out
    (point,) = served.get("/v1/drivers/held/trips", token).json()
    assert point["dgpt_version"] == version and point["acc_on_s"] == 60.0
    assert not (queue.root / "rejected").exists()
