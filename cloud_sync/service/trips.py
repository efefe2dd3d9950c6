"""Trip reports: what the cloud knows of each ACC trip, for the per-trip learning curve.

``POST /v1/trips`` body: ``{"driver_id", "condition", "trip_id", "dgpt_version", "acc_on_s",
"segments": [sha256...], "start_utc"?}``. The cloud computes the intervention time (s; pedal
pressed while the ACC was on) and takeovers (press onsets) from the named stored takeover
segments; the vehicle states ``acc_on_s`` (s, 0..86,400, not below the interventions) and a
published ``dgpt_version``. Then ``poi_pct = 100·intervention_s/acc_on_s`` and
``takeovers_per_min``. Stored once per (driver, trip id); another report under a taken id: 422.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from dataclasses import astuple, dataclass
from datetime import datetime
from typing import TYPE_CHECKING, Any

import numpy as np

from cloud_sync.api import BadBatchError, TripReceipt, check_plain
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import utc_now_iso
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import trip_from_bytes
from dbc.vocab.tripmode import TripMode

if TYPE_CHECKING:
    from cloud_sync.service.rules import CloudService

#: the longest ACC-on time a report may state, s (one day)
MAX_ACC_ON_S = 86_400.0
#: the most segments one report may name
MAX_SEGMENTS = 10_000
_SHA256 = re.compile(r"[0-9a-f]{64}")
_KEYS = {"driver_id", "condition", "trip_id", "dgpt_version", "acc_on_s", "segments", "start_utc"}


@dataclass(frozen=True)
class TripReport:
    """One trip report, checked for shape (the module docstring has the fields)."""

    driver_id: str
    condition: str
    trip_id: str
    dgpt_version: int
    acc_on_s: float
    segments: tuple[str, ...]
    start_utc: str | None

    @classmethod
    def parse(cls, body: object) -> TripReport:
        """The report in a decoded JSON ``body``; BadBatchError (422) for anything else."""
        if not isinstance(body, Mapping):
            raise BadBatchError("a trip report is a JSON object")
        unknown = set(body) - _KEYS
        if unknown:
            raise BadBatchError(f"trip report: unknown field(s) {', '.join(sorted(unknown))}")
        names = {k: body.get(k, "default" if k == "condition" else None) for k in _KEYS}
        plain = {k: names[k] for k in ("driver_id", "condition", "trip_id")}
        check_plain(BadBatchError, **plain)
        version, acc_on = _numbers(names["dgpt_version"], names["acc_on_s"])
        segments = _digests(names["segments"] if names["segments"] is not None else [])
        start = names["start_utc"]
        if start is not None and not _is_utc(start):
            raise BadBatchError(f"trip report: start_utc {start!r} is not ISO 8601 UTC")
        driver_id, condition, trip_id = map(str, plain.values())
        return cls(driver_id, condition, trip_id, version, acc_on, segments, start)

    def canonical(self) -> str:
        """The report as canonical JSON (sorted keys): what a duplicate must equal."""
        fields = {k: getattr(self, k) for k in sorted(_KEYS)}
        fields["segments"] = list(self.segments)
        return json.dumps(fields, sort_keys=True, separators=(",", ":"))


def _numbers(version: object, acc_on: object) -> tuple[int, float]:
    """(dgpt_version, acc_on_s) checked; BadBatchError otherwise."""
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise BadBatchError(f"trip report: dgpt_version {version!r} is not a version >= 1")
    if not isinstance(acc_on, int | float) or isinstance(acc_on, bool):
        raise BadBatchError(f"trip report: acc_on_s {acc_on!r} is not a number")
    if not (math.isfinite(acc_on) and 0.0 <= acc_on <= MAX_ACC_ON_S):
        raise BadBatchError(f"trip report: acc_on_s {acc_on!r} is outside 0..{MAX_ACC_ON_S}")
    return version, float(acc_on)


def _digests(segments: object) -> tuple[str, ...]:
    """The segment digests checked (distinct lower-case SHA-256 hex); BadBatchError otherwise."""
    if not isinstance(segments, list) or len(segments) > MAX_SEGMENTS:
        raise BadBatchError(f"trip report: segments is a list of <= {MAX_SEGMENTS} digests")
    for digest in segments:
        if not (isinstance(digest, str) and _SHA256.fullmatch(digest)):
            raise BadBatchError(f"trip report: {digest!r} is not a SHA-256 digest")
    if len(set(segments)) != len(segments):
        raise BadBatchError("trip report: a segment is named twice")
    return tuple(segments)


def _is_utc(text: object) -> bool:
    if not isinstance(text, str) or len(text) > 40 or not text.endswith("Z"):
        return False
    try:
        datetime.fromisoformat(text[:-1] + "+00:00")
    except ValueError:
        return False
    return True


def segment_interventions(trip: Trip) -> tuple[float, int]:
    """(intervention s, takeovers) of one takeover segment (module docstring), pure: pedal
    samples while on (Active, Override, Standby after the first engagement) times the median
    period, and press onsets while on."""
    n = len(trip)
    if n == 0:
        return 0.0, 0
    dt = float(np.median(np.diff(trip.t_s))) if n > 1 else 0.0
    state = trip.acc_state
    engaged = (state == int(AccState.ACTIVE)) | (state == int(AccState.OVERRIDE))
    on = engaged | ((state == int(AccState.STANDBY)) & (np.cumsum(engaged) > 0))
    accel = np.nan_to_num(trip.accel_pedal, nan=0.0) > 0.0
    brake = np.nan_to_num(trip.brake_pedal, nan=0.0) > 0.0
    onsets = (_onsets(accel) | _onsets(brake)) & on
    return float(((accel | brake) & on).sum()) * dt, int(onsets.sum())


def _onsets(pressed: np.ndarray) -> np.ndarray:
    prev = np.concatenate([[False], pressed[:-1]])
    out: np.ndarray = pressed & ~prev
    return out


def record_trip(service: CloudService, vehicle_id: str, body: object) -> TripReceipt:
    """Check and keep one trip report of ``vehicle_id``; its receipt (ForbiddenError: not
    the vehicle's driver; BadBatchError: malformed, unknown segment or version, taken id)."""
    report = TripReport.parse(body)
    service._own(vehicle_id, report.driver_id)  # noqa: SLF001 - the service's ownership rule
    published = {v.version for v in service.store.versions(report.driver_id, report.condition)}
    if report.dgpt_version not in published:
        raise BadBatchError(
            f"trip report: {report.driver_id}/{report.condition} has no published "
            f"version {report.dgpt_version}"
        )
    # the intervention s, takeovers and tolerance s of the stored segments the report names
    store = service.store
    seconds, takeovers, tolerance = 0.0, 0, 0.0
    for digest in report.segments:
        rows = store.query(
            "SELECT driver_id, condition, kind FROM batches WHERE digest = ?", (digest,)
        )
        if not rows:
            raise BadBatchError(f"trip report: segment {digest[:12]} was not uploaded")
        if rows[0][:2] != (report.driver_id, report.condition):
            raise BadBatchError(f"trip report: segment {digest[:12]} is another trip's driver")
        if rows[0][2] != TripMode.TAKEOVER:
            raise BadBatchError(f"trip report: batch {digest[:12]} is not a takeover segment")
        trip = trip_from_bytes(store.read_blob(digest), f"batch {digest}")
        spent, count = segment_interventions(trip)
        seconds += spent
        takeovers += count
        tolerance += float(np.median(np.diff(trip.t_s))) if len(trip) > 1 else 0.0
    if seconds > report.acc_on_s + tolerance:
        raise BadBatchError(
            f"trip report: acc_on_s {report.acc_on_s:.1f} s is shorter than the "
            f"{seconds:.1f} s of interventions in its segments"
        )
    text = report.canonical()
    with service.store.transaction() as db:
        old = db.execute(
            "SELECT report FROM trips WHERE driver_id = ? AND trip_id = ?",
            (report.driver_id, report.trip_id),
        ).fetchone()
        if old is not None:
            if old[0] != text:
                raise BadBatchError(f"trip report: trip id {report.trip_id!r} is taken")
            return TripReceipt(report.trip_id, report.driver_id, duplicate=True)
        marks = ",".join("?" * len(report.segments))
        if (
            report.segments
            and db.execute(
                f"SELECT 1 FROM trip_segments WHERE digest IN ({marks})",  # noqa: S608 - only ?s
                report.segments,
            ).fetchone()
        ):
            raise BadBatchError("trip report: a segment belongs to another trip already")
        cur = db.execute(
            "INSERT INTO trips (vehicle_id, driver_id, condition, trip_id, start_utc, "
            "received_utc, dgpt_version, acc_on_s, intervention_s, takeovers, report) "
            "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)",
            (vehicle_id, *astuple(report)[:3], report.start_utc, utc_now_iso())
            + (report.dgpt_version, report.acc_on_s, seconds, takeovers, text),
        )
        db.executemany(
            "INSERT INTO trip_segments VALUES (?, ?)", [(d, cur.lastrowid) for d in report.segments]
        )
    return TripReceipt(report.trip_id, report.driver_id, duplicate=False)


def trip_rows(service: CloudService, driver_id: str) -> list[dict[str, Any]]:
    """The driver's trips in arrival order, numbered per condition from 1, with the
    cloud's per-trip measures (module docstring)."""
    rows = service.store.query(
        "SELECT seq, condition, trip_id, start_utc, received_utc, dgpt_version, acc_on_s, "
        "intervention_s, takeovers, report FROM trips WHERE driver_id = ? ORDER BY seq",
        (driver_id,),
    )
    counts: dict[str, int] = {}
    out = []
    for _, cond, trip_id, start, received, version, acc_on, inter, takeovers, text in rows:
        counts[cond] = counts.get(cond, 0) + 1
        minutes = acc_on / 60.0
        out.append(
            {
                "index": counts[cond],
                "condition": cond,
                "trip_id": trip_id,
                "start_utc": start,
                "received_utc": received,
                "dgpt_version": version,
                "acc_on_s": acc_on,
                "intervention_s": inter,
                "takeovers": takeovers,
                "poi_pct": 100.0 * inter / acc_on if acc_on > 0 else None,
                "takeovers_per_min": takeovers / minutes if minutes > 0 else None,
                "segments": json.loads(text)["segments"],
            }
        )
    return out
