"""The trip-log file format: a :class:`dbc.vocab.triplog.Trip` as an MCAP file.

An MCAP file with JSON schema-encoded messages:

- topic ``/pacc/car_following``, schema ``pacc.CarFollowingSample``: one message per sample
  ``{"t_s", "v_mps", "gap_m", "v_lead_mps", "a_mps2", "accel_pedal", "brake_pedal",
  "acc_state"}``; a missing value (NaN) is written as ``null``;
- topic ``/pacc/trip_meta``, schema ``pacc.TripMeta``: one message, the ``meta`` dict.

Each message's MCAP ``log_time`` is UTC when ``meta["start_utc"]`` (ISO 8601, the UTC of the
first sample) is given: that instant plus the sample's offset from the first sample. Without
it ``t_s`` itself is the log time (trips whose clock is not the wall clock and that must stay
byte-identical run to run, such as the simulator's manual trips).

On bytes (:func:`trip_to_bytes`, :func:`trip_from_bytes`) and binary streams
(:func:`write_trip_to`, :func:`read_trip_from`); :func:`write_trip` (atomic) and
:func:`read_trip` are thin path wrappers. Reading is sequential, checks the CRCs and requires
the MCAP footer, so a truncated or corrupted log is refused with :class:`TripLogError` naming
the file (or the given name) and the cause, never read in part.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

import numpy as np

from dbc.vocab.acc_state import AccState
from dbc.vocab.mcap_errors import mcap_errors
from dbc.vocab.triplog import FLOAT_FIELDS, Trip, TripLogError

__all__ = [
    "META_TOPIC",
    "SAMPLE_TOPIC",
    "read_trip",
    "read_trip_from",
    "trip_from_bytes",
    "trip_to_bytes",
    "write_trip",
    "write_trip_to",
]

SAMPLE_TOPIC = "/pacc/car_following"
META_TOPIC = "/pacc/trip_meta"
SAMPLE_SCHEMA_NAME = "pacc.CarFollowingSample"
META_SCHEMA_NAME = "pacc.TripMeta"
PROFILE = "pacc.trip/1"


#: the largest AccState code (FAULT)
_ACC_STATE_MAX = int(max(AccState))

_NUM = {"type": ["number", "null"]}
SAMPLE_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": SAMPLE_SCHEMA_NAME,
    "description": "One car-following sample: SI units, pedals 0..1, acc_state an AccState code",
    "type": "object",
    "properties": {
        "t_s": {"type": "number"},
        "v_mps": _NUM,
        "gap_m": _NUM,
        "v_lead_mps": _NUM,
        "a_mps2": _NUM,
        "accel_pedal": _NUM,
        "brake_pedal": _NUM,
        "acc_state": {"type": "integer", "minimum": 0, "maximum": _ACC_STATE_MAX},
    },
    "required": [*FLOAT_FIELDS, "acc_state"],
}
META_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": META_SCHEMA_NAME,
    "description": "Trip metadata: driver_id, condition, mode (manual|acc|takeover), seed",
    "type": "object",
}


def _num(x: float) -> float | None:
    return None if math.isnan(x) else float(x)


def _unnum(x: Any, where: str) -> float:
    if x is None:
        return math.nan
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise TripLogError(f"{where}: expected a number or null, got {x!r}")
    return float(x)


def _compression() -> Any:
    # mcap costs ~0.1 s of start-up; only writing and reading a trip need it
    from mcap.writer import CompressionType  # noqa: PLC0415

    try:
        import zstandard  # noqa: F401, PLC0415 - a probe: is the optional codec installed?
    except ImportError:  # pragma: no cover - zstandard ships with mcap
        return CompressionType.NONE
    return CompressionType.ZSTD


def write_trip(path: str | os.PathLike[str], trip: Trip) -> None:
    """Write ``trip`` to ``path`` as an MCAP file (:func:`trip_to_bytes`, see the module
    docstring for the layout).

    The file is written to a temporary name and renamed, so a crash never leaves a partial log
    under ``path`` (and a failed write removes the temporary file). Raises
    :class:`TripLogError` if ``meta`` is not JSON-serialisable, OSError if ``path`` cannot be
    written.
    """
    path = Path(path)
    data = trip_to_bytes(trip)
    tmp = path.with_name(path.name + ".part")
    try:
        tmp.write_bytes(data)
        tmp.replace(path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink(missing_ok=True)  # no partial file left beside the destination
        raise


def trip_to_bytes(trip: Trip) -> bytes:
    """The MCAP bytes of ``trip`` (:class:`TripLogError` if ``meta`` is not JSON-serialisable)."""
    stream = io.BytesIO()
    write_trip_to(stream, trip)
    return stream.getvalue()


def write_trip_to(stream: IO[bytes], trip: Trip) -> None:
    """Write ``trip`` as MCAP to a binary ``stream`` (the caller owns and closes it)."""
    try:
        meta_bytes = json.dumps(trip.meta, sort_keys=True, allow_nan=False).encode()
    except (TypeError, ValueError) as exc:
        raise TripLogError(f"Trip.meta is not JSON-serialisable: {exc}") from exc
    _write_mcap(stream, trip, meta_bytes)


def _write_mcap(stream: IO[bytes], trip: Trip, meta_bytes: bytes) -> None:
    from mcap.writer import Writer  # noqa: PLC0415 - see _compression

    columns = [getattr(trip, k).tolist() for k in FLOAT_FIELDS]
    states = trip.acc_state.tolist()
    writer = Writer(stream, compression=_compression())
    writer.start(profile=PROFILE, library="pacc.cloud_sync")
    sample_schema = writer.register_schema(
        SAMPLE_SCHEMA_NAME, "jsonschema", json.dumps(SAMPLE_SCHEMA).encode()
    )
    meta_schema = writer.register_schema(
        META_SCHEMA_NAME, "jsonschema", json.dumps(META_SCHEMA).encode()
    )
    sample_ch = writer.register_channel(SAMPLE_TOPIC, "json", sample_schema)
    meta_ch = writer.register_channel(META_TOPIC, "json", meta_schema)
    origin_ns, t_first = _stamp_origin(trip)
    t0_ns = max(origin_ns, 0)
    writer.add_message(meta_ch, t0_ns, meta_bytes, t0_ns)
    for i in range(len(trip)):
        row = {k: _num(col[i]) for k, col in zip(FLOAT_FIELDS, columns, strict=True)}
        row["acc_state"] = int(states[i])
        stamp = max(origin_ns + int(round((columns[0][i] - t_first) * 1e9)), 0)
        writer.add_message(sample_ch, stamp, json.dumps(row).encode(), stamp, sequence=i)
    writer.finish()  # type: ignore[no-untyped-call]


def _stamp_origin(trip: Trip) -> tuple[int, float]:
    """(log time of the first sample in ns, its ``t_s``): UTC from ``meta["start_utc"]``
    when given and valid, else ``t_s`` itself."""
    t_first = float(trip.t_s[0]) if len(trip) else 0.0
    start = trip.meta.get("start_utc")
    if isinstance(start, str):
        try:
            when = datetime.fromisoformat(start.replace("Z", "+00:00"))
        except ValueError:
            when = None
        if when is not None and when.tzinfo is not None:
            delta = when - datetime(1970, 1, 1, tzinfo=UTC)
            us = (delta.days * 86400 + delta.seconds) * 1_000_000 + delta.microseconds
            return us * 1000, t_first
    return int(round(t_first * 1e9)), t_first


def read_trip(path: str | os.PathLike[str]) -> Trip:
    """Read a trip written by :func:`write_trip`.

    Raises :class:`TripLogError` with the file name and the cause if the file is missing, not
    MCAP, truncated (no footer), has a bad CRC, or holds no ``/pacc/car_following`` channel.
    """
    path = Path(path)
    with mcap_errors(path, "trip log", TripLogError), path.open("rb") as stream:
        return read_trip_from(stream, str(path))


def trip_from_bytes(data: bytes, where: str = "trip log bytes") -> Trip:
    """Parse the MCAP bytes of a trip log (errors as :func:`read_trip`, naming ``where``)."""
    return read_trip_from(io.BytesIO(data), where)


def read_trip_from(stream: IO[bytes], where: str) -> Trip:
    """Read a trip log from a binary ``stream`` to its end; ``where`` names it in errors."""
    found = _scan(stream, where)
    if not found.footer:
        raise TripLogError(f"{where}: truncated trip log (no MCAP footer)")
    topics = {c.topic: c for c in found.channels.values()}
    if SAMPLE_TOPIC not in topics:
        raise TripLogError(
            f"{where}: not a pacc trip log (no {SAMPLE_TOPIC} channel; topics: "
            f"{sorted(topics) or 'none'})"
        )
    sch = found.schemas.get(topics[SAMPLE_TOPIC].schema_id)
    if sch is None or sch.name != SAMPLE_SCHEMA_NAME:
        raise TripLogError(f"{where}: {SAMPLE_TOPIC} does not use schema {SAMPLE_SCHEMA_NAME}")
    meta = found.meta
    if meta is not None and not isinstance(meta, dict):
        raise TripLogError(f"{where}: {META_TOPIC} message is not a JSON object")
    return _trip_from_rows(found.rows, meta or {}, where)


@dataclass
class _Records:
    """What one sequential pass over an MCAP file found."""

    schemas: dict[int, Any] = field(default_factory=dict)
    channels: dict[int, Any] = field(default_factory=dict)
    rows: list[dict[str, Any]] = field(default_factory=list)
    meta: Any = None
    footer: bool = False


def _scan(stream: IO[bytes], where: str) -> _Records:
    """Read ``stream`` record by record (CRCs checked); :class:`TripLogError` if unreadable."""
    # see _compression: mcap only when a trip is read
    from mcap import records  # noqa: PLC0415
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    found = _Records()
    with mcap_errors(where, "trip log", TripLogError):
        for record in StreamReader(stream, validate_crcs=True).records:
            _take(record, found, where, records)
    return found


def _take(record: Any, found: _Records, path: str, kinds: Any) -> None:
    """File one MCAP record into ``found`` (``kinds``: the ``mcap.records`` module)."""
    if isinstance(record, kinds.Schema):
        found.schemas[record.id] = record
    elif isinstance(record, kinds.Channel):
        found.channels[record.id] = record
    elif isinstance(record, kinds.Message):
        channel = found.channels.get(record.channel_id)
        if channel is None:
            raise TripLogError(f"{path}: message on unknown channel")
        if channel.topic == SAMPLE_TOPIC:
            found.rows.append(json.loads(record.data))
        elif channel.topic == META_TOPIC:
            found.meta = json.loads(record.data)
    elif isinstance(record, kinds.Footer):
        found.footer = True


def _trip_from_rows(rows: list[dict[str, Any]], meta: dict[str, Any], where: str) -> Trip:
    cols: dict[str, list[float]] = {k: [] for k in FLOAT_FIELDS}
    states: list[int] = []
    for i, row in enumerate(rows):
        if not isinstance(row, dict):
            raise TripLogError(f"{where}: sample {i} is not a JSON object")
        try:
            for k in FLOAT_FIELDS:
                cols[k].append(_unnum(row[k], f"{where}: sample {i} field {k}"))
            state = row["acc_state"]
        except KeyError as exc:
            raise TripLogError(f"{where}: sample {i} lacks field {exc.args[0]!r}") from exc
        if isinstance(state, bool) or not isinstance(state, int):
            raise TripLogError(f"{where}: sample {i} acc_state is not an integer")
        states.append(state)
    try:
        arrays = {k: np.asarray(v, dtype=np.float64) for k, v in cols.items()}
        return Trip(**arrays, acc_state=np.asarray(states, dtype=np.int64), meta=meta)
    except TripLogError as exc:
        raise TripLogError(f"{where}: {exc}") from exc
