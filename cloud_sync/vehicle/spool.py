"""The vehicle's spool: trip logs waiting for the cloud, crash-safe, inside a size quota.

Each batch is one MCAP trip log ``<seq>-<kind>-<sha256>.mcap`` (kind ``takeover``, ``manual``
or ``acc``; the digest is the upload's idempotency key), written under ``.incoming/``, fsynced
and renamed (whole or absent after a crash). A batch leaves on the cloud's ack, by quota
eviction (manual first, then acc, takeovers last; never the one just added) or to
``rejected/`` with the reason; a file whose bytes no longer match its digest goes to
``quarantine/``.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import re
import threading
import uuid
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from cloud_sync.api import BadBatchError, check_plausible
from cloud_sync.durable import set_aside
from cloud_sync.errors import CloudSyncError
from dbc.atomic import fsync_dir
from dbc.vocab.triplog import Trip, TripLogError, trip_mode
from dbc.vocab.triplog_file import read_trip, write_trip
from dbc.vocab.tripmode import TripModeError

log = logging.getLogger(__name__)

#: a batch's kind: its trip mode's value (:func:`dbc.vocab.triplog.trip_mode`)
BatchKind = Literal["takeover", "manual", "acc"]
#: eviction order under the quota: first kind first
EVICTION_ORDER: tuple[BatchKind, ...] = ("manual", "acc", "takeover")
#: default quota, bytes (a takeover segment is ~10-30 kB, a 10-min manual trip ~0.3 MB)
DEFAULT_QUOTA_BYTES = 256 * 1024 * 1024

_NAME = re.compile(
    r"^(?P<seq>\d{12})-(?P<kind>takeover|manual|acc)-(?P<digest>[0-9a-f]{64})\.mcap$"
)
_INCOMING = ".incoming"
_QUARANTINE = "quarantine"
_CHUNK = 1 << 20


class SpoolError(CloudSyncError):
    """The spool cannot take a batch (too large for the quota, unreadable trip, full disk)."""


@dataclass(frozen=True, order=True)
class Batch:
    """One spooled trip log. Ordered by ``seq`` (oldest first)."""

    seq: int
    kind: BatchKind
    digest: str
    size_bytes: int
    path: Path = field(compare=False)


@dataclass
class SpoolStats:
    """What the spool did since it was opened (counts)."""

    added: Counter[str] = field(default_factory=Counter)
    acked: int = 0
    evicted: Counter[str] = field(default_factory=Counter)
    partials_removed: int = 0
    quarantined: int = 0
    rejected: int = 0


def file_digest(path: Path) -> str:
    """SHA-256 of the file's bytes, hex."""
    sha = hashlib.sha256()
    with path.open("rb") as stream:
        while chunk := stream.read(_CHUNK):
            sha.update(chunk)
    return sha.hexdigest()


class Spool:
    """The spool folder ``root`` (created if missing), its batches within ``quota_bytes``.
    Thread-safe; one writing process per folder."""

    def __init__(self, root: str | os.PathLike[str], *, quota_bytes: int = DEFAULT_QUOTA_BYTES):
        if quota_bytes <= 0:
            raise SpoolError(f"quota_bytes must be > 0, got {quota_bytes}")
        self.root = Path(root)
        self.quota_bytes = quota_bytes
        self.stats = SpoolStats()
        self._lock = threading.Lock()
        try:
            (self.root / _INCOMING).mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise SpoolError(f"cannot create spool {self.root}: {exc.strerror or exc}") from exc
        self._batches: dict[str, Batch] = {}
        self._recover()
        self._next_seq = max((b.seq for b in self._batches.values()), default=0) + 1

    # -- opening -------------------------------------------------------------------------

    def _recover(self) -> None:
        """Remove half-written files, index the batches, quarantine any whose digest is off."""
        for part in (self.root / _INCOMING).iterdir():
            with contextlib.suppress(OSError):
                part.unlink()
                self.stats.partials_removed += 1
        for path in sorted(self.root.glob("*.mcap")):
            match = _NAME.match(path.name)
            if match is None or file_digest(path) != match["digest"]:
                (self.root / _QUARANTINE).mkdir(exist_ok=True)
                path.replace(self.root / _QUARANTINE / path.name)
                self.stats.quarantined += 1
                log.warning("spool: %s does not match its name's digest, quarantined", path.name)
                continue
            batch = Batch(
                seq=int(match["seq"]),
                kind=match["kind"],  # type: ignore[arg-type]  # the regex admits only BatchKind
                digest=match["digest"],
                size_bytes=path.stat().st_size,
                path=path,
            )
            self._batches.setdefault(batch.digest, batch)

    # -- adding --------------------------------------------------------------------------

    def put_trip(self, trip: Trip, kind: BatchKind | None = None) -> Batch:
        """Spool ``trip`` as one batch (kind from its mode unless given; the same bytes
        again: the batch spooled). SpoolError: not written, unknown mode, over the quota."""
        try:
            kind = kind or trip_mode(trip).value
        except TripModeError as exc:
            raise SpoolError(f"spool {self.root}: not spooled: {exc}") from exc
        incoming = self.root / _INCOMING / f"{uuid.uuid4().hex}.mcap"
        try:
            write_trip(incoming, trip)
        except (OSError, TripLogError) as exc:
            with contextlib.suppress(OSError):
                incoming.unlink(missing_ok=True)
            raise SpoolError(f"spool {self.root}: cannot write the trip: {exc}") from exc
        return self._admit(incoming, kind)

    def put_file(self, source: str | os.PathLike[str], kind: BatchKind | None = None) -> Batch:
        """Spool a copy of an MCAP trip log; SpoolError if it is not a readable pacc trip
        log, holds implausible samples (:func:`cloud_sync.api.check_plausible`) or is too large."""
        try:
            trip = read_trip(source)
        except TripLogError as exc:
            raise SpoolError(f"not spooled: {exc}") from exc
        try:
            check_plausible(trip)
        except BadBatchError as exc:
            raise SpoolError(f"not spooled: {source}: {exc}") from exc
        return self.put_trip(trip, kind)

    def _admit(self, incoming: Path, kind: BatchKind) -> Batch:
        """fsync ``incoming``, rename it into the spool under its digest, enforce the quota."""
        try:
            with incoming.open("rb+") as stream:
                os.fsync(stream.fileno())
            size = incoming.stat().st_size
            if size > self.quota_bytes:
                incoming.unlink()
                raise SpoolError(
                    f"spool {self.root}: a {size}-byte batch exceeds the whole quota "
                    f"({self.quota_bytes} bytes)"
                )
            digest = file_digest(incoming)
            with self._lock:
                known = self._batches.get(digest)
                if known is not None:
                    incoming.unlink()
                    return known
                seq = self._next_seq
                self._next_seq += 1
                final = self.root / f"{seq:012d}-{kind}-{digest}.mcap"
                incoming.replace(final)
                fsync_dir(self.root)
                batch = Batch(seq=seq, kind=kind, digest=digest, size_bytes=size, path=final)
                self._batches[digest] = batch
                self.stats.added[kind] += 1
                self._enforce_quota(keep=batch)
                return batch
        except OSError as exc:
            with contextlib.suppress(OSError):
                incoming.unlink(missing_ok=True)
            raise SpoolError(f"spool {self.root}: {exc.strerror or exc}") from exc

    def _enforce_quota(self, keep: Batch) -> None:
        """Evict batches (policy in the module docstring) until the total fits the quota."""
        total = sum(b.size_bytes for b in self._batches.values())
        if total <= self.quota_bytes:
            return
        rank = {kind: i for i, kind in enumerate(EVICTION_ORDER)}
        victims = sorted(
            (b for b in self._batches.values() if b is not keep),
            key=lambda b: (rank[b.kind], b.seq),
        )
        for victim in victims:
            if total <= self.quota_bytes:
                break
            self._remove(victim)
            total -= victim.size_bytes
            self.stats.evicted[victim.kind] += 1
            log.warning(
                "spool quota %d B: evicted %s batch %d", self.quota_bytes, victim.kind, victim.seq
            )

    def _remove(self, batch: Batch) -> None:
        with contextlib.suppress(FileNotFoundError):
            batch.path.unlink()
        fsync_dir(self.root)
        del self._batches[batch.digest]

    # -- draining ------------------------------------------------------------------------

    def pending(self) -> list[Batch]:
        """The batches not yet acknowledged, oldest first."""
        with self._lock:
            return sorted(self._batches.values())

    def size_bytes(self) -> int:
        """Bytes the pending batches occupy."""
        with self._lock:
            return sum(b.size_bytes for b in self._batches.values())

    def reject(self, digest: str, reason: str) -> bool:
        """The cloud refused batch ``digest`` for good: set it aside in ``rejected/`` with
        the reason. False if no such batch is pending."""
        with self._lock:
            batch = self._batches.get(digest)
            if batch is None:
                return False
            set_aside(batch.path, reason)
            del self._batches[digest]
            self.stats.rejected += 1
            log.error(
                "spool: batch %d (%s) rejected by the cloud: %s", batch.seq, batch.kind, reason
            )
            return True

    def ack(self, digest: str) -> bool:
        """The cloud holds batch ``digest``: delete it. False if no such batch is pending."""
        with self._lock:
            batch = self._batches.get(digest)
            if batch is None:
                return False
            self._remove(batch)
            self.stats.acked += 1
            return True
