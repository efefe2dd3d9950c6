"""Checks of an upload before the cloud keeps it: a pacc trip log of a known kind, no larger than
:data:`MAX_DECOMPRESSED_BYTES` decompressed (:func:`check_chunks` reads the MCAP chunk sizes
without decompressing), with plausible samples (:func:`cloud_sync.api.check_plausible`); a
failure of the cloud's own storage becomes a retryable answer (:func:`storage_errors`).
"""

from __future__ import annotations

import contextlib
import errno
import io
import sqlite3
from collections.abc import Iterator

from cloud_sync.api import BadBatchError, CloudUnavailableError, check_plausible
from dbc.vocab.triplog import Trip, TripLogError, trip_mode
from dbc.vocab.triplog_file import trip_from_bytes
from dbc.vocab.tripmode import TripMode, TripModeError

#: the most a batch may decompress to, bytes (a 2-hour trip is about 15 MB of samples)
MAX_DECOMPRESSED_BYTES = 64 * 1024 * 1024


class StorageFullError(CloudUnavailableError):
    """The cloud's disk is full: nothing stored; the vehicle keeps the batch and retries."""

    status = 507


@contextlib.contextmanager
def storage_errors() -> Iterator[None]:
    """An OS or SQLite failure of the cloud's own storage becomes a retryable answer (507 for
    a full disk, else 503), never a 500 and never a batch the vehicle drops."""
    try:
        yield
    except (OSError, sqlite3.OperationalError) as exc:
        if isinstance(exc, OSError):
            full, what = (
                exc.errno in (errno.ENOSPC, errno.EDQUOT),
                f"storage failed: {exc.strerror or exc}",
            )
        else:
            full, what = "full" in str(exc), f"index failed: {exc}"
        if full:
            raise StorageFullError(
                "the cloud's disk is full: batch not stored, retry later"
            ) from exc
        raise CloudUnavailableError(f"the cloud's {what}") from exc


def parse_batch(data: bytes) -> tuple[Trip, TripMode]:
    """The checked trip of an upload and its kind; BadBatchError (422) for anything else."""
    check_chunks(data)
    try:
        trip = trip_from_bytes(data, "uploaded trip log")
        mode = trip_mode(trip)
    except (TripLogError, TripModeError) as exc:
        raise BadBatchError(f"not a pacc trip log: {exc}") from exc
    check_plausible(trip)
    return trip, mode


def check_chunks(data: bytes) -> None:
    """Refuse MCAP bytes that would decompress past :data:`MAX_DECOMPRESSED_BYTES`, read
    without decompressing (a file that is not MCAP is left to the trip-log reader)."""
    # mcap and zstandard cost start-up; only an upload needs them
    import zstandard  # noqa: PLC0415
    from mcap.records import Chunk  # noqa: PLC0415
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    total = 0
    try:
        for record in StreamReader(io.BytesIO(data), emit_chunks=True).records:
            if not isinstance(record, Chunk):
                continue
            size = record.uncompressed_size
            if record.compression == "zstd":
                with contextlib.suppress(zstandard.ZstdError):  # no size in the frame
                    size = max(size, zstandard.frame_content_size(record.data))
            elif record.compression:
                raise BadBatchError(
                    f"not a pacc trip log: {record.compression!r} chunks (zstd or none)"
                )
            total += size
            if total > MAX_DECOMPRESSED_BYTES:
                raise BadBatchError(
                    f"the trip log decompresses to more than {MAX_DECOMPRESSED_BYTES} bytes"
                )
    except BadBatchError:
        raise
    except Exception:  # noqa: BLE001, S110 - damaged MCAP: the reader names the cause
        pass
