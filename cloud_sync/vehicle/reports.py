"""Trip reports waiting for the cloud: the vehicle's end-of-trip reports, queued on disk.

Each report (:mod:`cloud_sync.service.trips`) is a JSON file ``reports/<seq>-<trip_id>.json``
in the spool, written atomically. :meth:`ReportQueue.send` posts them oldest first, each once
none of its segments is still spooled: acknowledged or duplicate — deleted; refused for good
(422, 413) or unreadable — moved to ``reports/rejected/`` with the reason; anything else
(unreachable, 401, 403, 404 ...) — kept for the next pass (:attr:`ReportStats.last_held`).
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
from cloud_sync.durable import set_aside, write_atomic
from cloud_sync.errors import CloudSyncError
from dbc.vocab.dgpt import PLAIN_NAME

log = logging.getLogger(__name__)

#: the spool's sub-folder of reports
REPORTS = "reports"
_NAME = re.compile(rf"^\d{{12}}-({PLAIN_NAME.pattern})\.json$")
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
    """The ``reports/`` folder of the spool at ``spool_root``. Thread-safe."""

    def __init__(self, spool_root: str | os.PathLike[str]) -> None:
        self.root = Path(spool_root) / REPORTS
        self.stats = ReportStats()
        self._lock = threading.Lock()
        if self.root.is_dir():  # a write cut short by a crash: never renamed, not a report
            for part in self.root.glob(".*.part"):
                with contextlib.suppress(OSError):
                    part.unlink()

    def put(self, report: Mapping[str, Any]) -> Path:
        """Queue ``report`` (its ``trip_id`` a plain name); its file. ReportError: not JSON,
        no plain trip id, or not written."""
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
        set_aside(path, reason)
        self.stats.rejected += 1
        log.error("trip report %s set aside in %s/rejected: %s", path.name, self.root, reason)


def http_answer(exc: CloudError) -> str:
    """What the cloud answered: ``HTTP <status>: <detail>`` (the status said once), or that
    it is unavailable."""
    if isinstance(exc, CloudUnavailableError):
        return f"the cloud is unavailable: {exc}"
    return f"HTTP {exc.status}: {_STATUS_PREFIX.sub('', str(exc), count=1)}"


__all__ = ["REPORTS", "ReportError", "ReportQueue", "ReportStats", "http_answer"]
