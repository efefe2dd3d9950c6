"""One test suite, two backends: the embedded cloud (LocalCloud) and the HTTP service on
127.0.0.1 (uvicorn in a thread, HttpCloud). Both must give the same answers."""

from __future__ import annotations

import dataclasses
import socket
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx
import numpy as np
import pytest

from cloud_sync.api import (
    AuthError,
    BadBatchError,
    CloudApi,
    CloudUnavailableError,
    ForbiddenError,
    NotFoundError,
    PayloadTooLargeError,
)
from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService, DeferredExecutor, ServiceConfig
from cloud_sync.service.store import BatchRow
from cloud_sync.signing import load_public_key, verify_dgpt
from cloud_sync.vehicle.client import HttpCloud
from dbc.vocab.acc_state import AccState
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import write_trip
from tests.cloud_sync.conftest import follower_trip
from tests.cloud_sync.served import Served

LIMIT = 2 * 1024 * 1024


def trip_bytes(trip: Trip, tmp: Path) -> bytes:
    path = tmp / f"{id(trip)}.mcap"
    write_trip(path, trip)
    return path.read_bytes()


def retag(trip: Trip, **meta: object) -> Trip:
    return dataclasses.replace(trip, meta={**trip.meta, **meta})


def takeover_of(trip: Trip) -> Trip:
    """The trip as a takeover segment: ACC active for its first 10 s, then the driver."""
    state = np.full(len(trip), int(AccState.OVERRIDE), dtype=np.int64)
    state[:100] = int(AccState.ACTIVE)
    return dataclasses.replace(trip, acc_state=state, meta={**trip.meta, "mode": "takeover"})


@pytest.fixture
def cloud(tmp_path: Path) -> Iterator[CloudService]:
    pool = ThreadPoolExecutor(max_workers=1)
    service = CloudService.open(
        tmp_path / "cloud", executor=pool, config=ServiceConfig(max_upload_bytes=LIMIT)
    )
    service.register_vehicle("car-b")  # another vehicle, with a driver of its own
    service.register_driver("car-b", "other")
    yield service
    pool.shutdown(wait=True)
    service.store.close()


Connect = Callable[[str], CloudApi]


@pytest.fixture(params=["local", "http"])
def connect(request: pytest.FixtureRequest, cloud: CloudService) -> Iterator[Connect]:
    """A factory: token -> this backend's client of ``cloud``."""
    if request.param == "local":
        yield lambda token: LocalCloud(cloud, token)
        return
    served: Served = request.getfixturevalue("http_server")
    served.serve(cloud)
    clients: list[HttpCloud] = []

    def make(token: str) -> CloudApi:
        clients.append(HttpCloud(served.url, token, timeout_s=30.0))
        return clients[-1]

    yield make
    for c in clients:
        c.close()


@pytest.fixture
def token(cloud: CloudService) -> str:
    token = cloud.register_vehicle("car-a")
    cloud.register_driver("car-a", "syn")
    return token


def test_an_upload_is_stored_once_and_acknowledged_by_digest(
    connect: Connect, cloud: CloudService, token: str, tmp_path: Path
) -> None:
    data = trip_bytes(follower_trip(0, minutes=0.5), tmp_path)
    api = connect(token)
    first = api.upload(data)
    again = api.upload(data)
    assert (first.driver_id, first.kind, first.duplicate) == ("syn", "manual", False)
    assert again.duplicate and again.digest == first.digest
    assert cloud.store.batch_count() == 1
    assert cloud.store.read_blob(first.digest) == data


def test_a_wrong_token_is_401(connect: Connect, tmp_path: Path) -> None:
    data = trip_bytes(follower_trip(0, minutes=0.2), tmp_path)
    with pytest.raises(AuthError):
        connect("not-a-token").upload(data)
    with pytest.raises(AuthError):
        connect("").latest_dgpt("syn")


def test_another_vehicles_driver_is_403(
    connect: Connect, cloud: CloudService, token: str, tmp_path: Path
) -> None:
    foreign = retag(follower_trip(0, minutes=0.2), driver_id="other")
    api = connect(token)
    with pytest.raises(ForbiddenError):
        api.upload(trip_bytes(foreign, tmp_path))
    with pytest.raises(ForbiddenError):
        api.latest_dgpt("other")
    assert cloud.store.batch_count() == 0


def test_an_oversized_upload_is_413_and_stored_nowhere(
    connect: Connect, cloud: CloudService, token: str
) -> None:
    with pytest.raises(PayloadTooLargeError):
        connect(token).upload(b"\0" * (LIMIT + 1))
    assert cloud.store.batch_count() == 0


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty"])
def test_a_corrupt_upload_is_422_and_stored_nowhere(
    damage: str, connect: Connect, cloud: CloudService, token: str, tmp_path: Path
) -> None:
    data = trip_bytes(follower_trip(0, minutes=0.2), tmp_path)
    bad = {"truncated": data[: len(data) // 2], "garbage": b"PK\3\4 not mcap", "empty": b""}
    with pytest.raises(BadBatchError):
        connect(token).upload(bad[damage])
    assert cloud.store.batch_count() == 0
    assert not list((cloud.store.root / "blobs").rglob("*.mcap"))


def test_a_trip_without_a_driver_is_422(connect: Connect, token: str, tmp_path: Path) -> None:
    anonymous = dataclasses.replace(follower_trip(0, minutes=0.2), meta={"mode": "manual"})
    with pytest.raises(BadBatchError, match="driver_id"):
        connect(token).upload(trip_bytes(anonymous, tmp_path))


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("condition", "../../../escaped"),
        ("condition", "/etc/x"),
        ("driver_id", "../syn"),
        ("condition", "default\n"),  # a trailing newline passed ^...$ with re.match
        ("driver_id", "syn\n"),
    ],
)
def test_names_that_would_leave_the_store_are_422(
    key: str, value: str, connect: Connect, cloud: CloudService, token: str, tmp_path: Path
) -> None:
    """driver_id and condition become folder names: only plain names get in."""
    trip = retag(follower_trip(0, minutes=0.2), **{key: value})
    with pytest.raises(BadBatchError, match="not a plain name"):
        connect(token).upload(trip_bytes(trip, tmp_path))
    assert cloud.store.batch_count() == 0
    with pytest.raises(NotFoundError):
        connect(token).latest_dgpt("syn", "../other")


def test_no_table_yet_is_404(connect: Connect, token: str) -> None:
    with pytest.raises(NotFoundError):
        connect(token).latest_dgpt("syn")


def test_an_unreachable_cloud_is_unavailable() -> None:
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with (
        HttpCloud(f"http://127.0.0.1:{port}", "t", timeout_s=2.0) as api,
        pytest.raises(CloudUnavailableError),
    ):
        api.upload(b"x")


@pytest.mark.slow
def test_manual_trips_learn_a_signed_table_and_takeovers_fine_tune_it(tmp_path: Path) -> None:
    """The loop's cloud half: manual trips -> v1 signed; a takeover batch -> v2 signed.
    (Learning does not depend on the transport: the embedded backend only; each wait_idle
    learns from every batch since the last.)"""
    cloud = CloudService.open(tmp_path / "cloud", DeferredExecutor())
    api = LocalCloud(cloud, cloud.register("car-a", ["syn"]))
    for seed in range(2):
        api.upload(trip_bytes(follower_trip(seed, minutes=3.0), tmp_path))
    cloud.wait_idle(120.0)
    public = load_public_key(api.public_key_pem())
    first = verify_dgpt(api.latest_dgpt("syn"), public)
    assert (first.driver_id, first.source) == ("syn", "irl")
    at_20 = first.lookup(20.0)
    assert 4.0 + 1.6 * 20.0 - 6.0 < at_20 < 4.0 + 1.6 * 20.0 + 6.0  # the follower's 36 m
    closer = follower_trip(11, minutes=2.0, headway_s=1.0, v_lo=15.0, v_hi=25.0)
    receipt = api.upload(trip_bytes(takeover_of(closer), tmp_path))
    assert receipt.kind == "takeover"
    cloud.wait_idle(120.0)
    second = verify_dgpt(api.latest_dgpt("syn"), public)
    assert second.version > first.version
    assert second.lookup(20.0) < at_20  # the takeovers asked for less gap
    kept = [v.version for v in cloud.store.versions("syn", "default")]
    assert kept[-2:] == [first.version, second.version]  # every version kept, in order
    assert kept == sorted(set(kept))
    assert cloud.job_errors == []
    cloud.store.close()


def test_openapi_description_lists_the_routes(cloud: CloudService, http_server: Served) -> None:
    http_server.serve(cloud)
    spec = httpx.get(f"{http_server.url}/openapi.json", timeout=10.0).json()
    assert {"/v1/batches", "/v1/drivers/{driver_id}/dgpt", "/v1/key", "/v1/health"} <= set(
        spec["paths"]
    )


def test_openapi_documents_the_body_the_bearer_scheme_and_the_errors(
    cloud: CloudService, http_server: Served
) -> None:
    http_server.serve(cloud)
    spec = httpx.get(f"{http_server.url}/openapi.json", timeout=10.0).json()
    docs = httpx.get(f"{http_server.url}/docs", timeout=10.0).text
    js = httpx.get(f"{http_server.url}/static/swagger-ui/swagger-ui-bundle.js", timeout=10.0)
    post = spec["paths"]["/v1/batches"]["post"]
    body = post["requestBody"]["content"]["application/octet-stream"]["schema"]
    assert body == {"type": "string", "format": "binary"} and post["requestBody"]["required"]
    assert {"401", "403", "413", "422", "503", "507"} <= set(post["responses"])
    schemes = spec["components"]["securitySchemes"]
    assert any(s["type"] == "http" and s["scheme"] == "bearer" for s in schemes.values())
    assert post["security"] and spec["paths"]["/v1/drivers/{driver_id}/dgpt"]["get"]["security"]
    # Swagger UI offline: its assets come from the cloud itself, no CDN
    assert "/static/swagger-ui/swagger-ui-bundle.js" in docs and "cdn" not in docs.lower()
    assert js.status_code == 200 and len(js.content) > 100_000


def test_a_full_disk_is_507_with_retry_after_and_the_batch_stays_spooled(
    cloud: CloudService, token: str, tmp_path: Path, http_server: Served
) -> None:
    """The store's disk full (ENOSPC from the blob write): 507 + Retry-After over HTTP, a
    retryable error for the vehicle, nothing stored."""
    import errno  # noqa: PLC0415

    from cloud_sync.api import CloudUnavailableError  # noqa: PLC0415
    from cloud_sync.vehicle.client import HttpCloud  # noqa: PLC0415

    real = cloud.store.add_batch

    def full(row: BatchRow, data: bytes) -> bool:  # the disk is full: the one fault injected
        raise OSError(errno.ENOSPC, "No space left on device")

    cloud.store.add_batch = full  # type: ignore[method-assign]
    served = http_server
    served.serve(cloud)
    data = trip_bytes(follower_trip(0, minutes=0.2), tmp_path)
    try:
        answer = httpx.post(
            f"{served.url}/v1/batches",
            content=data,
            headers={"Authorization": f"Bearer {token}"},
            timeout=10.0,
        )
        assert answer.status_code == 507 and answer.headers["retry-after"] == "60"
        assert "disk is full" in answer.json()["detail"]
        with HttpCloud(served.url, token) as client, pytest.raises(CloudUnavailableError):
            client.upload(data)
    finally:
        cloud.store.add_batch = real  # type: ignore[method-assign]
    assert cloud.store.batch_count() == 0


def test_a_422_names_no_server_path(connect: Connect, token: str) -> None:
    with pytest.raises(BadBatchError) as info:
        connect(token).upload(b"PK\3\4 not mcap")
    assert "/tmp" not in str(info.value) and ".mcap" not in str(info.value)
