"""The cloud's storage: an SQLite index and content-addressed files under one data folder.

Layout: ``index.sqlite`` (vehicles, drivers, batches, DGPT versions, trip reports; WAL;
``user_version`` = :data:`SCHEMA_VERSION`), ``blobs/<d[:2]>/<digest>.mcap`` (uploaded batches
by SHA-256), ``dgpt/<driver>/<condition>/v<version>.json`` (every signed version, never
overwritten), ``keys/cloud.key|.pub``. A file is written, fsynced and renamed before its row is
committed; ``.<name>.part`` leftovers are removed at open; an older schema is migrated by adding
tables only. One connection behind a lock; one process per folder.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import astuple, dataclass
from pathlib import Path
from typing import Any

from cloud_sync.errors import CloudSyncError
from dbc.atomic import write_bytes_atomic

SCHEMA = """
CREATE TABLE IF NOT EXISTS vehicles (
    vehicle_id TEXT PRIMARY KEY,
    token_sha256 TEXT NOT NULL UNIQUE
);
CREATE TABLE IF NOT EXISTS drivers (
    driver_id TEXT PRIMARY KEY,
    vehicle_id TEXT NOT NULL REFERENCES vehicles(vehicle_id)
);
CREATE TABLE IF NOT EXISTS batches (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    digest TEXT NOT NULL UNIQUE,
    vehicle_id TEXT NOT NULL,
    driver_id TEXT NOT NULL,
    condition TEXT NOT NULL,
    kind TEXT NOT NULL,
    size_bytes INTEGER NOT NULL,
    received_utc TEXT NOT NULL,
    used_in_version INTEGER
);
CREATE INDEX IF NOT EXISTS batches_by_driver ON batches(driver_id, condition, used_in_version);
CREATE TABLE IF NOT EXISTS dgpt_versions (
    driver_id TEXT NOT NULL,
    condition TEXT NOT NULL,
    version INTEGER NOT NULL,
    source TEXT NOT NULL,
    created_utc TEXT NOT NULL,
    n_batches INTEGER NOT NULL,
    PRIMARY KEY (driver_id, condition, version)
);
CREATE TABLE IF NOT EXISTS trips (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    vehicle_id TEXT NOT NULL,
    driver_id TEXT NOT NULL,
    condition TEXT NOT NULL,
    trip_id TEXT NOT NULL,
    start_utc TEXT,
    received_utc TEXT NOT NULL,
    dgpt_version INTEGER NOT NULL,
    acc_on_s REAL NOT NULL,
    intervention_s REAL NOT NULL,
    takeovers INTEGER NOT NULL,
    report TEXT NOT NULL,
    UNIQUE (driver_id, trip_id)
);
CREATE TABLE IF NOT EXISTS trip_segments (
    digest TEXT PRIMARY KEY,
    trip_seq INTEGER NOT NULL REFERENCES trips(seq)
);
"""
#: the index's schema version (``PRAGMA user_version``; 0, unset, was the first schema,
#: before the trip reports); an index of a newer schema is refused
SCHEMA_VERSION = 2


class StoreError(CloudSyncError):
    """The cloud's data folder cannot be opened or written."""


@dataclass(frozen=True)
class BatchRow:
    """One stored batch (a trip log) and what it was used for."""

    seq: int
    digest: str
    vehicle_id: str
    driver_id: str
    condition: str
    kind: str
    size_bytes: int
    received_utc: str
    used_in_version: int | None


@dataclass(frozen=True)
class VersionRow:
    """One published DGPT version."""

    driver_id: str
    condition: str
    version: int
    source: str
    created_utc: str
    n_batches: int


class CloudStore:
    """The data folder of one cloud (see the module docstring)."""

    def __init__(self, data_dir: str | os.PathLike[str]) -> None:
        self.root = Path(data_dir)
        self._lock = threading.RLock()
        try:
            self.root.mkdir(parents=True, exist_ok=True)
            self._db = sqlite3.connect(
                self.root / "index.sqlite", check_same_thread=False, isolation_level=None
            )
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA foreign_keys=ON")
            self._migrate()
        except (OSError, sqlite3.Error) as exc:
            raise StoreError(f"cannot open the cloud data folder {self.root}: {exc}") from exc
        #: temporary files of a killed process (``.*.part``: no row points at them) removed
        self.orphans_removed = 0
        for part in [*self.root.glob("blobs/**/.*.part"), *self.root.glob("dgpt/**/.*.part")]:
            with contextlib.suppress(OSError):
                part.unlink()
                self.orphans_removed += 1

    def _migrate(self) -> None:
        """Create the tables of a new index, or add those an older one lacks (one
        transaction: a crash leaves the old index as it was)."""
        (old,) = self._db.execute("PRAGMA user_version").fetchone()
        if old > SCHEMA_VERSION:
            self._db.close()
            raise StoreError(f"index schema {old} is newer than this pacc's ({SCHEMA_VERSION})")
        if old == SCHEMA_VERSION:
            return
        with self.transaction() as db:
            for statement in SCHEMA.split(";"):
                db.execute(statement)
            db.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Connection]:
        """An immediate transaction on the index, under the store's lock (committed when the
        block ends, rolled back if it raises)."""
        with self._lock:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                yield self._db
            except BaseException:
                self._db.execute("ROLLBACK")
                raise
            self._db.execute("COMMIT")

    def query(self, sql: str, args: tuple[object, ...] = ()) -> list[tuple[Any, ...]]:
        """The rows of a read-only ``sql`` on the index, under the store's lock."""
        with self._lock:
            return list(self._db.execute(sql, args).fetchall())

    def close(self) -> None:
        """Close the index."""
        with self._lock:
            self._db.close()

    # -- vehicles and drivers -----------------------------------------------------------

    def save_vehicle(
        self,
        vehicle_id: str,
        token_sha256: str | None,
        drivers: list[str],
        before_commit: Callable[[], None] | None = None,
        *,
        new: bool = False,
    ) -> None:
        """Register (``new``) or update a vehicle in one transaction: its token's SHA-256 (None:
        kept; the old token stops working), ``drivers`` added, ``before_commit`` inside it (all
        or nothing). StoreError: the vehicle exists (``new``) or is unknown, a driver is taken."""
        with self.transaction() as db:
            known = db.execute("SELECT 1 FROM vehicles WHERE vehicle_id = ?", (vehicle_id,))
            if new and known.fetchone():
                raise StoreError(
                    f"vehicle {vehicle_id!r} is already registered (pacc cloud vehicle adds "
                    "drivers and reissues or revokes its token)"
                )
            if new:
                db.execute("INSERT INTO vehicles VALUES (?, ?)", (vehicle_id, token_sha256))
            elif not known.fetchone():
                raise StoreError(f"no vehicle {vehicle_id!r} (pacc cloud register adds one)")
            elif token_sha256 is not None:
                db.execute(
                    "UPDATE vehicles SET token_sha256 = ? WHERE vehicle_id = ?",
                    (token_sha256, vehicle_id),
                )
            for driver_id in drivers:
                row = db.execute(
                    "SELECT vehicle_id FROM drivers WHERE driver_id = ?", (driver_id,)
                ).fetchone()
                if row is not None:
                    raise StoreError(
                        f"driver {driver_id!r} is already registered to vehicle {row[0]!r}"
                    )
                db.execute("INSERT INTO drivers VALUES (?, ?)", (driver_id, vehicle_id))
            if before_commit is not None:
                before_commit()

    def vehicle_by_token(self, token_sha256: str) -> str | None:
        """The vehicle whose token hashes to ``token_sha256``, or None."""
        rows = self.query("SELECT vehicle_id FROM vehicles WHERE token_sha256 = ?", (token_sha256,))
        return str(rows[0][0]) if rows else None

    def driver_vehicle(self, driver_id: str) -> str | None:
        """The vehicle ``driver_id`` is registered to, or None."""
        rows = self.query("SELECT vehicle_id FROM drivers WHERE driver_id = ?", (driver_id,))
        return str(rows[0][0]) if rows else None

    # -- batches ------------------------------------------------------------------------

    def blob_path(self, digest: str) -> Path:
        """Where batch ``digest`` is stored."""
        return self.root / "blobs" / digest[:2] / f"{digest}.mcap"

    def add_batch(self, row: BatchRow, data: bytes) -> bool:
        """Store a batch's bytes and its row; False (nothing changed) if already stored."""
        with self._lock:
            if self.query("SELECT 1 FROM batches WHERE digest = ?", (row.digest,)):
                if not self.blob_path(row.digest).is_file():  # lost after its row: heal it
                    write_bytes_atomic(self.blob_path(row.digest), data, durable=True)
                return False
            write_bytes_atomic(self.blob_path(row.digest), data, durable=True)
            with self.transaction() as db:
                db.execute(
                    "INSERT INTO batches (digest, vehicle_id, driver_id, condition, kind, "
                    "size_bytes, received_utc) VALUES (?, ?, ?, ?, ?, ?, ?)",
                    astuple(row)[1:8],  # digest ... received_utc
                )
            return True

    def batches(
        self, driver_id: str, condition: str, *, unused_only: bool = False
    ) -> list[BatchRow]:
        """The driver's batches under ``condition`` in arrival order."""
        sql = "SELECT * FROM batches WHERE driver_id = ? AND condition = ?"
        if unused_only:
            sql += " AND used_in_version IS NULL"
        return [BatchRow(*r) for r in self.query(sql + " ORDER BY seq", (driver_id, condition))]

    def unused_keys(self) -> list[tuple[str, str]]:
        """(driver, condition) pairs with batches no version was learned from yet."""
        rows = self.query(
            "SELECT DISTINCT driver_id, condition FROM batches "
            "WHERE used_in_version IS NULL ORDER BY driver_id, condition"
        )
        return [(str(d), str(c)) for d, c in rows]

    def batch_count(self) -> int:
        """How many batches the cloud holds."""
        return int(self.query("SELECT COUNT(*) FROM batches")[0][0])

    def read_blob(self, digest: str) -> bytes:
        """The bytes of batch ``digest``."""
        return self.blob_path(digest).read_bytes()

    # -- DGPT versions ------------------------------------------------------------------

    def version_path(self, driver_id: str, condition: str, version: int) -> Path:
        """Where a signed DGPT version is stored (StoreError for a name that would leave
        the folder: the service admits only plain names, this is the second guard)."""
        base = (self.root / "dgpt").resolve()
        path = (base / driver_id / condition / f"v{version}.json").resolve()
        if not path.is_relative_to(base) or len(path.relative_to(base).parts) != 3:
            raise StoreError(f"DGPT name {driver_id!r}/{condition!r} is not a plain name")
        return path

    def add_version(self, row: VersionRow, signed: bytes, used: list[str]) -> None:
        """Publish a signed DGPT version and mark the batches ``used``; an existing version
        is refused (StoreError) before its file is touched."""
        final = self.version_path(row.driver_id, row.condition, row.version)
        try:
            with self.transaction() as db:
                db.execute(
                    "INSERT INTO dgpt_versions VALUES (?, ?, ?, ?, ?, ?)",
                    astuple(row),
                )
                db.executemany(
                    "UPDATE batches SET used_in_version = ? WHERE digest = ?",
                    [(row.version, d) for d in used],
                )
                write_bytes_atomic(final, signed, durable=True)  # no row without its file
        except sqlite3.IntegrityError as exc:
            raise StoreError(
                f"DGPT {row.driver_id}/{row.condition} v{row.version} exists already"
            ) from exc

    def versions(self, driver_id: str, condition: str) -> list[VersionRow]:
        """Every published version of the driver's table under ``condition``, oldest first."""
        rows = self.query(
            "SELECT * FROM dgpt_versions WHERE driver_id = ? AND condition = ? ORDER BY version",
            (driver_id, condition),
        )
        return [VersionRow(*r) for r in rows]

    def read_version(self, row: VersionRow) -> bytes:
        """The signed bytes of a published version."""
        return self.version_path(row.driver_id, row.condition, row.version).read_bytes()
