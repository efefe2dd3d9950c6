"""The cloud as an HTTP service: ``pacc cloud serve --data DIR --host 127.0.0.1 --port 8080``.

A FastAPI application over :class:`cloud_sync.service.rules.CloudService` (its OpenAPI description
is
served at ``/openapi.json``, the interactive one at ``/docs``). Every call but ``/v1/health``
and ``/v1/key`` needs ``Authorization: Bearer <vehicle token>``.

=======  ==================================  ==========================================
method   path                                what
=======  ==================================  ==========================================
POST     /v1/batches                         upload one batch (raw MCAP bytes) -> receipt
GET      /v1/drivers/{driver}/dgpt           newest signed DGPT (``?condition=``)
GET      /v1/key                             the cloud's public signing key (PEM)
GET      /v1/health                          liveness and counts
=======  ==================================  ==========================================

Errors answer ``{"detail": "..."}`` with the status of :mod:`cloud_sync.api`'s table. An upload
is refused with 413 as soon as its declared or streamed size passes the limit, before it is
read whole. Learning jobs run on the service's executor, never in the request.
"""

from __future__ import annotations

from dataclasses import asdict
from typing import Any

from fastapi import FastAPI, Request
from fastapi.responses import JSONResponse, Response
from starlette.concurrency import run_in_threadpool

from cloud_sync.api import CloudError, PayloadTooLargeError
from cloud_sync.service.rules import CloudService

#: seconds a vehicle is asked to wait after a 503 or 507 (full disk) answer
RETRY_AFTER_S = 60


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


def create_app(service: CloudService) -> FastAPI:
    """The HTTP application over ``service``."""
    app = FastAPI(
        title="pacc cloud",
        version="1",
        description="Trip-log ingest, per-driver DGPT learning and signed DGPT download.",
    )

    @app.exception_handler(CloudError)
    async def _cloud_error(_: Request, exc: CloudError) -> JSONResponse:
        # 503/507: the vehicle keeps the batch and comes back later
        headers = {"Retry-After": str(RETRY_AFTER_S)} if exc.status in (503, 507) else None
        return JSONResponse({"detail": str(exc)}, status_code=exc.status, headers=headers)

    @app.post("/v1/batches", status_code=201)
    async def upload(request: Request) -> JSONResponse:
        vehicle = service.authenticate(_token(request))
        data = await _body(request, service.config.max_upload_bytes)
        receipt = await run_in_threadpool(service.upload, vehicle, data)  # parse, fsync, index
        return JSONResponse(asdict(receipt), status_code=200 if receipt.duplicate else 201)

    @app.get("/v1/drivers/{driver_id}/dgpt")
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

    return app


__all__ = ["create_app"]
