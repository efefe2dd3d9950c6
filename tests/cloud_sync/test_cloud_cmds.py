"""``pacc cloud register | serve | sync`` as a user runs them (serve as a real process)."""

from __future__ import annotations

import io
import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import httpx
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from cloud_sync.service.rules import CloudService
from dbc.vocab.triplog_file import trip_to_bytes, write_trip
from pacc.commands.cloud import main
from tests.cloud_sync.conftest import follower_trip
from tests.cloud_sync.test_uploader import free_port

ROOT = Path(__file__).resolve().parents[2]


def register(tmp: Path, *drivers: str) -> tuple[Path, Path]:
    data, token = tmp / "cloud", tmp / "car.token"
    args = ["register", "--data", str(data), "--vehicle", "car", "--token-file", str(token)]
    for d in drivers:
        args += ["--driver", d]
    assert main(args) == 0
    return data, token


def test_register_writes_a_private_token_and_names_the_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data, token = register(tmp_path, "syn")
    out = capsys.readouterr().out
    assert f"{data / 'keys' / 'cloud.pub'}" in out
    assert token.stat().st_mode & 0o777 == 0o600
    service = CloudService.open(data)
    assert service.authenticate(token.read_text().strip()) == "car"
    assert service.store.driver_vehicle("syn") == "car"
    again = ["register", "--data", str(data), "--vehicle", "car", "--token-file", str(token)]
    assert main(again) == 2
    assert "already registered" in capsys.readouterr().err


def test_register_never_overwrites_another_vehicles_token_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data, token = register(tmp_path, "syn")
    kept = token.read_text()
    car2 = ["register", "--data", str(data), "--vehicle", "car2", "--token-file", str(token)]
    assert main(car2) == 2
    assert "exists" in capsys.readouterr().err and token.read_text() == kept
    service = CloudService.open(data)
    assert service.authenticate(kept.strip()) == "car"
    assert service.store.query("SELECT vehicle_id FROM vehicles") == [("car",)]
    service.store.close()
    assert main([*car2, "--force"]) == 0 and token.read_text() != kept
    assert token.stat().st_mode & 0o777 == 0o600


def test_a_driver_of_another_vehicle_is_refused_with_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data, _ = register(tmp_path, "syn")
    car2 = ["register", "--data", str(data), "--vehicle", "car2", "--driver", "syn"]
    assert main([*car2, "--token-file", str(tmp_path / "car2.token")]) == 2
    assert "already registered to vehicle 'car'" in capsys.readouterr().err
    assert not (tmp_path / "car2.token").exists()


def test_the_operator_adds_drivers_reissues_and_revokes_a_token(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from cloud_sync.api import AuthError  # noqa: PLC0415

    data, token = register(tmp_path, "syn")
    old = token.read_text().strip()
    vehicle = ["vehicle", "--data", str(data), "--vehicle", "car"]
    assert main([*vehicle, "--driver", "d3"]) == 0
    assert main([*vehicle, "--new-token", str(token)]) == 2  # the file is there: --force
    assert main([*vehicle, "--new-token", str(token), "--force"]) == 0
    assert main(["vehicle", "--data", str(data), "--vehicle", "nope", "--driver", "x"]) == 2
    service = CloudService.open(data)
    assert service.store.driver_vehicle("d3") == "car"
    new = token.read_text().strip()
    assert service.authenticate(new) == "car"
    with pytest.raises(AuthError):
        service.authenticate(old)
    assert main([*vehicle, "--revoke"]) == 0
    with pytest.raises(AuthError):
        service.authenticate(new)
    service.store.close()
    assert "no vehicle 'nope'" in capsys.readouterr().err


def test_sync_add_of_an_implausible_trip_log_is_one_error_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data, token = register(tmp_path, "syn")
    huge = tmp_path / "huge.mcap"
    huge.write_bytes(scaled_times(trip_to_bytes(follower_trip(0, minutes=0.2)), 1e300))
    args = ["sync", "--spool", str(tmp_path / "s"), "--cloud", str(data)]
    assert main([*args, "--token-file", str(token), "--add", str(huge)]) == 1
    err = capsys.readouterr().err
    assert "t_s = 1e+300" in err and len(err.strip().splitlines()) == 1
    assert not list((tmp_path / "s").glob("*.mcap"))


def scaled_times(data: bytes, scale: float) -> bytes:
    """A trip log's bytes with every sample time ``(t_s + 1) * scale`` (log times kept)."""
    out = io.BytesIO()
    writer = Writer(out)
    writer.start(profile="pacc.trip/1", library="test")
    ids: dict[str, int] = {}
    for schema, channel, msg in make_reader(io.BytesIO(data)).iter_messages():
        if channel.topic not in ids:
            assert schema is not None
            sid = writer.register_schema(schema.name, schema.encoding, schema.data)
            ids[channel.topic] = writer.register_channel(
                channel.topic, channel.message_encoding, sid
            )
        body = json.loads(msg.data)
        if "t_s" in body:
            body["t_s"] = (body["t_s"] + 1.0) * scale
        writer.add_message(ids[channel.topic], msg.log_time, json.dumps(body).encode(), 0)
    writer.finish()  # type: ignore[no-untyped-call]
    return out.getvalue()


@pytest.mark.slow
def test_sync_into_an_embedded_cloud_learns_and_fetches_a_verified_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data, token = register(tmp_path, "syn")
    trips = []
    for seed in range(3):
        trips.append(tmp_path / f"manual{seed}.mcap")
        write_trip(trips[-1], follower_trip(seed, minutes=2.0))
    args = ["sync", "--spool", str(tmp_path / "spool"), "--cloud", str(data)]
    args += ["--token-file", str(token), "--add", *map(str, trips)]
    args += ["--fetch", "syn", "--trust", str(data / "keys" / "cloud.pub")]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "uploaded 3 batch(es)" in out and "0 still spooled" in out
    assert "DGPT syn/default v" in out and "verified" in out


def test_fetch_without_a_trusted_key_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    data, token = register(tmp_path)
    args = ["sync", "--spool", str(tmp_path / "s"), "--cloud", str(data)]
    assert main([*args, "--token-file", str(token), "--fetch", "syn"]) == 2
    assert "--trust" in capsys.readouterr().err


def test_sync_to_an_unreachable_cloud_keeps_the_batch(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    token = tmp_path / "t"
    token.write_text("abc\n")
    write_trip(tmp_path / "a.mcap", follower_trip(0, minutes=0.2))
    args = ["sync", "--spool", str(tmp_path / "s"), "--cloud", f"http://127.0.0.1:{free_port()}"]
    args += ["--token-file", str(token), "--add", str(tmp_path / "a.mcap"), "--retry-s", "0.2"]
    assert main(args) == 1
    assert "1 still spooled" in capsys.readouterr().out
    assert len(list((tmp_path / "s").glob("*.mcap"))) == 1


def test_a_bad_token_file_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "t").write_text("two tokens\n")
    args = ["sync", "--spool", str(tmp_path / "s"), "--cloud", str(tmp_path / "c")]
    assert main([*args, "--token-file", str(tmp_path / "t")]) == 1
    assert "holds no single token" in capsys.readouterr().err


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[str, Path, Path]]:
    """``pacc cloud serve`` as a process, for the module: vehicle car with drivers syn (whose
    trips its tests upload) and learner (whose trips one test waits to be learned)."""
    data, token = register(tmp_path_factory.mktemp("served"), "syn", "learner")
    port = free_port()
    proc = subprocess.Popen(
        [sys.executable, "-m", "pacc", "cloud", "serve", "--data", str(data), "--port", str(port)],
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 30.0
    while time.monotonic() < deadline:
        try:
            if httpx.get(f"{url}/v1/health", timeout=1.0).status_code == 200:
                break
        except httpx.TransportError:
            time.sleep(0.1)
    yield url, data, token
    proc.send_signal(signal.SIGTERM)
    out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0, out
    assert "serving" in out and "pacc cloud stopped" in out


def _batches(url: str) -> int:
    """How many batches the served cloud holds."""
    return int(httpx.get(f"{url}/v1/health", timeout=5.0).json()["batches"])


@pytest.mark.slow
def test_serve_then_sync_over_http(
    server: tuple[str, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url, data, token = server
    write_trip(tmp_path / "a.mcap", follower_trip(0, minutes=0.5))
    before = _batches(url)
    args = ["sync", "--spool", str(tmp_path / "s"), "--cloud", url, "--token-file", str(token)]
    assert main([*args, "--add", str(tmp_path / "a.mcap")]) == 0
    assert "uploaded 1 batch(es)" in capsys.readouterr().out
    assert _batches(url) == before + 1
    assert httpx.get(f"{url}/openapi.json", timeout=5.0).status_code == 200


def test_serve_on_a_taken_port_is_one_line_and_exit_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with socket.create_server(("127.0.0.1", 0)) as taken:
        port = taken.getsockname()[1]
        argv = ["serve", "--data", str(tmp_path / "c"), "--port", str(port)]
        assert main([*argv, "--scheduler", "local"]) == 2
    out, err = capsys.readouterr()
    assert err.strip() == (
        f"pacc cloud serve: error: cannot listen on 127.0.0.1:{port}: Address already in use"
    )
    assert "serving" not in out


def test_an_embedded_sync_into_a_served_folder_is_refused_with_the_url(
    server: tuple[str, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url, data, token = server
    write_trip(tmp_path / "a.mcap", follower_trip(1, minutes=0.2))
    before = _batches(url)
    args = ["sync", "--spool", str(tmp_path / "s"), "--cloud", str(data), "--token-file"]
    assert main([*args, str(token), "--add", str(tmp_path / "a.mcap")]) == 1
    assert f"served by pacc cloud serve at {url}" in capsys.readouterr().err
    assert len(list((tmp_path / "s").glob("*.mcap"))) == 1  # kept for a sync to the URL
    assert _batches(url) == before


@pytest.mark.slow
def test_sync_waits_for_the_served_cloud_to_learn_before_it_fetches(
    server: tuple[str, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url, data, token = server
    trips = []
    for seed in range(3):
        trips.append(tmp_path / f"manual{seed}.mcap")
        trip = follower_trip(seed, minutes=2.0)
        write_trip(trips[-1], replace(trip, meta={**trip.meta, "driver_id": "learner"}))
    args = ["sync", "--spool", str(tmp_path / "s"), "--cloud", url, "--token-file", str(token)]
    args += ["--add", *map(str, trips), "--fetch", "learner"]
    args += ["--trust", str(data / "keys" / "cloud.pub"), "--wait", "120"]
    assert main(args) == 0, capsys.readouterr().err
    assert "DGPT learner/default v" in capsys.readouterr().out
    auth = {"Authorization": f"Bearer {token.read_text().strip()}"}
    batches = httpx.get(f"{url}/v1/drivers/learner/batches", headers=auth, timeout=5.0).json()
    assert len(batches) == 3 and all(b["used_in_version"] for b in batches)  # learned from


def test_learn_never_writes_over_its_demonstration(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    demo = tmp_path / "m.mcap"
    write_trip(demo, follower_trip(0, minutes=2.0))
    kept = demo.read_bytes()
    argv = ["learn", "--demos", str(demo), "--driver", "syn", "--learner", "empirical"]
    assert main([*argv, "-o", str(demo)]) == 2
    assert "it would overwrite" in capsys.readouterr().err
    assert demo.read_bytes() == kept
