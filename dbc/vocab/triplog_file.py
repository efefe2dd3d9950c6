"""The trip-log file format: a :class:`dbc.vocab.triplog.Trip` as an MCAP file.

JSON messages: one ``/pacc/car_following`` (``pacc.CarFollowingSample``) per sample, NaN as
``null``, and one ``/pacc/trip_meta`` (``pacc.TripMeta``), the ``meta`` dict. Log times are
UTC (``meta["start_utc"]`` plus each sample's offset, ns) or, without it, ``t_s`` itself
(byte-identical run to run). Reading checks CRCs and requires the footer: a truncated or
corrupt log is refused with :class:`TripLogError` naming it, never read in part.
"""

from __future__ import annotations

import io
import json
import math
import os
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import IO, Any

import numpy as np

from dbc.atomic import write_bytes_atomic
from dbc.vocab.mcap_errors import mcap_errors
from dbc.vocab.triplog import ACC_STATE_MAX, FLOAT_FIELDS, Trip, TripLogError

SAMPLE_TOPIC = "/pacc/car_following"
META_TOPIC = "/pacc/trip_meta"
SAMPLE_SCHEMA_NAME = "pacc.CarFollowingSample"
META_SCHEMA_NAME = "pacc.TripMeta"
PROFILE = "pacc.trip/1"

_NUM = {"type": ["number", "null"]}
SAMPLE_SCHEMA: dict[str, Any] = {
    "$schema": "https://json-schema.org/draft/2020-12/schema",
    "title": SAMPLE_SCHEMA_NAME,
    "description": "One car-following sample: SI units, pedals 0..1, acc_state an AccState code",
    "type": "object",
    "properties": {
        "t_s": {"type": "number"},
        **dict.fromkeys(FLOAT_FIELDS[1:], _NUM),
        "acc_state": {"type": "integer", "minimum": 0, "maximum": ACC_STATE_MAX},
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


def write_trip(path: str | os.PathLike[str], trip: Trip) -> None:
    """Write ``trip`` to ``path`` as MCAP (:func:`trip_to_bytes`) atomically (:mod:`dbc.atomic`:
    a crash never leaves a partial log). OSError if ``path`` cannot be written."""
    write_bytes_atomic(path, trip_to_bytes(trip))


def trip_to_bytes(trip: Trip) -> bytes:
    """The MCAP bytes of ``trip`` (:class:`TripLogError` if ``meta`` is not JSON-serialisable)."""
    from mcap.writer import CompressionType, Writer  # noqa: PLC0415 - ~0.1 s of start-up

    try:
        meta_bytes = json.dumps(trip.meta, sort_keys=True, allow_nan=False).encode()
    except (TypeError, ValueError) as exc:
        raise TripLogError(f"Trip.meta is not JSON-serialisable: {exc}") from exc
    stream = io.BytesIO()
    columns = [getattr(trip, k).tolist() for k in FLOAT_FIELDS]
    states = trip.acc_state.tolist()
    writer = Writer(stream, compression=CompressionType.ZSTD)
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
    return stream.getvalue()


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
            us = (when - datetime(1970, 1, 1, tzinfo=UTC)) // timedelta(microseconds=1)
            return us * 1000, t_first
    return int(round(t_first * 1e9)), t_first


def read_trip(path: str | os.PathLike[str]) -> Trip:
    """Read a trip log file; :class:`TripLogError` names the file and the cause (missing, not
    MCAP, truncated, a bad CRC, no ``/pacc/car_following`` channel)."""
    path = Path(path)
    with mcap_errors(path, "trip log", TripLogError), path.open("rb") as stream:
        return _read(stream, str(path))


def trip_from_bytes(data: bytes, where: str = "trip log bytes") -> Trip:
    """Parse the MCAP bytes of a trip log (errors as :func:`read_trip`, naming ``where``)."""
    return _read(io.BytesIO(data), where)


def _read(stream: IO[bytes], where: str) -> Trip:
    """One sequential pass over the records (CRCs checked); the footer is required."""
    from mcap import records  # noqa: PLC0415 - mcap only when a trip is read
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    with mcap_errors(where, "trip log", TripLogError):
        found = list(StreamReader(stream, validate_crcs=True).records)
    schemas = {r.id: r for r in found if isinstance(r, records.Schema)}
    channels = {r.id: r for r in found if isinstance(r, records.Channel)}
    by_topic: dict[str, list[Any]] = {SAMPLE_TOPIC: [], META_TOPIC: []}
    for r in found:
        if isinstance(r, records.Message):
            if r.channel_id not in channels:
                raise TripLogError(f"{where}: message on unknown channel")
            by_topic.get(channels[r.channel_id].topic, []).append(r.data)
    if not any(isinstance(r, records.Footer) for r in found):
        raise TripLogError(f"{where}: truncated trip log (no MCAP footer)")
    topics = {c.topic: c for c in channels.values()}
    if SAMPLE_TOPIC not in topics:
        raise TripLogError(
            f"{where}: not a pacc trip log (no {SAMPLE_TOPIC} channel; topics: "
            f"{sorted(topics) or 'none'})"
        )
    sch = schemas.get(topics[SAMPLE_TOPIC].schema_id)
    if sch is None or sch.name != SAMPLE_SCHEMA_NAME:
        raise TripLogError(f"{where}: {SAMPLE_TOPIC} does not use schema {SAMPLE_SCHEMA_NAME}")
    with mcap_errors(where, "trip log", TripLogError):
        rows = [json.loads(d) for d in by_topic[SAMPLE_TOPIC]]
        meta = json.loads(by_topic[META_TOPIC][-1]) if by_topic[META_TOPIC] else None
    if meta is not None and not isinstance(meta, dict):
        raise TripLogError(f"{where}: {META_TOPIC} message is not a JSON object")
    return _trip_from_rows(rows, meta or {}, where)


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
