"""``pacc study`` through the vehicle-cloud loop: manual trips up, verified tables down, and
the incremental-learning experiment (takeovers up, fine-tuned versions down)."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService
from cloud_sync.service.trips import trip_rows
from dbc.vocab.dgpt_file import load_dgpt
from pacc.commands.study import main
from pacc.study.loop import StudyCloud
from pacc.study.pipeline import run
from pacc.study.spec import StudySpec, table1_method, validate
from sim_bus.errors import SimError
from tests.cloud_sync.conftest import takeover_segment
from tests.ecu.test_cli_cloud import cloud_table


@pytest.mark.slow
def test_study_learns_its_irl_tables_in_the_embedded_cloud(tmp_path: Path) -> None:
    cfg = StudySpec(
        drivers=("d2",),
        scenarios=("B",),
        methods=(table1_method("irl"),),
        trials=1,
        seed=1,
        duration_s=20.0,
        workers=1,
        logs=False,
    )
    rows = run(cfg, tmp_path, progress=False)
    assert len(rows) == 1 and rows[0]["driver"] == "d2"
    service = CloudService.open(tmp_path / "cloud")
    kinds = [b.kind for b in service.store.batches("d2", "default")]
    assert kinds == ["manual"] * 4  # the four manual trips went up through the spool
    versions = service.store.versions("d2", "default")
    table = load_dgpt(tmp_path / "irl" / "d2.json")
    assert (table.source, table.version) == ("irl", versions[-1].version)
    assert list((tmp_path / "spool").glob("*.mcap")) == []  # all acknowledged
    cached = tmp_path / "spool" / "profiles" / "d2" / "default.signed.json"
    assert cached.is_file()  # the vehicle keeps the verified table it drove with


@pytest.mark.slow
def test_incremental_learning_fine_tunes_between_trips(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    argv = ["--drivers", "d3", "--incremental", "3", "--duration", "40", "--seed", "2"]
    assert main([*argv, "--out", str(tmp_path), "-q"]) == 0
    out = capsys.readouterr().out
    assert "Incremental learning" in out and "incremental.png" in out
    with (tmp_path / "incremental.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["trip"]) for r in rows] == [1, 2, 3]
    versions = [int(r["dgpt_version"]) for r in rows]
    assert versions == sorted(versions)  # each trip drives the newest version
    service = CloudService.open(tmp_path / "cloud")
    takeovers = [b for b in service.store.batches("d3", "default") if b.kind == "takeover"]
    assert len(takeovers) == sum(int(r["uploaded"]) for r in rows)
    assert takeovers, "d3 made no takeover in 3 trips: the fine-tuning went untested"
    assert versions[-1] > versions[0]  # the takeovers made a new version for a later trip
    # the cloud's per-trip curve (trip reports): its own PoI and NIM from the segments it got
    points = trip_rows(service, "d3")
    assert [p["dgpt_version"] for p in points] == versions
    for p, r in zip(points, rows, strict=True):
        assert p["poi_pct"] == pytest.approx(float(r["poi_pct"]), abs=1.0)
        assert p["takeovers_per_min"] == pytest.approx(float(r["nim_per_min"]), abs=0.5)
    assert (tmp_path / "incremental.png").stat().st_size > 0


def test_cloud_options_are_checked_before_anything_runs() -> None:
    with pytest.raises(SimError, match="--token-file F and --trust"):
        validate(StudySpec(cloud="http://127.0.0.1:9"))
    with pytest.raises(SimError, match="not with --cloud or --incremental"):
        validate(StudySpec(learn_in="direct", incremental=2))
    with pytest.raises(SimError, match="--incremental must be >= 0"):
        validate(StudySpec(incremental=-1))


def test_the_study_reports_its_trips_through_the_vehicles_report_queue(tmp_path: Path) -> None:
    """StudyCloud is a use of the vehicle's one wiring (VehicleLink): a trip report goes
    through the spool's report queue behind its segment; a refused one is SimError and set
    aside with its reason, not lost."""
    cloud = StudyCloud.embedded(tmp_path, ["syn"], seed=0)
    assert isinstance(cloud.link.cloud, LocalCloud)
    service = cloud.link.cloud.service
    version = service.publish(cloud_table(2.5, version=1), [])
    assert cloud.upload([takeover_segment(7, [(50, 80, "accel")])]) == 1
    report = {
        "driver_id": "syn",
        "condition": "default",
        "trip_id": "study-t1",
        "dgpt_version": version,
        "acc_on_s": 20.0,
        "segments": cloud.last_digests,
    }
    cloud.report_trip(report)
    assert cloud.link.uploader.reports.pending() == []
    (row,) = trip_rows(service, "syn")
    assert (row["trip_id"], row["takeovers"], row["dgpt_version"]) == ("study-t1", 1, version)
    bad = {**report, "trip_id": "study-t2", "dgpt_version": version + 5, "segments": []}
    with pytest.raises(SimError, match="trip report refused"):
        cloud.report_trip(bad)
    rejected = tmp_path / "spool" / "reports" / "rejected"
    (reason,) = rejected.glob("*-study-t2.json.reason")
    assert "no published version" in reason.read_text()
    assert [r["trip_id"] for r in trip_rows(service, "syn")] == ["study-t1"]
