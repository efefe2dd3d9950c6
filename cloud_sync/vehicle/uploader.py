"""The uploader: drains the spool and its trip reports into the cloud, nothing lost.

Pending batches go oldest first on a thread of their own; one is deleted only when the receipt
names its digest. A retryable failure (:class:`CloudUnavailableError`) is retried with
exponential backoff and full jitter; 413/422 move the batch to ``rejected/``; 401 ends the pass
and 403 or another 4xx skips the batch for this pass (:attr:`SendStats.held`).

Then the trip reports (:mod:`cloud_sync.service.trips`), queued by :class:`ReportQueue` as JSON
files ``reports/<seq>-<trip_id>.json`` in the spool (written atomically), are posted oldest
first, each once none of its segments is still spooled: acknowledged or duplicate — deleted;
refused for good (422, 413) or unreadable — moved to ``reports/rejected/`` with the reason;
anything else (unreachable, 401, 403, 404 ...) — kept for the next pass.
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

from tenacity import RetryCallState, Retrying, retry_if_exception_type, wait_random_exponential

from cloud_sync.api import (
    AuthError,
    BadBatchError,
    CloudApi,
    CloudError,
    CloudUnavailableError,
    PayloadTooLargeError,
)
from cloud_sync.durable import set_aside
from cloud_sync.errors import CloudSyncError
from cloud_sync.vehicle.spool import Batch, Spool
from dbc.atomic import write_bytes_atomic
from dbc.vocab.dgpt import PLAIN_NAME

log = logging.getLogger(__name__)

#: the spool's sub-folder of reports
REPORTS = "reports"
_NAME = re.compile(rf"^\d{{12}}-({PLAIN_NAME.pattern})\.json$")
_STATUS_PREFIX = re.compile(r"^HTTP \d{3}: ")


class ReportError(CloudSyncError):
    """A report cannot be queued (not JSON, no trip id, a full disk)."""


@dataclass
class SendStats:
    """What the uploader (batches) or the report queue did since start (counts)."""

    sent: int = 0
    duplicates: int = 0
    rejected: int = 0
    held: int = 0
    retries: int = 0
    queued: int = 0
    #: why the newest held one was kept ("" if none): for the command to say so
    last_held: str = ""

    def hold(self, why: str) -> None:
        """Count one kept for a later pass, and why."""
        self.held += 1
        self.last_held = why


class ReportQueue:
    """The ``reports/`` folder of the spool at ``spool_root``. Thread-safe."""

    def __init__(self, spool_root: str | os.PathLike[str]) -> None:
        self.root = Path(spool_root) / REPORTS
        self.stats = SendStats()
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
                write_bytes_atomic(final, (text + "\n").encode("utf-8"), durable=True)
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
                hint = " (not the service's root URL, or a cloud without POST /v1/trips)"
                why = f"{path.name}: {http_answer(exc)}"
                self.stats.hold(why + (hint if exc.status == 404 else ""))
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


@dataclass(frozen=True)
class UploaderConfig:
    """Timing, s: first retry's wait (doubling, full jitter), the longest wait, idle poll."""

    backoff_s: float = 0.5
    backoff_max_s: float = 60.0
    poll_s: float = 5.0


class Uploader:
    """Uploads the batches of ``spool`` to ``cloud`` (see the module docstring)."""

    def __init__(self, spool: Spool, cloud: CloudApi, config: UploaderConfig | None = None) -> None:
        self.spool = spool
        self.cloud = cloud
        self.config = config if config is not None else UploaderConfig()
        self.stats = SendStats()
        #: the spool's trip reports, posted after the batches
        self.reports = ReportQueue(spool.root)
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None

    # -- one pass ------------------------------------------------------------------------

    def drain(self) -> int:
        """Upload every pending batch (retrying until answered or stopped), then the trip
        reports that may go; the batches acknowledged in this pass."""
        done = 0
        for batch in self.spool.pending():
            if self._stop.is_set():
                break
            try:
                done += int(self._deliver(batch))
            except AuthError as exc:  # every batch would get the same answer: stop the pass
                self.stats.hold(f"the cloud refused the token (HTTP 401): {exc}")
                log.error("upload refused, token not accepted: %s (batches kept)", exc)
                return done
        if not self._stop.is_set():
            try:
                self.reports.send(self.cloud, {b.digest for b in self.spool.pending()})
            except OSError as exc:  # the reports folder: kept for the next pass
                log.error("trip reports not sent: %s", exc)
        return done

    def _deliver(self, batch: Batch) -> bool:
        """Upload one batch (with retries); True when the cloud acknowledged it."""
        try:
            data = batch.path.read_bytes()
        except FileNotFoundError:  # evicted by the quota meanwhile
            return False
        cfg = self.config
        retrying = Retrying(
            retry=retry_if_exception_type(CloudUnavailableError),
            wait=wait_random_exponential(multiplier=cfg.backoff_s, max=cfg.backoff_max_s),
            stop=lambda _: self._stop.is_set(),
            sleep=self._sleep,
            before_sleep=self._count_retry,
            reraise=True,
        )
        try:
            receipt = retrying(self.cloud.upload, data)
        except CloudUnavailableError:
            return False  # stopped while the cloud was away: the batch stays spooled
        except (PayloadTooLargeError, BadBatchError) as exc:  # about this batch: set aside
            self.spool.reject(batch.digest, http_answer(exc))
            self.stats.rejected += 1
            return False
        except AuthError:
            raise
        except CloudError as exc:  # about the set-up (403 ...): keep it for the next pass
            hint = (
                " (add the driver to this vehicle: pacc cloud vehicle --vehicle V --driver ID; "
                "ECU takeovers need pacc ecu --driver ID)"
            )
            why = f"batch {batch.seq}: {http_answer(exc)}"
            self.stats.hold(why + (hint if exc.status == 403 else ""))
            log.error("batch %d kept, the cloud answered %s", batch.seq, http_answer(exc))
            return False
        if receipt.digest != batch.digest:  # never delete on a receipt for other bytes
            log.error("receipt digest %s for batch %s: kept", receipt.digest, batch.digest)
            return False
        self.spool.ack(batch.digest)
        self.stats.sent += 1
        self.stats.duplicates += int(receipt.duplicate)
        return True

    def _sleep(self, seconds: float) -> None:
        """Wait between attempts; stop() ends the wait at once."""
        self._stop.wait(seconds)

    def _count_retry(self, state: RetryCallState) -> None:
        self.stats.retries += 1
        outcome = state.outcome
        log.warning(
            "upload attempt %d failed (%s); retrying",
            state.attempt_number,
            outcome.exception() if outcome is not None else "?",
        )

    # -- the thread ----------------------------------------------------------------------

    def start(self) -> None:
        """Run :meth:`drain` on a daemon thread whenever notified, or every ``poll_s``."""
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="pacc-uploader", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                self.drain()
            except Exception:  # a spool I/O error must not kill the thread: log, go on
                log.exception("uploader pass failed")
            self._wake.wait(self.config.poll_s)
            self._wake.clear()

    def notify(self) -> None:
        """A batch was spooled: drain soon (thread-safe, cheap)."""
        self._wake.set()

    def stop(self, timeout_s: float = 10.0) -> None:
        """End the thread (an upload in flight finishes or fails; a backoff is cut short)."""
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join(timeout_s)
            self._thread = None
