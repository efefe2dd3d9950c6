"""The vehicle's link to the cloud: the one wiring of spool, uploader and verified download.

:class:`VehicleLink` is used by ``pacc ecu --cloud`` (threads: the recorder's
:meth:`~VehicleLink.sink` spools each takeover segment and wakes the uploader; a schedule
fetches the driver's newest verified table every ``sync_every_s`` s and offers it to the ECU)
and by the study harness
(:class:`pacc.study.loop.StudyCloud`: :meth:`~VehicleLink.put`, then a blocking
:meth:`~VehicleLink.drain`). Trip reports (:mod:`cloud_sync.service.trips`) are queued in the
spool's ``reports/`` folder and posted behind their segments (:mod:`cloud_sync.vehicle.uploader`).
"""

from __future__ import annotations

import dataclasses
import logging
import threading
import uuid
from collections.abc import Callable, Mapping
from typing import Any

from cloud_sync.api import CloudApi
from cloud_sync.errors import CloudSyncError
from cloud_sync.vehicle.download import ProfileDownloader
from cloud_sync.vehicle.spool import Spool
from cloud_sync.vehicle.uploader import ReportError, Uploader, UploaderConfig
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog import Trip

log = logging.getLogger(__name__)

#: default period of the profile download, s
DEFAULT_SYNC_EVERY_S = 60.0


class VehicleLink:
    """Spool + uploader + verified download for the vehicle ``vehicle_id`` (tagged into each
    spooled trip's meta; None: not tagged). ``downloader`` None: upload only; ``driver_id``,
    ``condition``: whose table is fetched every ``sync_every_s`` s (None: no schedule)."""

    def __init__(
        self,
        cloud: CloudApi,
        spool: Spool,
        vehicle_id: str | None,
        *,
        downloader: ProfileDownloader | None = None,
        driver_id: str | None = None,
        condition: str = "default",
        sync_every_s: float = DEFAULT_SYNC_EVERY_S,
        uploader_config: UploaderConfig | None = None,
    ) -> None:
        if not sync_every_s > 0:
            raise CloudSyncError(f"sync_every_s must be > 0, got {sync_every_s}")
        self.cloud = cloud
        self.spool = spool
        self.vehicle_id = vehicle_id
        self.uploader = Uploader(spool, cloud, uploader_config)
        self.downloader = downloader
        self.driver_id = driver_id
        self.condition = condition
        self.sync_every_s = sync_every_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        #: tables handed to the ECU so far
        self.offered = 0
        #: the version of the verified cloud table the trip started with (None: none)
        self.start_version: int | None = None
        #: digests of the takeover segments spooled during this trip
        self.segments: list[str] = []

    def put(self, trip: Trip) -> str:
        """Spool ``trip`` (tagged with the vehicle id); its batch digest (SpoolError)."""
        if self.vehicle_id is not None:
            trip = dataclasses.replace(trip, meta={**trip.meta, "vehicle_id": self.vehicle_id})
        batch = self.spool.put_trip(trip)
        if batch.kind == "takeover" and batch.digest not in self.segments:
            self.segments.append(batch.digest)
        return batch.digest

    def sink(self, trip: Trip) -> None:
        """The recorder's sink: :meth:`put` and wake the uploader (SpoolError: it retries)."""
        self.put(trip)
        self.uploader.notify()

    def table(self, driver_id: str, condition: str) -> Dgpt | None:
        """The driver's newest verified table: downloaded now, else the last good one."""
        if self.downloader is None:
            return None
        fresh = self.downloader.fetch(driver_id, condition)
        return fresh or self.downloader.last_good(driver_id, condition)

    def initial_table(self) -> Dgpt | None:
        """:meth:`table` of the link's driver at start (its version is the trip's)."""
        if self.driver_id is None:
            return None
        table = self.table(self.driver_id, self.condition)
        self.start_version = None if table is None else table.version
        return table

    def queue_report(self, report: Mapping[str, Any]) -> None:
        """Queue a trip report behind its segments (ReportError if it cannot be)."""
        self.uploader.reports.put(report)
        self.uploader.notify()

    def end_trip(self, acc_on_s: float, start_utc: str | None = None) -> str:
        """Queue the report of the trip (``acc_on_s`` s of ACC on, started at ISO 8601 UTC
        ``start_utc``); a line saying what was done. Never raises."""
        if self.driver_id is None or self.start_version is None:
            return "cloud: no trip report (the trip drove no verified cloud table of a --driver)"
        if not acc_on_s > 0.0:
            return "cloud: no trip report (the ACC was never on)"
        stamp = (start_utc or "").replace("-", "").replace(":", "").split(".")[0]
        report = {
            "driver_id": self.driver_id,
            "condition": self.condition,
            "trip_id": f"ecu-{stamp or 'trip'}-{uuid.uuid4().hex[:12]}",
            "dgpt_version": self.start_version,
            "acc_on_s": round(float(acc_on_s), 3),
            "segments": list(self.segments),
        }
        if start_utc:
            report["start_utc"] = start_utc
        try:
            self.queue_report(report)
        except ReportError as exc:  # its message says "trip report not queued: <why>"
            return f"cloud: {exc}"
        return (
            f"cloud: trip report {report['trip_id']} queued (v{self.start_version}, "
            f"{report['acc_on_s']:.1f} s ACC on, {len(self.segments)} takeover segment(s))"
        )

    def start(self, offer: Callable[[Dgpt, str], None]) -> None:
        """Start the uploader and the download schedule; new tables go to ``offer``."""
        self.uploader.start()
        if self.downloader is None or self.driver_id is None:
            return
        self._stop.clear()
        self._thread = threading.Thread(
            target=self._schedule, args=(offer,), name="pacc-download", daemon=True
        )
        self._thread.start()

    def _schedule(self, offer: Callable[[Dgpt, str], None]) -> None:
        assert self.downloader is not None and self.driver_id is not None
        while not self._stop.wait(self.sync_every_s):
            try:
                table = self.downloader.fetch(self.driver_id, self.condition)
            except Exception:  # an I/O error of the cache must not end the schedule
                log.exception("profile download failed")
                continue
            if table is not None:
                offer(table, f"cloud: {table.driver_id} {table.source} v{table.version}")
                self.offered += 1

    def drain(self, timeout_s: float, backoff_max_s: float = 1.0) -> Uploader:
        """Upload what is spooled, then the reports that may go, for up to ``timeout_s`` s;
        the pass's uploader (its counts are added to :attr:`uploader`'s too)."""
        last = Uploader(self.spool, self.cloud, UploaderConfig(backoff_max_s=backoff_max_s))
        timer = threading.Timer(timeout_s, last.stop)
        timer.start()
        try:
            last.drain()
        finally:
            timer.cancel()
        self.uploader.stats.sent += last.stats.sent
        self.uploader.stats.rejected += last.stats.rejected
        self.uploader.reports.stats.sent += last.reports.stats.sent
        self.uploader.reports.stats.rejected += last.reports.stats.rejected
        return last

    def stop(self, drain_s: float = 5.0) -> None:
        """Stop both threads, then :meth:`drain` for up to ``drain_s`` s; what the cloud did
        not acknowledge stays spooled for the next run."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(10.0)
            self._thread = None
        self.uploader.stop()
        if drain_s > 0 and (self.spool.pending() or self.uploader.reports.pending()):
            self.drain(drain_s)

    def report(self) -> str:
        """One line of what the link did."""
        up = self.uploader.stats
        text = (
            f"cloud: {up.sent} batch(es) uploaded, {up.rejected} rejected, "
            f"{len(self.spool.pending())} spooled, {self.spool.stats.evicted.total()} evicted"
        )
        reports = self.uploader.reports
        if reports.stats.queued or reports.stats.sent or reports.pending():
            text += (
                f"; trip reports sent {reports.stats.sent}, queued "
                f"{len(reports.pending())}, refused {reports.stats.rejected}"
            )
        if self.downloader is not None:
            dl = self.downloader.report
            text += (
                f"; tables fetched {dl.fetched}, offered {self.offered}, "
                f"refused {len(dl.refusals)}, offline {dl.offline}"
            )
        return text
