"""The vehicle's HTTP client of ``pacc cloud serve``, as a :class:`cloud_sync.api.CloudApi`.

Transport failures and 5xx answers become :class:`~cloud_sync.api.CloudUnavailableError`; a
4xx the error of its status (a plain :class:`~cloud_sync.api.CloudError` for 405, 409 ...).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any
from urllib.parse import quote

import httpx

from cloud_sync.api import ERRORS_BY_STATUS, CloudError, CloudUnavailableError, Receipt, TripReceipt

#: seconds to connect, and to wait for an answer (an upload waits for its ingest)
DEFAULT_TIMEOUT_S = 30.0
#: seconds between two looks at the learning jobs (:meth:`HttpCloud.wait_learned`)
POLL_S = 0.1


class HttpCloud:
    """One vehicle's (``token``) connection to the service at ``url``; ``timeout_s`` per call, s."""

    def __init__(self, url: str, token: str, *, timeout_s: float = DEFAULT_TIMEOUT_S) -> None:
        self.url = url.rstrip("/")
        self._http = httpx.Client(
            base_url=self.url,
            headers={"Authorization": f"Bearer {token}"} if token.strip() else {},
            timeout=timeout_s,
        )

    def close(self) -> None:
        """Close the connection pool."""
        self._http.close()

    def __enter__(self) -> HttpCloud:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _call(self, method: str, path: str, **kwargs: Any) -> httpx.Response:
        try:
            response = self._http.request(method, path, **kwargs)
        except httpx.TransportError as exc:
            raise CloudUnavailableError(f"{self.url}{path}: {type(exc).__name__}: {exc}") from exc
        if response.status_code >= 500:
            raise CloudUnavailableError(
                f"{self.url}{path}: HTTP {response.status_code}: {response.text[:200]}"
            )
        if response.status_code >= 400:
            try:
                detail = str(response.json().get("detail", response.text))
            except ValueError:
                detail = response.text[:200]
            error = ERRORS_BY_STATUS.get(response.status_code, CloudError)(
                f"HTTP {response.status_code}: {detail}"
            )
            error.status = response.status_code  # a plain CloudError (405, 409, 429 ...) too
            raise error
        return response

    def upload(self, data: bytes) -> Receipt:
        """Deliver one batch; the receipt the service answered with."""
        headers = {"Content-Type": "application/octet-stream"}
        body = self._call("POST", "/v1/batches", content=data, headers=headers).json()
        return Receipt(
            str(body["digest"]), str(body["driver_id"]), str(body["kind"]), bool(body["duplicate"])
        )

    def latest_dgpt(self, driver_id: str, condition: str = "default") -> bytes:
        """The newest signed DGPT of one of this vehicle's drivers."""
        return self._call(
            "GET", f"/v1/drivers/{quote(driver_id, safe='')}/dgpt", params={"condition": condition}
        ).content

    def public_key_pem(self) -> bytes:
        """The cloud's public signing key (PEM)."""
        return self._call("GET", "/v1/key").content

    def wait_learned(
        self, driver_id: str, condition: str = "default", timeout_s: float = 120.0
    ) -> None:
        """Poll ``GET /v1/jobs`` every ``POLL_S`` s until the job of (driver, condition) is
        idle or gone; CloudUnavailableError after ``timeout_s`` s."""
        deadline = time.monotonic() + timeout_s
        while True:
            busy = [
                j
                for j in self._call("GET", "/v1/jobs").json()
                if (j.get("driver_id"), j.get("condition")) == (driver_id, condition)
                and j.get("state") != "idle"
            ]
            if not busy:
                return
            if time.monotonic() > deadline:
                raise CloudUnavailableError(
                    f"{self.url}: learning {driver_id}/{condition} still "
                    f"{busy[0].get('state')} after {timeout_s:g} s"
                )
            time.sleep(POLL_S)

    def report_trip(self, report: Mapping[str, Any]) -> TripReceipt:
        """Report one ACC trip (``POST /v1/trips``); the receipt the service answered with."""
        body = self._call("POST", "/v1/trips", json=dict(report)).json()
        return TripReceipt(str(body["trip_id"]), str(body["driver_id"]), bool(body["duplicate"]))
