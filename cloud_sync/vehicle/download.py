"""Profile download: the newest signed DGPT for (driver, condition), checked before use.

:class:`ProfileDownloader` verifies the table's Ed25519 signature and its gaps against the
vehicle's :class:`~dbc.vocab.dgpt.SafetyBounds` (:func:`cloud_sync.signing.verify_dgpt`) and
keeps the signed bytes as ``cache_dir/<driver>/<condition>.signed.json``: the last good table,
verified again whenever read. Anything else is refused and reported; the last good one stays.
"""

from __future__ import annotations

import logging
import os
from dataclasses import dataclass, field
from pathlib import Path

from cryptography.hazmat.primitives.asymmetric.ed25519 import Ed25519PublicKey

from cloud_sync.api import CloudApi, CloudError, CloudUnavailableError, NotFoundError, check_plain
from cloud_sync.errors import CloudSyncError
from cloud_sync.signing import SignatureError, verify_dgpt
from dbc.atomic import write_bytes_atomic
from dbc.vocab.dgpt import Dgpt, SafetyBounds

log = logging.getLogger(__name__)


@dataclass
class FetchReport:
    """What the downloads did (counts and the newest refusal's reason)."""

    fetched: int = 0
    unchanged: int = 0
    offline: int = 0
    not_found: int = 0
    refusals: list[str] = field(default_factory=list)

    def describe(self) -> str:
        """One human line: the counts, and the newest refusal's reason if any."""
        text = (
            f"{self.fetched} fetched, {self.unchanged} unchanged, {self.not_found} not found, "
            f"{self.offline} offline, {len(self.refusals)} refused"
        )
        return text + (f" (last: {self.refusals[-1]})" if self.refusals else "")


class ProfileDownloader:
    """Downloads from ``cloud`` the tables ``public_key`` signed within ``bounds`` (None:
    the defaults), the last good ones kept under ``cache_dir``."""

    def __init__(
        self,
        cloud: CloudApi,
        public_key: Ed25519PublicKey,
        cache_dir: str | os.PathLike[str],
        bounds: SafetyBounds | None = None,
    ) -> None:
        self.cloud = cloud
        self.public_key = public_key
        self.cache_dir = Path(cache_dir)
        self.bounds = bounds if bounds is not None else SafetyBounds()
        self.report = FetchReport()

    def cache_path(self, driver_id: str, condition: str) -> Path:
        """Where the last good signed table of (driver, condition) is kept (CloudSyncError
        for a name that is not plain: it would leave the cache folder)."""
        check_plain(CloudSyncError, driver_id=driver_id, condition=condition)
        return self.cache_dir / driver_id / f"{condition}.signed.json"

    def last_good(self, driver_id: str, condition: str = "default") -> Dgpt | None:
        """The cached table, verified again, and only if it is ``driver_id``'s in
        ``condition`` (a signature proves who signed, not for whom); else None."""
        path = self.cache_path(driver_id, condition)
        try:
            data = path.read_bytes()
        except FileNotFoundError:
            return None
        except OSError as exc:
            self._refuse(f"cached table {path} unreadable: {exc.strerror or exc}")
            return None
        return self._verified(data, driver_id, condition, f"cached table {path}")

    def fetch(self, driver_id: str, condition: str = "default") -> Dgpt | None:
        """Download, verify and cache the newest table; None if nothing new. The cloud's or
        the table's faults are counted in :attr:`report`, never raised."""
        data = self._download(driver_id, condition)
        table = None if data is None else self._verified(data, driver_id, condition)
        if data is None or table is None:
            return None
        cached = self.last_good(driver_id, condition)
        if cached is not None and cached.version >= table.version:
            self.report.unchanged += 1
            return None
        try:
            write_bytes_atomic(self.cache_path(driver_id, condition), data, durable=True)
        except OSError as exc:  # a full disk: use the table, say it is not kept for offline
            self._refuse(f"verified table not cached ({exc.strerror or exc}); used this run only")
        self.report.fetched += 1
        return table

    def _download(self, driver_id: str, condition: str) -> bytes | None:
        try:
            return self.cloud.latest_dgpt(driver_id, condition)
        except CloudUnavailableError as exc:
            self.report.offline += 1
            log.info("profile download offline: %s", exc)
        except NotFoundError:
            self.report.not_found += 1
        except CloudError as exc:
            self._refuse(f"cloud refused the download: {exc}")
        return None

    def _verified(
        self, data: bytes, driver_id: str, condition: str, what: str = "downloaded table"
    ) -> Dgpt | None:
        try:
            table = verify_dgpt(data, self.public_key, self.bounds)
        except SignatureError as exc:
            self._refuse(f"{what} refused: {exc}")
            return None
        if table.driver_id != driver_id or table.condition != condition:
            self._refuse(
                f"{what} is for {table.driver_id}/{table.condition}, "
                f"asked for {driver_id}/{condition}"
            )
            return None
        return table

    def _refuse(self, reason: str) -> None:
        self.report.refusals.append(reason)
        log.error("profile refused: %s", reason)
