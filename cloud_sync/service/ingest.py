"""Checks of an upload before the cloud keeps it: the bytes must be a pacc trip log of a known
kind whose samples a car could have recorded, and a failure of the cloud's own storage becomes
a retryable answer, never a lost batch.

- **Size before decompressing** (:func:`check_chunks`): the MCAP chunks are read without
  decompressing them; their declared sizes together, and each zstd frame's own content size,
  must stay within :data:`MAX_DECOMPRESSED_BYTES`, and only zstd or uncompressed chunks are read
  (a 17 KB zstd bomb must not become 512 MiB of memory).
- **Plausible samples** (:func:`check_plausible`), as the vehicle's adaptation filter refuses
  non-finite or negative speeds and gaps: 1 to :data:`MAX_SAMPLES` samples, times within
  ±:data:`MAX_T_S`, every value finite or missing (NaN), speeds 0..:data:`MAX_SPEED_MPS`, gaps
  :data:`MIN_GAP_M`..:data:`MAX_GAP_M`, accelerations within ±:data:`MAX_ACCEL_MPS2`.
"""

from __future__ import annotations

import contextlib
import errno
import io
import sqlite3
from collections.abc import Iterator

import numpy as np

from cloud_sync.api import BadBatchError, CloudUnavailableError
from dbc.vocab.triplog import Trip, TripLogError, trip_mode
from dbc.vocab.triplog_file import trip_from_bytes
from dbc.vocab.tripmode import TripMode, TripModeError

__all__ = [
    "MAX_DECOMPRESSED_BYTES",
    "MAX_SAMPLES",
    "StorageFullError",
    "check_chunks",
    "check_plausible",
    "parse_batch",
    "storage_errors",
]

#: the most a batch may decompress to, bytes (a 2-hour trip is about 15 MB of samples)
MAX_DECOMPRESSED_BYTES = 64 * 1024 * 1024
#: the most samples of one batch: 2 hours at the trip logs' 10 Hz
MAX_SAMPLES = 72_000
#: sample times, s: within ±MAX_T_S (an MCAP log time, ns in 64 bits, holds ±292 years)
MAX_T_S = 1e9
#: the fastest plausible speed, m/s (360 km/h)
MAX_SPEED_MPS = 100.0
#: the gap range, m: a collision's last sample may be a little negative
MIN_GAP_M, MAX_GAP_M = -10.0, 1000.0
#: the largest plausible acceleration magnitude, m/s² (about 2 g)
MAX_ACCEL_MPS2 = 20.0


class StorageFullError(CloudUnavailableError):
    """The cloud's disk is full: nothing stored; the vehicle keeps the batch and retries."""

    status = 507


@contextlib.contextmanager
def storage_errors() -> Iterator[None]:
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


def check_plausible(trip: Trip) -> None:
    """Refuse a trip whose samples no car recorded (module docstring); BadBatchError."""
    n = len(trip)
    if not 1 <= n <= MAX_SAMPLES:
        raise BadBatchError(f"a batch holds 1 to {MAX_SAMPLES} samples, this one {n}")
    ranges = {
        "t_s": (-MAX_T_S, MAX_T_S),
        "v_mps": (0.0, MAX_SPEED_MPS),
        "v_lead_mps": (0.0, MAX_SPEED_MPS),
        "gap_m": (MIN_GAP_M, MAX_GAP_M),
        "a_mps2": (-MAX_ACCEL_MPS2, MAX_ACCEL_MPS2),
    }
    for name, (lo, hi) in ranges.items():
        column = getattr(trip, name)
        known = column[~np.isnan(column)]
        if known.size and not (known.min() >= lo and known.max() <= hi):
            bad = known[(known < lo) | (known > hi)][0]
            raise BadBatchError(
                f"implausible trip log: {name} = {bad:g} outside {lo:g}..{hi:g} "
                "(finite values or null only)"
            )
