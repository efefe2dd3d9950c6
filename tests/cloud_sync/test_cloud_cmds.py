"""``pacc cloud register | serve | sync`` as a user runs them (serve as a real process)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from cloud_sync.service.rules import CloudService
from dbc.vocab.triplog_file import write_trip
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
    assert main(again) == 1
    assert "already registered" in capsys.readouterr().err


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
    args += ["--token-file", str(token), "--add", str(tmp_path / "a.mcap"), "--retry-s", "1"]
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


@pytest.fixture
def server(tmp_path: Path) -> Iterator[tuple[str, Path, Path]]:
    data, token = register(tmp_path, "syn")
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


@pytest.mark.slow
def test_serve_then_sync_over_http(
    server: tuple[str, Path, Path], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    url, data, token = server
    write_trip(tmp_path / "a.mcap", follower_trip(0, minutes=0.5))
    args = ["sync", "--spool", str(tmp_path / "s"), "--cloud", url, "--token-file", str(token)]
    assert main([*args, "--add", str(tmp_path / "a.mcap")]) == 0
    assert "uploaded 1 batch(es)" in capsys.readouterr().out
    assert httpx.get(f"{url}/v1/health", timeout=5.0).json()["batches"] == 1
    assert httpx.get(f"{url}/openapi.json", timeout=5.0).status_code == 200
