"""Profile download: verified, cached as the last good table, and refused when it is not right."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import pytest

from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService
from cloud_sync.signing import load_public_key
from cloud_sync.vehicle.client import HttpCloud
from cloud_sync.vehicle.download import ProfileDownloader
from dbc.vocab.dgpt import Dgpt, SafetyBounds, predefined
from tests.cloud_sync.test_uploader import free_port


def table(headway_s: float, version: int = 1, bounds: SafetyBounds | None = None) -> Dgpt:
    t = predefined(headway_s, driver_id="d1", created_utc="2026-01-01T00:00:00Z", bounds=bounds)
    for _ in range(version):
        t = t.with_gaps(t.gap_m, source="irl", created_utc="2026-01-01T00:00:00Z")
    return t


@pytest.fixture
def cloud(tmp_path: Path) -> Iterator[tuple[CloudService, LocalCloud]]:
    service = CloudService.open(tmp_path / "cloud")
    token = service.register_vehicle("car")
    service.register_driver("car", "d1")
    yield service, LocalCloud(service, token)
    service.store.close()


def downloader(api: LocalCloud | HttpCloud, service: CloudService, tmp: Path) -> ProfileDownloader:
    return ProfileDownloader(api, load_public_key(service.public_key_pem()), tmp / "cache")


def test_a_new_version_is_verified_cached_and_fetched_once(
    cloud: tuple[CloudService, LocalCloud], tmp_path: Path
) -> None:
    service, api = cloud
    dl = downloader(api, service, tmp_path)
    assert dl.fetch("d1") is None and dl.report.not_found == 1
    service.publish(table(2.0), [])
    got = dl.fetch("d1")
    assert got is not None and got.lookup(20.0) == pytest.approx(44.0)
    assert dl.fetch("d1") is None and dl.report.unchanged == 1  # nothing new
    last = dl.last_good("d1")
    assert last is not None and last.version == got.version
    service.publish(table(1.5, version=2), [])
    newer = dl.fetch("d1")
    assert newer is not None and newer.version > got.version


def test_offline_keeps_the_last_good_table(
    cloud: tuple[CloudService, LocalCloud], tmp_path: Path
) -> None:
    service, api = cloud
    service.publish(table(2.0), [])
    assert downloader(api, service, tmp_path).fetch("d1") is not None
    with HttpCloud(f"http://127.0.0.1:{free_port()}", "t", timeout_s=1.0) as dead:
        offline = downloader(dead, service, tmp_path)
        assert offline.fetch("d1") is None and offline.report.offline == 1
        last = offline.last_good("d1")
    assert last is not None and last.lookup(20.0) == pytest.approx(44.0)


def test_a_tampered_cache_is_refused(
    cloud: tuple[CloudService, LocalCloud], tmp_path: Path
) -> None:
    service, api = cloud
    service.publish(table(2.0), [])
    dl = downloader(api, service, tmp_path)
    dl.fetch("d1")
    path = dl.cache_path("d1", "default")
    envelope = json.loads(path.read_bytes())
    envelope["dgpt"] = envelope["dgpt"].replace('"version": 1', '"version": 9')
    path.write_text(json.dumps(envelope))
    assert dl.last_good("d1") is None
    assert "tampered" in dl.report.refusals[-1]


def test_a_table_from_another_cloud_is_refused(
    cloud: tuple[CloudService, LocalCloud], tmp_path: Path
) -> None:
    service, api = cloud
    impostor = CloudService.open(tmp_path / "impostor")
    impostor.publish(table(2.0), [])
    trusting_impostor = ProfileDownloader(
        LocalCloud(service, api.token), load_public_key(impostor.public_key_pem()), tmp_path / "c"
    )
    service.publish(table(2.0), [])
    assert trusting_impostor.fetch("d1") is None
    assert "trusts" in trusting_impostor.report.refusals[-1]
    impostor.store.close()


def test_a_signed_table_outside_the_vehicles_bounds_is_refused(
    cloud: tuple[CloudService, LocalCloud], tmp_path: Path
) -> None:
    service, api = cloud
    service.publish(table(6.0, bounds=SafetyBounds(headway_max_s=8.0)), [])
    dl = downloader(api, service, tmp_path)
    assert dl.fetch("d1") is None
    assert "refused" in dl.report.refusals[-1]
    assert dl.last_good("d1") is None  # nothing was kept


@pytest.mark.parametrize(("driver", "condition"), [("d3", "default"), ("d1", "wet")])
def test_a_signed_table_in_another_drivers_or_conditions_cache_is_refused(
    cloud: tuple[CloudService, LocalCloud], tmp_path: Path, driver: str, condition: str
) -> None:
    """d1's signed table copied to d3's (or to d1's wet) cache path: the signature holds, but
    the table is not for that driver and condition; it is refused, not used."""
    service, api = cloud
    service.publish(table(2.0), [])
    dl = downloader(api, service, tmp_path)
    dl.fetch("d1")
    other = dl.cache_path(driver, condition)
    other.parent.mkdir(parents=True, exist_ok=True)
    other.write_bytes(dl.cache_path("d1", "default").read_bytes())
    assert dl.last_good(driver, condition) is None
    assert f"asked for {driver}/{condition}" in dl.report.refusals[-1]
