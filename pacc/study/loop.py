"""The study through the vehicle–cloud loop, and the paper's incremental learning measured.

:class:`StudyCloud` is the harness's (the study's, a ``pacc hil`` session's) use of the
vehicle's one cloud wiring, :class:`cloud_sync.vehicle.link.VehicleLink`: manual trips are
spooled and uploaded to the cloud (embedded under ``OUT/cloud`` or a running ``pacc cloud
serve``), which learns the driver's table; the IRL controllers drive the table the vehicle
downloaded and verified. :func:`run_incremental`: N consecutive IRL + OA trips per driver,
each trip's takeovers and report uploaded and the next trip driving the fine-tuned version;
one row per (driver, trip): version driven, PoI, NIM, takeovers.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Iterable, Mapping
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cloud_sync.api import CloudApi, CloudError
from cloud_sync.engine import is_dask, map_unordered, workers_of
from cloud_sync.errors import CloudSyncError
from cloud_sync.service.local import LocalCloud
from cloud_sync.service.rules import CloudService, DeferredExecutor, ServiceConfig
from cloud_sync.signing import load_public_key
from cloud_sync.vehicle.connect import connect, read_token, write_token
from cloud_sync.vehicle.download import ProfileDownloader
from cloud_sync.vehicle.link import VehicleLink
from cloud_sync.vehicle.spool import Spool
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog import Trip
from pacc.study.drive import DriveConfig, run_drive
from pacc.study.irl_table import manual_trips
from pacc.study.spec import StudySpec
from sim_bus.drivers import DriverParams
from sim_bus.errors import SimError
from sim_bus.lead.scenarios import canonical_profiles

#: the vehicle id the study registers in its embedded cloud
STUDY_VEHICLE = "study"
#: where a kept embedded cloud keeps its vehicle's token
TOKEN_FILE = "vehicle.token"
#: how long the study waits for a cloud that does not answer, s
SYNC_TIMEOUT_S = 120.0


@dataclass
class StudyCloud:
    """The harness's use of the vehicle's :class:`VehicleLink`: blocking upload and download."""

    link: VehicleLink
    #: the digests of the batches of the last :meth:`upload`
    last_digests: list[str] = field(default_factory=list)

    @classmethod
    def embedded(
        cls,
        out: Path,
        drivers: Iterable[str],
        seed: int,
        compute: Executor | None = None,
        *,
        keep: bool = False,
    ) -> StudyCloud:
        """An embedded cloud under ``out/cloud`` with the study's vehicle and ``drivers``
        registered: a fresh one or, with ``keep``, the one there reopened (its vehicle's
        token in ``cloud/vehicle.token``). ``compute``: where its learning jobs train (None:
        in this thread)."""
        if not keep:
            for folder in (out / "cloud", out / "spool"):
                shutil.rmtree(folder, ignore_errors=True)
        threads = workers_of(compute) if compute is not None else 1
        service = CloudService.open(
            out / "cloud", DeferredExecutor(threads), ServiceConfig(seed=seed), compute
        )
        token_path = out / "cloud" / TOKEN_FILE
        if keep and token_path.is_file():
            token = token_path.read_text(encoding="utf-8").strip()
        else:
            token = service.register_vehicle(STUDY_VEHICLE)
            for driver_id in drivers:
                service.register_driver(STUDY_VEHICLE, driver_id)
            if keep:
                write_token(token_path, token, force=True)
        return cls._linked(LocalCloud(service, token), service.public_key_pem(), out)

    @classmethod
    def open(
        cls,
        out: Path,
        drivers: Iterable[str],
        seed: int,
        cloud: str | None,
        token_file: str | Path | None,
        trust: str | Path | None,
        **embedded: Any,
    ) -> StudyCloud:
        """The running cloud (URL) or folder ``cloud``, where the drivers are registered to the
        vehicle of ``token_file`` (``pacc cloud register``); None: :meth:`embedded`."""
        if cloud is None:
            return cls.embedded(out, drivers, seed, **embedded)
        if token_file is None or trust is None:
            raise SimError("--cloud needs --token-file and --trust")
        try:
            return cls._linked(connect(cloud, read_token(Path(token_file))), Path(trust), out)
        except CloudSyncError as exc:
            raise SimError(f"study cloud: {exc}") from exc

    @classmethod
    def _linked(cls, api: CloudApi, key: bytes | Path, out: Path) -> StudyCloud:
        downloader = ProfileDownloader(api, load_public_key(key), out / "spool" / "profiles")
        return cls(VehicleLink(api, Spool(out / "spool"), None, downloader=downloader))

    def upload(self, trips: list[Trip]) -> int:
        """Spool ``trips`` and upload until the spool is empty; the batches uploaded
        (SimError: the cloud refused one, or did not take them in SYNC_TIMEOUT_S s)."""
        self.last_digests = [self.link.put(trip) for trip in trips]
        stats = self.link.drain(SYNC_TIMEOUT_S, backoff_max_s=5.0).stats
        spool = self.link.spool
        if stats.rejected or spool.pending():
            raise SimError(
                f"study cloud: {stats.rejected} batch(es) refused, "
                f"{len(spool.pending())} not taken (see {spool.root})"
            )
        return stats.sent

    def report_trip(self, report: dict[str, Any]) -> None:
        """Report one ACC trip (``cloud_sync.service.trips``) behind its uploaded segments
        (SimError: the cloud refused it or could not be reached; a held one stays queued)."""
        try:
            self.link.queue_report(report)
        except CloudSyncError as exc:
            raise SimError(f"study cloud: {exc}") from exc
        sent = self.link.drain(SYNC_TIMEOUT_S, backoff_max_s=5.0).reports.stats
        if sent.rejected or self.link.uploader.reports.pending():
            why = sent.last_held or f"see {self.link.uploader.reports.root}"
            raise SimError(f"study cloud: trip report refused: {why}")

    def table(self, driver_id: str, condition: str) -> Dgpt | None:
        """The newest verified table of the driver, downloaded now or the last good one."""
        try:
            self.link.cloud.wait_learned(driver_id, condition, SYNC_TIMEOUT_S)  # a served cloud
            return self.link.table(driver_id, condition)
        except CloudError as exc:  # fetch reports, but a bug must not pass silently
            raise SimError(f"study cloud: {exc}") from exc

    def verified(self, driver_id: str, condition: str) -> Dgpt:
        """:meth:`table`, or SimError saying why there is none."""
        table = self.table(driver_id, condition)
        if table is None:
            assert self.link.downloader is not None
            why = "; ".join(self.link.downloader.report.refusals) or "the cloud learned none"
            raise SimError(f"study cloud: no usable table for {driver_id} ({why})")
        return table

    def learn(self, trips: list[Trip], driver_id: str) -> tuple[Dgpt, int]:
        """Upload the manual ``trips``; the learned table (downloaded, verified) and the
        batches uploaded."""
        batches = self.upload(trips)
        return self.verified(driver_id, str(trips[0].meta.get("condition", "default"))), batches

    def fine_tune(self, segments: list[Trip], table: Dgpt) -> tuple[Dgpt, int]:
        """Upload a drive's takeover ``segments``; the newest verified table (``table`` when
        the cloud has nothing newer) and the batches uploaded."""
        batches = self.upload(segments) if segments else 0
        newer = self.table(table.driver_id, table.condition)
        return (newer if newer is not None and newer.version > table.version else table), batches


def cloud_irl_tables(
    cloud: StudyCloud,
    drivers: Mapping[str, DriverParams],
    seed: int,
    executor: Executor | None = None,
) -> dict[str, Dgpt]:
    """Driver id -> the IRL table the vehicle downloaded after uploading the manual trips.
    Every driver's trips go up first (in driver order), so an embedded cloud with a
    Dask cluster learns the drivers side by side at the first download; a Dask ``executor``
    also drives the manual trips."""
    made: dict[int, list[Trip]] = {}
    if is_dask(executor):
        assert executor is not None
        tasks = [(driver, seed) for driver in drivers.values()]
        made = dict(map_unordered(executor, _manual_trips, tasks))
    conditions: dict[str, str] = {}
    for index, (driver_id, driver) in enumerate(drivers.items()):
        trips = made.pop(index) if index in made else manual_trips(driver, seed)
        cloud.upload(trips)
        conditions[driver_id] = str(trips[0].meta.get("condition", "default"))
    return {driver_id: cloud.verified(driver_id, c) for driver_id, c in conditions.items()}


def _manual_trips(task: tuple[DriverParams, int]) -> list[Trip]:
    """A driver's manual trips (an executor task)."""
    return manual_trips(*task)


def _report_trip(cloud: StudyCloud, table: Dgpt, run: DriveConfig, acc_on_s: float) -> None:
    """Report the trip just driven (``run``, with ``table``, ``acc_on_s`` s of ACC on) and
    the takeover segments just uploaded: a point of the cloud's per-trip learning curve."""
    report: dict[str, Any] = {
        "driver_id": run.driver_id,
        "condition": table.condition,
        "dgpt_version": table.version,
        "acc_on_s": acc_on_s,
        "segments": cloud.last_digests,
    }
    # the trip's id: the same drive again (a rerun against the same cloud) is the same
    # report, a drive of another seed or length a new trip
    drive = {**report, "seed": run.seed, "duration_s": run.duration_s}
    digest = hashlib.sha256(json.dumps(drive, sort_keys=True).encode()).hexdigest()
    cloud.report_trip({**report, "trip_id": f"study-s{run.seed}-{digest[:16]}"})


def run_incremental(
    cfg: StudySpec,
    drivers: Mapping[str, DriverParams],
    cloud: StudyCloud,
    tables: Mapping[str, Dgpt],
) -> list[dict[str, Any]]:
    """``cfg.incremental`` consecutive IRL + OA trips per driver on scenario B (trip k with
    noise seed ``cfg.seed + k``); after each, its takeovers go up and the next trip drives
    with the fine-tuned version downloaded. Rows in (driver, trip) order."""
    profile = canonical_profiles(cfg.seed)["B"]
    rows: list[dict[str, Any]] = []
    for driver_id, driver in drivers.items():
        table = tables[driver_id]
        for trip in range(cfg.incremental):
            segments: list[Trip] = []
            run_cfg = DriveConfig(
                scenario="B",
                driver_id=driver_id,
                controller="irl+oa",
                seed=cfg.seed + trip,
                duration_s=cfg.duration_s,
                adaptation=cfg.adaptation,
                dbc=cfg.dbc,
                binding=cfg.binding,
            )
            result = run_drive(
                run_cfg, driver, table, profile, takeover_sink=segments.append, bus=cfg.bus
            )
            m = result.metrics
            uploaded = cloud.upload(segments)
            _report_trip(cloud, table, run_cfg, m.acc_on_s)
            rows.append(
                {
                    "driver": driver_id,
                    "trip": trip + 1,
                    "dgpt_version": table.version,
                    "poi_pct": m.poi_pct,
                    "nim_per_min": m.nim_per_min,
                    "takeovers": result.takeovers,
                    "uploaded": uploaded,
                    "min_ttc_s": m.min_ttc_s,
                    "collision": int(result.collision),
                }
            )
            newer = cloud.table(driver_id, table.condition)
            if newer is not None and newer.version > table.version:
                table = newer
    return rows
