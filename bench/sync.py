"""Vehicle-to-cloud sync: upload throughput and fine-tune latency, against a plain file copy.

1. Throughput: N takeover batches (15-s segments at 10 Hz, as the ECU's recorder writes them)
   are spooled, then uploaded by the uploader over HTTP to ``pacc cloud serve``'s application
   (uvicorn on 127.0.0.1, in this process's threads) until the spool is empty: every batch
   parsed, validated, stored and indexed. Peer: ``shutil.copyfile`` of the same files into a
   folder (what an rsync-style sync would cost at best on this disk).
2. Fine-tune latency: a driver whose first table was learned from manual trips uploads one
   takeover batch; measured from the upload's start to the signed new version being readable.

Run: ``python bench/sync.py [--batches 200]``; the last line is the headline ratio.
"""

from __future__ import annotations

import argparse
import dataclasses
import shutil
import socket
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import uvicorn

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cloud_sync.irl.sources.synthetic import follower_trip  # noqa: E402
from cloud_sync.service.http import create_app  # noqa: E402
from cloud_sync.service.local import LocalCloud  # noqa: E402
from cloud_sync.service.rules import CloudService  # noqa: E402
from cloud_sync.vehicle.client import HttpCloud  # noqa: E402
from cloud_sync.vehicle.spool import Spool  # noqa: E402
from cloud_sync.vehicle.uploader import Uploader, UploaderConfig  # noqa: E402
from dbc.vocab.acc_state import AccState  # noqa: E402
from dbc.vocab.triplog import Trip  # noqa: E402
from dbc.vocab.tripmode import TripMode  # noqa: E402


def takeover_segment(seed: int) -> Trip:
    """A 15-s takeover segment: 5 s ACC active, then the driver, 10 Hz."""
    trip = follower_trip(seed, minutes=0.25, headway_s=1.2, v_lo=15.0, v_hi=25.0)
    state = np.full(len(trip), int(AccState.OVERRIDE), dtype=np.int64)
    state[:50] = int(AccState.ACTIVE)
    return dataclasses.replace(
        trip, acc_state=state, meta={**trip.meta, "mode": TripMode.TAKEOVER.value}
    )


def serve(service: CloudService) -> tuple[str, uvicorn.Server, threading.Thread]:
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    server = uvicorn.Server(
        uvicorn.Config(create_app(service), log_level="warning", lifespan="off")
    )
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.01)
    return f"http://127.0.0.1:{sock.getsockname()[1]}", server, thread


def throughput(tmp: Path, n: int) -> tuple[float, float, int]:
    """(our MB/s, file-copy MB/s, bytes per batch)."""
    spool = Spool(tmp / "spool")
    for seed in range(n):
        spool.put_trip(takeover_segment(seed))
    files = [b.path for b in spool.pending()]
    total = sum(p.stat().st_size for p in files)
    (tmp / "copy").mkdir()
    t0 = time.perf_counter()
    for p in files:
        shutil.copyfile(p, tmp / "copy" / p.name)
    copy_s = time.perf_counter() - t0

    pool = ThreadPoolExecutor(max_workers=1)
    service = CloudService.open(tmp / "cloud", executor=pool)
    token = service.register_vehicle("car")
    service.register_driver("car", "syn")
    url, server, thread = serve(service)
    with HttpCloud(url, token) as client:
        uploader = Uploader(spool, client, UploaderConfig(backoff_s=0.05))
        t0 = time.perf_counter()
        uploader.drain()
        ours_s = time.perf_counter() - t0
    assert spool.pending() == [] and service.store.batch_count() == n
    server.should_exit = True
    thread.join()
    pool.shutdown()
    return total / ours_s / 1e6, total / copy_s / 1e6, total // n


def fine_tune_latency(tmp: Path) -> float:
    """Seconds from a takeover upload's start to its signed new version."""
    pool = ThreadPoolExecutor(max_workers=1)
    service = CloudService.open(tmp / "ft", executor=pool)
    token = service.register_vehicle("car")
    service.register_driver("car", "syn")
    api = LocalCloud(service, token)
    spool = Spool(tmp / "ft-spool")
    for seed in range(3):
        spool.put_trip(follower_trip(seed, minutes=4.0))
    Uploader(spool, api).drain()
    service.wait_idle()
    before = service.store.versions("syn", "default")[-1].version
    spool.put_trip(takeover_segment(99))
    t0 = time.perf_counter()
    Uploader(spool, api).drain()
    service.wait_idle()
    latency = time.perf_counter() - t0
    assert service.store.versions("syn", "default")[-1].version > before
    pool.shutdown()
    return latency


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batches", type=int, default=200)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        ours, copy, per = throughput(tmp, args.batches)
        latency = fine_tune_latency(tmp)
    print(f"batches: {args.batches} takeover segments, {per} bytes each")
    print(f"file copy (peer):     {copy:8.2f} MB/s")
    print(f"upload to the cloud:  {ours:8.2f} MB/s  ({ours * 1e6 / per:.0f} batches/s)")
    print(f"fine-tune latency:    {latency:8.2f} s from takeover upload to signed table")
    print(f"sync: {ours / copy:.3f}x file copy, fine-tune {latency:.2f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
