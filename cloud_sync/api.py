"""The contract between a vehicle and the cloud, whatever carries it.

Two backends implement :class:`CloudApi`: :class:`cloud_sync.service.local.LocalCloud` (the service
in-process over a local folder: the zero-set-up default) and
:class:`cloud_sync.vehicle.client.HttpCloud`
(a running ``pacc cloud serve``). Both raise the same errors, each with the HTTP status the
service answers with, so one test suite checks both:

=====================  ======  ==========================================================
error                  status  meaning
=====================  ======  ==========================================================
AuthError              401     no token, or a token the cloud does not know
ForbiddenError         403     the driver is not registered to this vehicle
NotFoundError          404     no such driver table (yet)
PayloadTooLargeError   413     the upload exceeds the service's size limit
BadBatchError          422     the upload is not a readable pacc trip log (stored nowhere)
CloudUnavailableError  503     the cloud cannot be reached or failed: retry later
=====================  ======  ==========================================================

Only :class:`CloudUnavailableError` is worth a retry; the others are answers.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from cloud_sync.errors import CloudSyncError


class CloudError(CloudSyncError):
    """An answer of the cloud that is not a success. ``status`` is its HTTP status."""

    status = 500


class AuthError(CloudError):
    """No token, or an unknown one."""

    status = 401


class ForbiddenError(CloudError):
    """The driver is not registered to this vehicle."""

    status = 403


class NotFoundError(CloudError):
    """No such driver table (yet)."""

    status = 404


class PayloadTooLargeError(CloudError):
    """The upload exceeds the size limit."""

    status = 413


class BadBatchError(CloudError):
    """The upload is not a readable pacc trip log."""

    status = 422


class CloudUnavailableError(CloudError):
    """The cloud cannot be reached, timed out or failed (5xx): retry later."""

    status = 503


#: status -> error class, for the HTTP client
ERRORS_BY_STATUS: dict[int, type[CloudError]] = {
    cls.status: cls
    for cls in (
        AuthError,
        ForbiddenError,
        NotFoundError,
        PayloadTooLargeError,
        BadBatchError,
        CloudUnavailableError,
    )
}


_PLAIN_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


def is_plain_name(value: object) -> bool:
    """True for a driver id or condition the cloud accepts: 1-64 characters of letters,
    digits, ``_ . -``, starting with a letter or digit (so never ``..``, ``/`` or absolute:
    these names become folder names in the cloud's store and on the vehicle)."""
    return isinstance(value, str) and _PLAIN_NAME.fullmatch(value) is not None


@dataclass(frozen=True)
class Receipt:
    """The cloud's acknowledgement of one uploaded batch.

    Attributes:
        digest: SHA-256 of the batch's bytes, hex (the vehicle deletes its copy by it).
        driver_id: whose trip it is (from the trip's metadata).
        kind: ``takeover``, ``manual`` or ``acc``.
        duplicate: the cloud held this batch already (nothing stored again).
    """

    digest: str
    driver_id: str
    kind: str
    duplicate: bool


@dataclass(frozen=True)
class TripReceipt:
    """The cloud's acknowledgement of one trip report (:mod:`cloud_sync.service.trips`).

    Attributes:
        trip_id: the vehicle's id of the trip.
        driver_id: whose trip it was.
        duplicate: the cloud held this very report already (nothing stored again).
    """

    trip_id: str
    driver_id: str
    duplicate: bool


class CloudApi(Protocol):
    """What a vehicle can ask of the cloud (one vehicle's view: its token is bound in)."""

    def upload(self, data: bytes) -> Receipt:
        """Deliver one batch (an MCAP trip log); idempotent by the bytes' digest."""
        ...

    def latest_dgpt(self, driver_id: str, condition: str = "default") -> bytes:
        """The newest signed DGPT of the driver (NotFoundError if none yet)."""
        ...

    def public_key_pem(self) -> bytes:
        """The cloud's public signing key (PEM)."""
        ...

    def wait_learned(
        self, driver_id: str, condition: str = "default", timeout_s: float = 120.0
    ) -> None:
        """Return once the cloud's learning job for (driver, condition) is idle, i.e. the
        batches uploaded so far are learned from (CloudUnavailableError after ``timeout_s``)."""
        ...

    def report_trip(self, report: Mapping[str, Any]) -> TripReceipt:
        """Report one ACC trip after its takeover segments were uploaded (the fields:
        :mod:`cloud_sync.service.trips`); idempotent per (driver, trip id)."""
        ...


__all__ = [
    "ERRORS_BY_STATUS",
    "AuthError",
    "BadBatchError",
    "CloudApi",
    "CloudError",
    "CloudUnavailableError",
    "ForbiddenError",
    "NotFoundError",
    "PayloadTooLargeError",
    "Receipt",
    "TripReceipt",
    "is_plain_name",
]
