"""What a person looks at: read-only JSON lists of the cloud's state, and the dashboard page.

``GET /v1/drivers``, ``/v1/drivers/{driver}/versions`` (tables with their metadata and gaps),
``/v1/drivers/{driver}/batches``, ``/v1/drivers/{driver}/trips`` (the per-trip learning curve,
:mod:`cloud_sync.service.trips`) and ``/v1/jobs``: a vehicle token sees its own drivers, an
operator token (``pacc cloud serve --operator-token-file``; only its SHA-256 kept) all of them.
``GET /dashboard`` is one self-contained page (no CDN) that draws these.
"""

from __future__ import annotations

import hmac
from pathlib import Path
from typing import Any

from cloud_sync.api import ForbiddenError, NotFoundError
from cloud_sync.service.rules import CloudService, sha256_hex
from cloud_sync.service.trips import trip_rows

__all__ = ["DASHBOARD", "ServiceViews"]

DASHBOARD = Path(__file__).with_name("dashboard.html")
#: the table metadata a version's view shows
_META = ("n_trips", "usable_demo_s", "covered_mps", "coverage_s", "method")


class ServiceViews:
    """The read-only views of ``service``; ``operator_token_sha256`` (hex; None: no operator)."""

    def __init__(self, service: CloudService, operator_token_sha256: str | None = None) -> None:
        self.service = service
        self.operator_sha = operator_token_sha256

    def viewer(self, token: str | None) -> str | None:
        """Who ``token`` is: a vehicle id, or None for the operator (AuthError: neither)."""
        if (
            token
            and self.operator_sha
            and hmac.compare_digest(sha256_hex(token.encode()), self.operator_sha)
        ):
            return None
        return self.service.authenticate(token)

    def _check(self, viewer: str | None, driver_id: str) -> None:
        owner = self.service.store.driver_vehicle(driver_id)
        if owner is None:
            raise NotFoundError(f"no driver {driver_id!r}")
        if viewer is not None and owner != viewer:
            raise ForbiddenError(f"driver {driver_id!r} is not registered to this vehicle")

    def drivers(self, viewer: str | None) -> list[dict[str, Any]]:
        """The drivers ``viewer`` may see, with their vehicle and conditions."""
        sql = "SELECT driver_id, vehicle_id FROM drivers"
        rows = self.service.store.query(
            sql + (" WHERE vehicle_id = ?" if viewer else "") + " ORDER BY driver_id",
            (viewer,) if viewer else (),
        )
        out = []
        for driver_id, vehicle_id in rows:
            conds = self.service.store.query(
                "SELECT DISTINCT condition FROM batches WHERE driver_id = ? UNION "
                "SELECT DISTINCT condition FROM dgpt_versions WHERE driver_id = ?",
                (driver_id, driver_id),
            )
            conditions = sorted(c for (c,) in conds)
            out.append({"driver_id": driver_id, "vehicle_id": vehicle_id, "conditions": conditions})
        return out

    def versions(self, viewer: str | None, driver_id: str) -> list[dict[str, Any]]:
        """Every table version of the driver (every condition), oldest first."""
        self._check(viewer, driver_id)
        from cloud_sync.signing import verify_dgpt  # noqa: PLC0415

        out = []
        key = self.service.key.public_key()
        for (condition,) in self.service.store.query(
            "SELECT DISTINCT condition FROM dgpt_versions WHERE driver_id = ?", (driver_id,)
        ):
            for row in self.service.store.versions(driver_id, condition):
                table = verify_dgpt(self.service.store.read_version(row), key).to_json_dict()
                meta = table.get("meta", {})
                used = self.service.store.query(
                    "SELECT digest FROM batches WHERE driver_id = ? AND condition = ? "
                    "AND used_in_version = ? ORDER BY seq",
                    (driver_id, condition, row.version),
                )
                out.append(
                    {
                        "condition": condition,
                        "version": row.version,
                        "source": row.source,
                        "created_utc": row.created_utc,
                        "n_batches": row.n_batches,
                        "batches": [d for (d,) in used],
                        "speed_mps": table["speed_mps"],
                        "gap_m": table["gap_m"],
                        "meta": {k: meta[k] for k in _META if k in meta},
                    }
                )
        return out

    def batches(self, viewer: str | None, driver_id: str) -> list[dict[str, Any]]:
        """The driver's batches in arrival order."""
        self._check(viewer, driver_id)
        rows = self.service.store.query(
            "SELECT digest, condition, kind, size_bytes, received_utc, used_in_version "
            "FROM batches WHERE driver_id = ? ORDER BY seq",
            (driver_id,),
        )
        keys = ("digest", "condition", "kind", "size_bytes", "received_utc", "used_in_version")
        return [dict(zip(keys, r, strict=True)) for r in rows]

    def trips(self, viewer: str | None, driver_id: str) -> list[dict[str, Any]]:
        """The driver's reported trips with the cloud's per-trip measures, in arrival order."""
        self._check(viewer, driver_id)
        return trip_rows(self.service, driver_id)

    def jobs(self, viewer: str | None) -> list[dict[str, Any]]:
        """The learning jobs ``viewer`` may see: (driver, condition) and their state."""
        svc = self.service
        with svc._jobs_lock:  # noqa: SLF001 - the service's own job table, under its lock
            states = {k: (s.running, s.dirty) for k, s in svc._jobs.items()}  # noqa: SLF001
        out = []
        for (driver_id, condition), (running, dirty) in sorted(states.items()):
            owner = svc.store.driver_vehicle(driver_id)
            if viewer is not None and owner != viewer:
                continue
            state = "running" if running else "queued" if dirty else "idle"
            out.append({"driver_id": driver_id, "condition": condition, "state": state})
        return out

    def page(self) -> bytes:
        """The dashboard."""
        return DASHBOARD.read_bytes()
