"""Trip reports waiting for the cloud: the vehicle's end-of-trip reports, queued on disk.

At the end of each ACC trip the vehicle reports it (``POST /v1/trips``,
:mod:`cloud_sync.service.trips`): the driver, the table version it drove with, its ACC-on
time and the digests of the takeover segments it spooled. A report names segments, and the
cloud accepts it only once they are stored, so reports travel behind the batches: each is a
JSON file in the spool's ``reports/`` folder, written atomically (a temporary file, fsync,
rename, fsync of the folder: after a crash it is whole or absent), named
``<seq>-<trip_id>.json`` so that they go in order. :meth:`ReportQueue.send` (called by the
uploader after each pass over the batches, :mod:`cloud_sync.vehicle.uploader`) posts the
pending reports oldest first, each only once none of its segments is still spooled:

- acknowledged (or a duplicate: the cloud holds this very report) — deleted;
- the cloud cannot be reached (:class:`~cloud_sync.api.CloudUnavailableError`), the token is
  refused (401) or the driver is not the vehicle's (403) — kept, the pass ends, tried again
  on the next pass or the next run (``pacc ecu --cloud``, ``pacc cloud sync --spool``);
- refused for good (422: a segment the cloud never got because the quota evicted it, an
  unpublished version, a taken trip id) — moved to ``reports/rejected/`` with the reason.

Nothing is lost while the cloud is away: delivery is at least once, and the cloud stores a
report once per (driver, trip id).
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import re
import threading
import uuid
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cloud_sync.api import (
    AuthError,
    CloudApi,
    CloudError,
    CloudUnavailableError,
    ForbiddenError,
)
from cloud_sync.durable import fsync_dir
from cloud_sync.errors import CloudSyncError

log = logging.getLogger(__name__)

#: the spool's sub-folder of reports
REPORTS = "reports"
_NAME = re.compile(r"^(?P<seq>\d{12})-(?P<trip>[A-Za-z0-9][A-Za-z0-9_.-]{0,63})\.json$")
_REJECTED = "rejected"


class ReportError(CloudSyncError):
    """A report cannot be queued (not JSON, no trip id, a full disk)."""


@dataclass
class ReportStats:
    """What the queue did since it was opened (counts)."""

    queued: int = 0
    sent: int = 0
    duplicates: int = 0
    rejected: int = 0
    held: int = 0


class ReportQueue:
    """The ``reports/`` folder of a spool (module docstring). Thread-safe.

    Args:
        spool_root: the spool folder; the reports live in ``spool_root/reports``.
    """

    def __init__(self, spool_root: str | os.PathLike[str]) -> None:
        self.root = Path(spool_root) / REPORTS
        self.stats = ReportStats()
        self._lock = threading.Lock()
        if self.root.is_dir():  # a write cut short by a crash: never renamed, not a report
            for part in self.root.glob(".*.part"):
                with contextlib.suppress(OSError):
                    part.unlink()

    def put(self, report: Mapping[str, Any]) -> Path:
        """Queue ``report`` (its ``trip_id`` a plain name); the file it was written to.

        Raises:
            ReportError: the report is not JSON, has no usable trip id, or cannot be written.
        """
        trip_id = report.get("trip_id")
        try:
            text = json.dumps(dict(report), sort_keys=True, allow_nan=False)
        except (TypeError, ValueError) as exc:
            raise ReportError(f"trip report not queued: {exc}") from exc
        with self._lock:
            seq = max((int(p.name[:12]) for p in self._files()), default=0) + 1
            final = self.root / f"{seq:012d}-{trip_id}.json"
            if not isinstance(trip_id, str) or _NAME.match(final.name) is None:
                raise ReportError(f"trip report not queued: trip_id {trip_id!r} is not plain")
            part = self.root / f".{uuid.uuid4().hex}.part"
            try:
                self.root.mkdir(parents=True, exist_ok=True)
                with part.open("w", encoding="utf-8") as stream:
                    stream.write(text + "\n")
                    stream.flush()
                    os.fsync(stream.fileno())
                part.replace(final)
                fsync_dir(self.root)
            except OSError as exc:
                with contextlib.suppress(OSError):
                    part.unlink(missing_ok=True)
                raise ReportError(f"trip report not queued: {exc.strerror or exc}") from exc
            self.stats.queued += 1
            return final

    def _files(self) -> list[Path]:
        if not self.root.is_dir():
            return []
        return sorted(p for p in self.root.iterdir() if _NAME.match(p.name))

    def pending(self) -> list[Path]:
        """The queued reports, oldest first."""
        with self._lock:
            return self._files()

    def send(self, cloud: CloudApi, spooled: Collection[str]) -> int:
        """Post the pending reports, oldest first (module docstring); ``spooled``: the
        digests of the batches still in the spool. Returns how many the cloud took."""
        done = 0
        for path in self.pending():
            try:
                report = json.loads(path.read_text(encoding="utf-8"))
            except (OSError, ValueError) as exc:
                self._reject(path, f"unreadable: {exc}")
                continue
            if not isinstance(report, dict) or not isinstance(report.get("segments", []), list):
                self._reject(path, "not a trip report (a JSON object with a segments list)")
                continue
            if any(d in spooled for d in report.get("segments", [])):
                break  # its segments first: the order is the upload's
            try:
                receipt = cloud.report_trip(report)
            except (CloudUnavailableError, AuthError, ForbiddenError) as exc:
                self.stats.held += 1
                log.warning("trip report %s kept for later: %s", path.name, exc)
                break
            except CloudError as exc:
                self._reject(path, f"HTTP {exc.status}: {exc}")
                continue
            path.unlink()
            self.stats.sent += 1
            self.stats.duplicates += int(receipt.duplicate)
            done += 1
        return done

    def _reject(self, path: Path, reason: str) -> None:
        target = self.root / _REJECTED
        target.mkdir(exist_ok=True)
        (target / f"{path.name}.reason").write_text(reason + "\n", encoding="utf-8")
        path.replace(target / path.name)
        fsync_dir(self.root)
        self.stats.rejected += 1
        log.error("trip report %s refused by the cloud: %s", path.name, reason)


__all__ = ["REPORTS", "ReportError", "ReportQueue", "ReportStats"]
