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
- refused for good, an answer about the report itself that no retry changes (as the uploader
  decides for batches: 422 :class:`~cloud_sync.api.BadBatchError`, a segment the cloud never
  got because the quota evicted it, an unpublished version, a taken trip id; 413
  :class:`~cloud_sync.api.PayloadTooLargeError`) — moved to ``reports/rejected/`` with the
  reason, and so is a file the cloud never saw because it cannot be read or is not a trip
  report (the reason says which);
- any other answer — kept, the pass ends, tried again on the next pass or the next run
  (``pacc ecu --cloud``, ``pacc cloud sync --spool``): the cloud cannot be reached
  (:class:`~cloud_sync.api.CloudUnavailableError`, 5xx), the token is refused (401), the driver
  is not the vehicle's (403), or an answer about the set-up that a later cloud may change
  (404: an older cloud without ``POST /v1/trips`` or a wrong URL prefix; 405, 409, 429 ...).
  :attr:`ReportStats.last_held` says why.

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
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from cloud_sync.api import (
    BadBatchError,
    CloudApi,
    CloudError,
    CloudUnavailableError,
    PayloadTooLargeError,
)
from cloud_sync.durable import fsync_dir, write_atomic
from cloud_sync.errors import CloudSyncError

log = logging.getLogger(__name__)

#: the spool's sub-folder of reports
REPORTS = "reports"
_NAME = re.compile(r"^(?P<seq>\d{12})-(?P<trip>[A-Za-z0-9][A-Za-z0-9_.-]{0,63})\.json$")
_REJECTED = "rejected"
_STATUS_PREFIX = re.compile(r"^HTTP \d{3}: ")


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
    #: why the last report was kept ("" when none was)
    last_held: str = ""


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
            try:
                write_atomic(final, (text + "\n").encode("utf-8"))
            except OSError as exc:
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
            except OSError as exc:
                self._reject(path, f"unreadable: {exc.strerror or exc}")
                continue
            except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError
                self._reject(path, f"not JSON: {exc}")
                continue
            if not isinstance(report, dict) or not isinstance(report.get("segments", []), list):
                self._reject(path, "not a trip report (a JSON object with a segments list)")
                continue
            if any(d in spooled for d in report.get("segments", [])):
                break  # its segments first: the order is the upload's
            try:
                receipt = cloud.report_trip(report)
            except (BadBatchError, PayloadTooLargeError) as exc:  # about this report: for good
                self._reject(path, f"refused by the cloud ({http_answer(exc)})")
                continue
            except CloudError as exc:  # unreachable, 401, 403, 404, 405, 409, 429 ...: held
                self.stats.held += 1
                self.stats.last_held = f"{path.name}: {http_answer(exc)}" + (
                    " (not the service's root URL, or a cloud without POST /v1/trips)"
                    if exc.status == 404
                    else ""
                )
                log.warning("trip report %s kept for later: %s", path.name, http_answer(exc))
                break
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
        log.error("trip report %s set aside in %s: %s", path.name, target, reason)


def http_answer(exc: CloudError) -> str:
    """What the cloud answered: ``HTTP <status>: <detail>``, the status said once (the HTTP
    client's messages start with it already, the embedded cloud's do not); the cloud out of
    reach, its own words."""
    if isinstance(exc, CloudUnavailableError):
        return f"the cloud is unavailable: {exc}"
    return f"HTTP {exc.status}: {_STATUS_PREFIX.sub('', str(exc), count=1)}"


__all__ = ["REPORTS", "ReportError", "ReportQueue", "ReportStats", "http_answer"]
