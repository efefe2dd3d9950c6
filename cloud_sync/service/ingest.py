"""Checks of an upload before the cloud keeps it: the bytes must be a pacc trip log of a known
kind, and a failure of the cloud's own storage becomes a retryable answer, never a lost batch.
"""

from __future__ import annotations

import contextlib
import errno
import sqlite3
from collections.abc import Iterator

from cloud_sync.api import BadBatchError, CloudUnavailableError
from cloud_sync.vehicle.spool import BatchKind, kind_of
from dbc.vocab.triplog import Trip, TripLogError
from dbc.vocab.triplog_file import trip_from_bytes
from dbc.vocab.tripmode import TripModeError


def _kind(trip: Trip) -> BatchKind:
    try:
        return kind_of(trip)
    except TripModeError as exc:
        raise BadBatchError(f"not a pacc trip log: {exc}") from exc


class StorageFullError(CloudUnavailableError):
    """The cloud's disk is full: nothing stored; the vehicle keeps the batch and retries."""

    status = 507


@contextlib.contextmanager
def _storage_errors() -> Iterator[None]:
    """An OS or SQLite failure of the cloud's own storage becomes a retryable answer (507 for
    a full disk, else 503), never a 500 and never a batch the vehicle drops."""
    try:
        yield
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EDQUOT):
            raise StorageFullError(
                "the cloud's disk is full: batch not stored, retry later"
            ) from exc
        raise CloudUnavailableError(f"the cloud's storage failed: {exc.strerror or exc}") from exc
    except sqlite3.OperationalError as exc:
        if "full" in str(exc):
            raise StorageFullError(
                "the cloud's disk is full: batch not stored, retry later"
            ) from exc
        raise CloudUnavailableError(f"the cloud's index failed: {exc}") from exc


def _parse_trip(data: bytes) -> Trip:
    try:
        return trip_from_bytes(data, "uploaded trip log")
    except TripLogError as exc:
        raise BadBatchError(f"not a pacc trip log: {exc}") from exc


__all__ = ["StorageFullError"]
