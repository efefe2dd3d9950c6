"""The uploader: drains the spool into the cloud on a thread of its own, nothing lost.

Pending batches go oldest first; one is deleted only when the receipt names its digest. A
retryable failure (:class:`CloudUnavailableError`) is retried with exponential backoff and full
jitter; 413/422 move the batch to ``rejected/``; 401 ends the pass and 403 or another 4xx skips
the batch for this pass (:attr:`UploadStats.held`). After the batches each pass posts the trip
reports that may go (:mod:`cloud_sync.vehicle.reports`).
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass

from tenacity import RetryCallState, Retrying, retry_if_exception_type, wait_random_exponential

from cloud_sync.api import (
    AuthError,
    BadBatchError,
    CloudApi,
    CloudError,
    CloudUnavailableError,
    PayloadTooLargeError,
)
from cloud_sync.vehicle.reports import ReportQueue, http_answer
from cloud_sync.vehicle.spool import Batch, Spool

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class UploaderConfig:
    """Timing, s: first retry's wait (doubling, full jitter), the longest wait, idle poll."""

    backoff_s: float = 0.5
    backoff_max_s: float = 60.0
    poll_s: float = 5.0


@dataclass
class UploadStats:
    """Counts since start."""

    uploaded: int = 0
    duplicates: int = 0
    rejected: int = 0
    held: int = 0
    retries: int = 0
    #: why the newest held batch was kept ("" if none): for the command to say so
    last_held: str = ""


class Uploader:
    """Uploads the batches of ``spool`` to ``cloud`` (see the module docstring)."""

    def __init__(self, spool: Spool, cloud: CloudApi, config: UploaderConfig | None = None) -> None:
        self.spool = spool
        self.cloud = cloud
        self.config = config if config is not None else UploaderConfig()
        self.stats = UploadStats()
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
                self.stats.held += 1
                self.stats.last_held = f"the cloud refused the token (HTTP 401): {exc}"
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
            self.stats.held += 1
            self.stats.last_held = f"batch {batch.seq}: {http_answer(exc)}" + (
                " (add the driver to this vehicle: pacc cloud vehicle --vehicle V --driver ID; "
                "ECU takeovers need pacc ecu --driver ID)"
                if exc.status == 403
                else ""
            )
            log.error("batch %d kept, the cloud answered %s", batch.seq, http_answer(exc))
            return False
        if receipt.digest != batch.digest:  # never delete on a receipt for other bytes
            log.error("receipt digest %s for batch %s: kept", receipt.digest, batch.digest)
            return False
        self.spool.ack(batch.digest)
        self.stats.uploaded += 1
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


__all__ = ["UploadStats", "Uploader", "UploaderConfig"]
