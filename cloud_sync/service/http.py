"""The cloud as an HTTP service (FastAPI): ``pacc cloud serve --data DIR --port 8080``.

Routes: ``POST /v1/batches`` (raw MCAP bytes -> receipt), ``POST /v1/trips`` (a trip report),
``GET /v1/drivers/{driver}/dgpt`` (newest signed DGPT, ``?condition=``), ``GET /v1/key`` (PEM)
and ``GET /v1/health``; every call but the last two needs ``Authorization: Bearer <token>``.
Errors answer ``{"detail": ...}`` with :mod:`cloud_sync.api`'s statuses; a full disk 507, any
other storage failure 503 (both with ``Retry-After``); an upload past the limit 413 before it
is read whole. OpenAPI at ``/openapi.json``, Swagger UI at ``/docs`` (served offline).

Read-only views (:class:`ServiceViews`): ``GET /v1/drivers``, ``/v1/drivers/{driver}/versions``
(tables with their metadata and gaps), ``.../batches``, ``.../trips`` (the per-trip learning
curve, :mod:`cloud_sync.service.trips`) and ``/v1/jobs``: a vehicle token sees its own drivers,
an operator token (``--operator-token-file``; only its SHA-256 kept) all of them.
``GET /dashboard`` is one self-contained page (no CDN) that draws these.
"""

from __future__ import annotations

import hmac
import json
import logging
from dataclasses import asdict
from pathlib import Path
from typing import Any

from fastapi import FastAPI, Request, Security
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import HTMLResponse, JSONResponse, Response
from fastapi.security import HTTPBearer
from fastapi.staticfiles import StaticFiles
from pydantic import BaseModel
from starlette.concurrency import run_in_threadpool
from starlette.requests import ClientDisconnect
from swagger_ui_bundle import swagger_ui_path

from cloud_sync.api import (
    BadBatchError,
    CloudError,
    ForbiddenError,
    NotFoundError,
    PayloadTooLargeError,
    Receipt,
    TripReceipt,
)
from cloud_sync.service.rules import CloudService, sha256_hex
from cloud_sync.service.trips import record_trip, trip_rows

log = logging.getLogger(__name__)

#: seconds a vehicle is asked to wait after a 503 or 507 (full disk) answer
RETRY_AFTER_S = 60
#: the largest trip report, bytes (10,000 segment digests fit)
TRIP_REPORT_LIMIT = 1024 * 1024
DASHBOARD = Path(__file__).with_name("dashboard.html")


class ErrorDetail(BaseModel):
    """The body of every error answer."""

    detail: str


#: documents the bearer scheme; the check itself is CloudService.authenticate
_BEARER = HTTPBearer(auto_error=False, description="the vehicle's token (pacc cloud register)")


def _errors(*statuses: int) -> dict[int | str, dict[str, Any]]:
    what = {
        401: "unknown or missing vehicle token",
        403: "the driver is not registered to this vehicle",
        404: "no such table (yet)",
        413: "the batch exceeds the upload limit",
        422: "not a pacc trip log (or trip report), or names that are not plain",
        503: "the cloud's storage failed: retry after Retry-After seconds",
        507: "the cloud's disk is full: retry after Retry-After seconds",
    }
    return {s: {"model": ErrorDetail, "description": what[s]} for s in statuses}


def _token(request: Request) -> str | None:
    header = request.headers.get("authorization", "")
    scheme, _, value = header.partition(" ")
    return value.strip() if scheme.lower() == "bearer" and value.strip() else None


async def _body(request: Request, limit: int) -> bytes:
    declared = request.headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > limit:
        raise PayloadTooLargeError(f"{declared} bytes exceed the limit of {limit}")
    chunks: list[bytes] = []
    size = 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise PayloadTooLargeError(f"upload exceeds the limit of {limit} bytes")
        chunks.append(chunk)
    return b"".join(chunks)


def create_app(service: CloudService, operator_token_sha256: str | None = None) -> FastAPI:
    """The HTTP application over ``service``; ``operator_token_sha256``: the operator token's
    SHA-256 (hex) for the read-only :class:`ServiceViews`."""
    app = FastAPI(
        title="pacc cloud",
        version="1",
        description="Trip-log ingest, per-driver DGPT learning and signed DGPT download.",
        docs_url=None,  # served below from the packaged assets, not from a CDN
        redoc_url=None,
    )
    # the bundled Swagger UI (4.x) renders OpenAPI 3.0 only, and the description needs no 3.1
    app.openapi_version = "3.0.3"
    app.mount("/static/swagger-ui", StaticFiles(directory=swagger_ui_path), name="swagger-ui")

    @app.get("/docs", include_in_schema=False)
    def docs() -> HTMLResponse:
        return get_swagger_ui_html(
            openapi_url=app.openapi_url or "/openapi.json",
            title="pacc cloud",
            swagger_js_url="/static/swagger-ui/swagger-ui-bundle.js",
            swagger_css_url="/static/swagger-ui/swagger-ui.css",
            swagger_favicon_url="/static/swagger-ui/favicon-32x32.png",
        )

    @app.exception_handler(CloudError)
    async def _cloud_error(_: Request, exc: CloudError) -> JSONResponse:
        # 503/507: the vehicle keeps the batch and comes back later
        headers = {"Retry-After": str(RETRY_AFTER_S)} if exc.status in (503, 507) else None
        return JSONResponse({"detail": str(exc)}, status_code=exc.status, headers=headers)

    @app.exception_handler(ClientDisconnect)
    async def _gone(request: Request, _: ClientDisconnect) -> Response:
        # the vehicle keeps the batch and retries: one line, not a traceback
        peer = request.client.host if request.client else "?"
        log.warning(
            "%s %s: client %s disconnected mid-upload", request.method, request.url.path, peer
        )
        return Response(status_code=400)

    @app.post(
        "/v1/batches",
        status_code=201,
        response_model=Receipt,
        dependencies=[Security(_BEARER)],
        responses=_errors(401, 403, 413, 422, 503, 507)
        | {200: {"model": Receipt, "description": "already held (a duplicate)"}},
        openapi_extra={
            "requestBody": {
                "required": True,
                "description": "one batch: the raw bytes of an MCAP trip log",
                "content": {
                    "application/octet-stream": {"schema": {"type": "string", "format": "binary"}}
                },
            }
        },
    )
    async def upload(request: Request) -> JSONResponse:
        vehicle = service.authenticate(_token(request))
        data = await _body(request, service.config.max_upload_bytes)
        receipt = await run_in_threadpool(service.upload, vehicle, data)  # parse, fsync, index
        return JSONResponse(asdict(receipt), status_code=200 if receipt.duplicate else 201)

    @app.post(
        "/v1/trips",
        status_code=201,
        response_model=TripReceipt,
        dependencies=[Security(_BEARER)],
        responses=_errors(401, 403, 413, 422, 503)
        | {200: {"model": TripReceipt, "description": "already held (a duplicate)"}},
        openapi_extra={
            "requestBody": {
                "required": True,
                "description": "a trip report (cloud_sync.service.trips)",
                "content": {"application/json": {"schema": {"type": "object"}}},
            }
        },
    )
    async def report_trip(request: Request) -> JSONResponse:
        vehicle = service.authenticate(_token(request))
        data = await _body(request, TRIP_REPORT_LIMIT)
        try:
            body = json.loads(data)
        except (ValueError, UnicodeDecodeError) as exc:
            raise BadBatchError(f"a trip report is JSON: {exc}") from exc
        except RecursionError as exc:
            raise BadBatchError("a trip report is JSON nested a few levels deep") from exc
        receipt = await run_in_threadpool(record_trip, service, vehicle, body)
        return JSONResponse(asdict(receipt), status_code=200 if receipt.duplicate else 201)

    @app.get(
        "/v1/drivers/{driver_id}/dgpt",
        dependencies=[Security(_BEARER)],
        responses=_errors(401, 403, 404)
        | {200: {"content": {"application/json": {}}, "description": "the signed DGPT"}},
    )
    def latest_dgpt(driver_id: str, request: Request, condition: str = "default") -> Response:
        vehicle = service.authenticate(_token(request))
        data = service.latest_signed(vehicle, driver_id, condition)
        return Response(content=data, media_type="application/json")

    @app.get("/v1/key")
    def key() -> Response:
        return Response(content=service.public_key_pem(), media_type="application/x-pem-file")

    @app.get("/v1/health")
    def health() -> dict[str, Any]:
        return {"status": "ok", "batches": service.store.batch_count()}

    _views(app, ServiceViews(service, operator_token_sha256))
    return app


def _views(app: FastAPI, views: ServiceViews) -> None:
    """The read-only list endpoints and the dashboard (:class:`ServiceViews`)."""

    @app.get("/v1/drivers")
    def drivers(request: Request) -> list[dict[str, Any]]:
        return views.drivers(views.viewer(_token(request)))

    @app.get("/v1/drivers/{driver_id}/versions")
    def versions(driver_id: str, request: Request) -> list[dict[str, Any]]:
        return views.versions(views.viewer(_token(request)), driver_id)

    @app.get("/v1/drivers/{driver_id}/batches")
    def batches(driver_id: str, request: Request) -> list[dict[str, Any]]:
        return views.batches(views.viewer(_token(request)), driver_id)

    @app.get("/v1/drivers/{driver_id}/trips")
    def trips(driver_id: str, request: Request) -> list[dict[str, Any]]:
        return views.trips(views.viewer(_token(request)), driver_id)

    @app.get("/v1/jobs")
    def jobs(request: Request) -> list[dict[str, Any]]:
        return views.jobs(views.viewer(_token(request)))

    @app.get("/dashboard")
    def dashboard() -> Response:
        return Response(content=views.page(), media_type="text/html; charset=utf-8")


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
