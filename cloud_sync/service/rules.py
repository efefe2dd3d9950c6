"""The cloud service's rules, free of any transport: who may do what, ingest, learning, publishing.

A vehicle (token kept as its SHA-256) reads and writes only its own drivers. An upload is
checked (:mod:`cloud_sync.service.ingest`), attributed to its ``driver_id``/``condition`` and
stored once per SHA-256. Each new batch schedules a learning job for its (driver, condition):
a pure function of the stored batches in digest order (manual trips learn a table, later
takeovers fine-tune it; too little data waits). Training may run on ``compute``
(:mod:`cloud_sync.engine`; :func:`train_table`, a pure function, runs anywhere) or, deferred
until a table is asked for, on a :class:`DeferredExecutor`; each version is signed
(:mod:`cloud_sync.signing`) and kept.
"""

from __future__ import annotations

import hashlib
import logging
import os
import secrets
import threading
import time
from collections.abc import Callable, Iterable
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PrivateKey

from cloud_sync.api import (
    AuthError,
    BadBatchError,
    ForbiddenError,
    NotFoundError,
    PayloadTooLargeError,
    Receipt,
    check_plain,
    is_plain_name,
)
from cloud_sync.engine import InlineExecutor, single_blas_thread
from cloud_sync.errors import DemoError
from cloud_sync.service.ingest import parse_batch, storage_errors
from cloud_sync.service.store import BatchRow, CloudStore, StoreError, VersionRow
from cloud_sync.signing import (
    load_private_key,
    new_private_key,
    public_pem,
    save_private_key,
    sign_dgpt,
    verify_dgpt,
)
from dbc.vocab.dgpt import Dgpt, utc_now_iso
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import trip_from_bytes
from dbc.vocab.tripmode import TripMode

if TYPE_CHECKING:  # the IRL stack (scipy) loads with the first job, not with every command
    from cloud_sync.irl.config import IrlConfig

log = logging.getLogger(__name__)

#: default upload limit, bytes (a 10-minute manual trip at 10 Hz is about 0.3 MB)
DEFAULT_MAX_UPLOAD_BYTES = 16 * 1024 * 1024


def sha256_hex(data: bytes) -> str:
    """SHA-256 of ``data``, hex."""
    return hashlib.sha256(data).hexdigest()


@dataclass(frozen=True)
class ServiceConfig:
    """Settings: the largest batch (bytes), the jobs' seed, IRL settings (None: defaults), and
    ``settle_s``: a learning job starts once its (driver, condition) has had no new batch for
    this long, s (0: at once), so that a burst of uploads (a vehicle's four manual trips)
    learns one version, not one from the first trip and another from all of them."""

    max_upload_bytes: int = DEFAULT_MAX_UPLOAD_BYTES
    seed: int = 0
    irl: IrlConfig | None = None
    settle_s: float = 0.0


class DeferredExecutor(Executor):
    """Queues jobs until :meth:`run_pending` (a sync pass of many batches learns once);
    ``threads`` > 1 runs that many queued jobs at a time (training elsewhere, on Dask)."""

    def __init__(self, threads: int = 1) -> None:
        self._queue: list[tuple[Future[Any], Callable[..., Any], tuple[Any, ...]]] = []
        self._lock = threading.Lock()
        self.threads = max(1, threads)

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future[Any]:
        """Queue ``fn(*args)``; its future completes in :meth:`run_pending`."""
        if kwargs:
            raise TypeError("DeferredExecutor.submit takes positional arguments only")
        future: Future[Any] = Future()
        with self._lock:
            self._queue.append((future, fn, args))
        return future

    def run_pending(self) -> None:
        """Run every queued job, oldest first: in the caller's thread, or ``threads`` at a
        time in a pool of threads."""
        while True:
            with self._lock:
                batch, self._queue = self._queue, []
            if not batch:
                return
            if self.threads == 1 or len(batch) == 1:
                for job in batch:
                    _complete(*job)
            else:
                with ThreadPoolExecutor(min(self.threads, len(batch)), "pacc-deferred") as pool:
                    list(pool.map(lambda job: _complete(*job), batch))


def _complete(future: Future[Any], fn: Callable[..., Any], args: tuple[Any, ...]) -> None:
    try:
        future.set_result(fn(*args))
    except BaseException as exc:  # the future carries it, as a pool's would
        future.set_exception(exc)


def train_table(
    manual: list[Trip],
    corrections: list[Trip],
    previous: Dgpt | None,
    driver_id: str,
    condition: str,
    seed: int,
    irl: IrlConfig | None,
) -> Dgpt:
    """A job's training, pure: ``previous`` (None: learned from the ``manual`` trips)
    fine-tuned with the ``corrections``; DemoError if the data are not enough yet. One BLAS
    thread: the same table on any engine."""
    from cloud_sync.irl.trainer import fine_tune, learn_dgpt  # noqa: PLC0415 - see imports

    with single_blas_thread():
        if previous is None:
            previous = learn_dgpt(
                manual, driver_id=driver_id, condition=condition, seed=seed, config=irl
            ).table
        table = previous
        if corrections:
            table = fine_tune(corrections, table, seed=seed, config=irl).table
        return table


@dataclass
class _JobState:
    running: bool = False
    dirty: bool = False
    touched: float = 0.0  # time.monotonic() of its newest batch
    futures: list[Future[Any]] = field(default_factory=list)


class CloudService:
    """The cloud over ``store``, signing with ``key``; learning jobs on ``executor`` (None:
    inline), their training on ``compute`` (None: the job's thread; not closed here)."""

    def __init__(
        self,
        store: CloudStore,
        key: Ed25519PrivateKey,
        executor: Executor | None = None,
        config: ServiceConfig | None = None,
        compute: Executor | None = None,
    ) -> None:
        self.compute = compute
        self.store = store
        self.key = key
        self.executor = executor if executor is not None else InlineExecutor()
        self.config = config if config is not None else ServiceConfig()
        self._jobs: dict[tuple[str, str], _JobState] = {}
        self._jobs_lock = threading.Lock()
        #: errors of learning jobs, newest last (a job never takes the service down)
        self.job_errors: list[str] = []

    @classmethod
    def open(
        cls,
        data_dir: str | os.PathLike[str],
        executor: Executor | None = None,
        config: ServiceConfig | None = None,
        compute: Executor | None = None,
    ) -> CloudService:
        """The service over ``data_dir``, creating the folder and its signing key if new."""
        store = CloudStore(data_dir)
        keys = Path(data_dir) / "keys"
        keys.mkdir(exist_ok=True)
        if not (keys / "cloud.key").exists():
            save_private_key(new_private_key(), keys / "cloud.key")
        key = load_private_key(keys / "cloud.key")
        if not (keys / "cloud.pub").is_file():  # new, or deleted: vehicles must find it
            (keys / "cloud.pub").write_bytes(public_pem(key))
        if store.orphans_removed:
            log.warning("removed %d partial file(s) of a killed run", store.orphans_removed)
        service = cls(store, key, executor, config, compute)
        service.resume()
        return service

    # -- vehicles and drivers -----------------------------------------------------------

    def register_vehicle(self, vehicle_id: str) -> str:
        """Register a vehicle without drivers; return its token (:meth:`register`)."""
        return self.register(vehicle_id, [])

    def register(
        self, vehicle_id: str, drivers: list[str], keep_token: Callable[[str], None] | None = None
    ) -> str:
        """Register a vehicle and its drivers in one transaction (``keep_token(token)`` inside
        it: all or nothing); the token. StoreError: names not plain, vehicle or driver taken."""
        token = self.update_vehicle(
            vehicle_id, drivers, token="new", keep_token=keep_token, new=True
        )
        assert token is not None
        return token

    def update_vehicle(
        self,
        vehicle_id: str,
        drivers: list[str],
        *,
        token: str | None = None,
        keep_token: Callable[[str], None] | None = None,
        new: bool = False,
    ) -> str | None:
        """Add ``drivers`` to a vehicle (``new``: a new one) and, with ``token`` ``"new"``,
        issue a fresh token (returned; ``keep_token`` inside the transaction) or ``"revoke"``
        it. StoreError."""
        _check_names(vehicle_id, drivers)
        fresh = secrets.token_urlsafe(32) if token == "new" else None
        # revoked: a value no token's SHA-256 (hex) can equal
        revoked = f"revoked-{secrets.token_hex(16)}" if token == "revoke" else None
        digest = sha256_hex(fresh.encode()) if fresh is not None else revoked
        hook = None if fresh is None or keep_token is None else (lambda: keep_token(fresh))
        self.store.save_vehicle(vehicle_id, digest, drivers, hook, new=new)
        return fresh

    def register_driver(self, vehicle_id: str, driver_id: str) -> None:
        """Bind ``driver_id`` to ``vehicle_id`` (:meth:`update_vehicle`)."""
        self.update_vehicle(vehicle_id, [driver_id])

    def authenticate(self, token: str | None) -> str:
        """The vehicle holding ``token``; :class:`AuthError` if none."""
        vehicle = self.store.vehicle_by_token(sha256_hex(token.encode())) if token else None
        if vehicle is None:
            raise AuthError("unknown or missing vehicle token")
        return vehicle

    def _own(self, vehicle_id: str, driver_id: str) -> None:
        if self.store.driver_vehicle(driver_id) != vehicle_id:
            raise ForbiddenError(f"driver {driver_id!r} is not registered to this vehicle")

    # -- ingest -------------------------------------------------------------------------

    def upload(self, vehicle_id: str, data: bytes) -> Receipt:
        """Ingest one batch from ``vehicle_id`` (see the module docstring)."""
        if len(data) > self.config.max_upload_bytes:
            raise PayloadTooLargeError(
                f"{len(data)} bytes exceed the limit of {self.config.max_upload_bytes}"
            )
        with storage_errors():
            trip, kind = parse_batch(data)
        driver_id = trip.meta.get("driver_id")
        if not isinstance(driver_id, str) or not driver_id:
            raise BadBatchError("the trip log names no driver_id in its metadata")
        condition = trip.meta.get("condition") or "default"
        check_plain(BadBatchError, driver_id=driver_id, condition=condition)
        self._own(vehicle_id, driver_id)
        digest = sha256_hex(data)
        row = BatchRow(
            0, digest, vehicle_id, driver_id, condition, kind.value, len(data), utc_now_iso(), None
        )
        with storage_errors():
            added = self.store.add_batch(row, data)
        if added:
            self.schedule(driver_id, condition)
        return Receipt(digest=digest, driver_id=driver_id, kind=row.kind, duplicate=not added)

    # -- learning -----------------------------------------------------------------------

    def schedule(self, driver_id: str, condition: str) -> None:
        """Run a learning job for the driver soon; jobs of one key never overlap."""
        key = (driver_id, condition)
        with self._jobs_lock:
            state = self._jobs.setdefault(key, _JobState())
            state.touched = time.monotonic()
            if state.running:
                state.dirty = True  # the running job will run once more
                return
            state.running = True
        try:  # outside the lock: an inline executor runs the job (which takes it) right here
            future = self.executor.submit(self._job_loop, key)
        except Exception:  # a pool shut down: the key must be schedulable again
            with self._jobs_lock:
                state.running = False
            raise
        with self._jobs_lock:
            state.futures = [f for f in state.futures if not f.done()] + [future]

    def resume(self) -> None:
        """Schedule every (driver, condition) with batches not learned from yet: the jobs a
        crash or a restart dropped (called by :meth:`open`)."""
        for driver_id, condition in self.store.unused_keys():
            self.schedule(driver_id, condition)

    def _settle(self, state: _JobState) -> None:
        """Wait until no batch came for ``config.settle_s`` s (the run then reads them all)."""
        if self.config.settle_s > 0.0:
            while (left := state.touched + self.config.settle_s - time.monotonic()) > 0.0:
                time.sleep(left)
            state.dirty = False  # a batch stored after this still marks it (schedule)

    def _job_loop(self, key: tuple[str, str]) -> None:
        state = self._jobs[key]
        while True:
            self._settle(state)
            try:
                self.learn_once(*key)
            except Exception as exc:  # a job's failure is reported, never raised at a client
                self.job_errors.append(f"{key[0]}/{key[1]}: {type(exc).__name__}: {exc}")
                log.exception("learning job %s/%s failed", *key)
            with self._jobs_lock:
                if not state.dirty:
                    state.running = False
                    return
                state.dirty = False

    def wait_idle(self, timeout_s: float | None = None) -> None:
        """Block until every learning job scheduled so far has finished (a deferred
        executor's queue runs now, in this thread)."""
        if isinstance(self.executor, DeferredExecutor):
            self.executor.run_pending()
        with self._jobs_lock:
            futures = [f for state in self._jobs.values() for f in state.futures]
        for future in futures:
            future.result(timeout=timeout_s)

    def learn_once(self, driver_id: str, condition: str) -> int | None:
        """Learn the driver's next version from the unused batches (new manual trips: relearn
        from all, then fine-tune with every correction; else fine-tune); None if nothing."""
        unused = self.store.batches(driver_id, condition, unused_only=True)
        if not unused:
            return None
        cfg = self.config
        previous = self.latest_table(driver_id, condition)
        relearn = previous is None or any(b.kind == TripMode.MANUAL for b in unused)
        batches = self.store.batches(driver_id, condition) if relearn else unused
        if relearn and not any(b.kind == TripMode.MANUAL for b in batches):
            return None  # the first table needs manual driving; read nothing until then
        manual = self._trips(b for b in batches if b.kind == TripMode.MANUAL)
        corrections = self._trips(b for b in batches if b.kind != TripMode.MANUAL)
        args = (manual, corrections, None if relearn else previous, driver_id, condition)
        try:
            if self.compute is None:
                table = train_table(*args, cfg.seed, cfg.irl)
            else:
                table = self.compute.submit(train_table, *args, cfg.seed, cfg.irl).result()
        except DemoError as exc:  # not enough evidence yet: wait for more batches
            log.info("learning %s/%s waits for data: %s", driver_id, condition, exc)
            return None
        return self.publish(table, [b.digest for b in unused])

    def _trips(self, batches: Iterable[BatchRow]) -> list[Trip]:
        """The trips of ``batches`` in digest order."""
        ordered = sorted(batches, key=lambda b: b.digest)
        return [
            trip_from_bytes(self.store.read_blob(b.digest), f"batch {b.digest}") for b in ordered
        ]

    def publish(self, table: Dgpt, used: list[str]) -> int:
        """Sign and keep ``table`` as the next version; mark the batches ``used``."""
        versions = self.store.versions(table.driver_id, table.condition)
        if versions and table.version <= versions[-1].version:
            table = replace(table, version=versions[-1].version + 1)  # versions only grow
        row = VersionRow(
            table.driver_id,
            table.condition,
            table.version,
            table.source,
            table.created_utc,
            len(used),
        )
        self.store.add_version(row, sign_dgpt(table, self.key), used)
        log.info("published DGPT %s/%s v%d", row.driver_id, row.condition, row.version)
        return table.version

    # -- publishing ---------------------------------------------------------------------

    def latest_signed(self, vehicle_id: str, driver_id: str, condition: str = "default") -> bytes:
        """The newest signed table of one of the vehicle's drivers (NotFoundError if none)."""
        self._own(vehicle_id, driver_id)
        if not is_plain_name(condition):
            raise NotFoundError(f"no condition {condition!r}: conditions are plain names")
        versions = self.store.versions(driver_id, condition)
        if not versions:
            raise NotFoundError(f"no DGPT for driver {driver_id!r} under {condition!r} yet")
        return self.store.read_version(versions[-1])

    def latest_table(self, driver_id: str, condition: str) -> Dgpt | None:
        """The newest published table (verified with the cloud's own key), or None."""
        versions = self.store.versions(driver_id, condition)
        if not versions:
            return None
        return verify_dgpt(self.store.read_version(versions[-1]), self.key.public_key())

    def public_key_pem(self) -> bytes:
        """The public half of the signing key (PEM)."""
        return public_pem(self.key)


def _check_names(vehicle_id: str, drivers: list[str]) -> None:
    check_plain(StoreError, vehicle_id=vehicle_id)
    for driver_id in drivers:
        check_plain(StoreError, driver_id=driver_id)
    if len(set(drivers)) != len(drivers):
        raise StoreError(f"a driver id is repeated: {', '.join(drivers)}")
