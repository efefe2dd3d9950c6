"""The vehicle's spool: atomic batches named by digest, recovery, quota eviction, crash safety."""

from __future__ import annotations

import os
import random
import signal
import time
from pathlib import Path

import numpy as np
import pytest

from cloud_sync.vehicle.spool import EVICTION_ORDER, Spool, SpoolError, file_digest
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import read_trip

#: SIGKILLs of the spool writer (every fourth after a commit)
SPOOL_KILLS = 20


def make_trip(mode: str, n: int = 50, seed: int = 0) -> Trip:
    """A small trip at 10 Hz whose bytes depend on ``seed``."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    v = 20.0 + rng.normal(0.0, 0.5, n)
    return Trip(
        t_s=t,
        v_mps=v,
        gap_m=40.0 + rng.normal(0.0, 1.0, n),
        v_lead_mps=v + rng.normal(0.0, 0.2, n),
        a_mps2=rng.normal(0.0, 0.3, n),
        accel_pedal=np.zeros(n),
        brake_pedal=np.zeros(n),
        acc_state=np.zeros(n, dtype=np.int64),
        meta={"driver_id": "d1", "mode": mode, "seed": seed},
    )


def test_a_batch_is_named_by_its_digest_and_survives_a_reopen(tmp_path: Path) -> None:
    spool = Spool(tmp_path)
    first = spool.put_trip(make_trip("takeover", seed=1))
    second = spool.put_trip(make_trip("manual", seed=2))
    assert first.path.name == f"{1:012d}-takeover-{first.digest}.mcap"
    assert file_digest(first.path) == first.digest
    assert read_trip(second.path).meta["mode"] == "manual"
    reopened = Spool(tmp_path)
    assert [(b.seq, b.kind, b.digest) for b in reopened.pending()] == [
        (1, "takeover", first.digest),
        (2, "manual", second.digest),
    ]
    assert reopened.put_trip(make_trip("acc", seed=3)).seq == 3  # numbering continues


def test_the_same_trip_twice_is_one_batch(tmp_path: Path) -> None:
    spool = Spool(tmp_path)
    a = spool.put_trip(make_trip("takeover", seed=5))
    b = spool.put_trip(make_trip("takeover", seed=5))
    assert a == b and len(spool.pending()) == 1
    assert len(list(tmp_path.glob("*.mcap"))) == 1


def test_ack_deletes_only_the_acknowledged_batch(tmp_path: Path) -> None:
    spool = Spool(tmp_path)
    keep = spool.put_trip(make_trip("takeover", seed=1))
    done = spool.put_trip(make_trip("takeover", seed=2))
    assert spool.ack(done.digest) is True
    assert spool.ack(done.digest) is False  # a repeated ack changes nothing
    assert spool.ack("0" * 64) is False
    assert spool.pending() == [keep] and not done.path.exists() and keep.path.exists()
    assert spool.stats.acked == 1


def test_leftovers_of_a_crash_are_removed_and_a_corrupt_batch_quarantined(tmp_path: Path) -> None:
    spool = Spool(tmp_path)
    good = spool.put_trip(make_trip("takeover", seed=1))
    bad = spool.put_trip(make_trip("takeover", seed=2))
    (tmp_path / ".incoming" / "half.mcap").write_bytes(b"\x89MCAP0\r\n half a file")
    data = bytearray(bad.path.read_bytes())
    data[len(data) // 2] ^= 0xFF  # one flipped byte
    bad.path.write_bytes(bytes(data))
    reopened = Spool(tmp_path)
    assert reopened.pending() == [good]
    assert reopened.stats.partials_removed == 1 and reopened.stats.quarantined == 1
    assert (tmp_path / "quarantine" / bad.path.name).exists()
    assert list((tmp_path / ".incoming").iterdir()) == []


def test_quota_evicts_manual_trips_first_and_takeovers_last(tmp_path: Path) -> None:
    size = Spool(tmp_path / "probe").put_trip(make_trip("manual", seed=0)).size_bytes
    spool = Spool(tmp_path / "s", quota_bytes=int(size * 3.5))  # room for three batches
    takeover = spool.put_trip(make_trip("takeover", seed=1))
    manual_old = spool.put_trip(make_trip("manual", seed=2))
    acc = spool.put_trip(make_trip("acc", seed=3))
    newest = spool.put_trip(make_trip("takeover", seed=4))  # over quota: oldest manual goes
    assert manual_old not in spool.pending()
    assert spool.pending() == [takeover, acc, newest]
    spool.put_trip(make_trip("takeover", seed=5))  # then the ACC trip, takeovers last
    assert acc not in spool.pending() and takeover in spool.pending()
    assert spool.stats.evicted == {"manual": 1, "acc": 1}
    assert spool.size_bytes() <= spool.quota_bytes
    assert EVICTION_ORDER[-1] == "takeover"


def test_a_batch_larger_than_the_quota_is_refused(tmp_path: Path) -> None:
    spool = Spool(tmp_path, quota_bytes=100)
    with pytest.raises(SpoolError, match="exceeds the whole quota"):
        spool.put_trip(make_trip("takeover"))
    assert spool.pending() == [] and list((tmp_path / ".incoming").iterdir()) == []


def test_a_file_that_is_not_a_trip_log_is_refused(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file")
    spool = Spool(tmp_path / "s")
    with pytest.raises(SpoolError, match=r"not spooled: .*junk\.mcap"):
        spool.put_file(junk)
    assert spool.pending() == []


def test_bad_settings_are_refused(tmp_path: Path) -> None:
    with pytest.raises(SpoolError, match="quota_bytes"):
        Spool(tmp_path, quota_bytes=0)
    (tmp_path / "file").write_text("x")
    with pytest.raises(SpoolError, match="cannot create spool"):
        Spool(tmp_path / "file" / "spool")


def writer(spool_dir: Path, first_seed: int) -> None:
    """The child: spool 400-sample takeover batches, one after the other, forever."""
    spool = Spool(spool_dir)
    seed = first_seed
    while True:
        spool.put_trip(make_trip("takeover", n=400, seed=seed))
        seed += 1


@pytest.mark.slow
def test_sigkill_at_random_points_leaves_only_whole_batches(tmp_path: Path) -> None:
    """A writer (a forked child) killed at 40 random instants: after each, every batch under
    a final name reads back and matches its digest, and reopening clears the half-written."""
    rng = random.Random(8)
    spool_dir = tmp_path / "spool"
    Spool(tmp_path / "warm-up").put_trip(make_trip("takeover", n=400))  # lazy imports, now
    seen: set[str] = set()
    for kill in range(SPOOL_KILLS):
        pid = os.fork()
        if pid == 0:  # pragma: no cover - the child only ever dies by SIGKILL
            try:
                writer(spool_dir, kill * 1000)
            finally:
                os._exit(1)
        if kill % 4 == 0:  # every fourth kill lands after a commit whatever the machine's load
            before = len(list(spool_dir.glob("*.mcap")))
            deadline = time.monotonic() + 20.0
            while len(list(spool_dir.glob("*.mcap"))) <= before and time.monotonic() < deadline:
                time.sleep(0.005)
        time.sleep(rng.uniform(0.0, 0.15))
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        spool = Spool(spool_dir)  # opening checks every digest
        for batch in spool.pending():
            if batch.digest not in seen:  # the new ones also read back whole
                assert len(read_trip(batch.path)) == 400
                seen.add(batch.digest)
        assert spool.stats.quarantined == 0
        assert list((spool_dir / ".incoming").iterdir()) == []
    assert len(Spool(spool_dir).pending()) > SPOOL_KILLS // 4  # more than the waited-for ones
