"""The cloud's store: a published version is never overwritten, lost blobs heal, names stay
inside the data folder, and learning resumes after a restart."""

from __future__ import annotations

from pathlib import Path

import pytest

from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService
from cloud_sync.service.store import StoreError, VersionRow
from cloud_sync.signing import verify_dgpt
from dbc.vocab.dgpt import predefined
from dbc.vocab.triplog_file import write_trip
from tests.cloud_sync.conftest import follower_trip


def test_a_version_that_exists_is_refused_without_touching_its_file(tmp_path: Path) -> None:
    service = CloudService.open(tmp_path)
    version = service.publish(predefined(2.0, driver_id="d1", created_utc="x"), [])
    row = service.store.versions("d1", "default")[-1]
    before = service.store.read_version(row)
    with pytest.raises(StoreError, match="exists already"):
        service.store.add_version(
            VersionRow("d1", "default", version, "irl", "x", 0), b'{"other": 1}', []
        )
    assert service.store.read_version(row) == before
    assert verify_dgpt(before, service.key.public_key()).version == version
    assert not list((tmp_path / "dgpt").rglob("*.part"))


def test_a_lost_blob_is_written_again_by_the_next_upload(tmp_path: Path) -> None:
    service = CloudService.open(tmp_path / "cloud")
    cloud = LocalCloud(service, service.register_vehicle("car"))
    service.register_driver("car", "syn")
    write_trip(tmp_path / "t.mcap", follower_trip(0, minutes=0.2))
    data = (tmp_path / "t.mcap").read_bytes()
    receipt = cloud.upload(data)
    service.store.blob_path(receipt.digest).unlink()  # a rename a power cut did not keep
    assert cloud.upload(data).duplicate
    assert service.store.read_blob(receipt.digest) == data


@pytest.mark.parametrize(("driver", "condition"), [("..", "x"), ("d1", "../../x"), ("/a", "b")])
def test_version_paths_stay_inside_the_store(tmp_path: Path, driver: str, condition: str) -> None:
    service = CloudService.open(tmp_path)
    with pytest.raises(StoreError, match="plain name"):
        service.store.version_path(driver, condition, 1)


def test_a_driver_id_that_is_not_a_plain_name_cannot_be_registered(tmp_path: Path) -> None:
    service = CloudService.open(tmp_path)
    service.register_vehicle("car")
    with pytest.raises(StoreError, match="plain name"):
        service.register_driver("car", "../d1")


@pytest.mark.slow
def test_learning_resumes_after_a_restart(tmp_path: Path) -> None:
    """Batches stored, then the process ends before learning (the embedded cloud defers it):
    the next process learns them when a table is asked for."""
    first = LocalCloud.open(tmp_path / "cloud", "")
    token = first.service.register_vehicle("car")
    first.service.register_driver("car", "syn")
    first = LocalCloud(first.service, token)
    for seed in range(2):
        write_trip(tmp_path / f"{seed}.mcap", follower_trip(seed, minutes=1.5))
        first.upload((tmp_path / f"{seed}.mcap").read_bytes())
    first.service.store.close()  # the process ends; its queued job is gone
    again = LocalCloud.open(tmp_path / "cloud", token)
    assert again.service.store.unused_keys() == [("syn", "default")]
    assert verify_dgpt(again.latest_dgpt("syn"), again.service.key.public_key()).source == "irl"
    assert again.service.store.unused_keys() == []
