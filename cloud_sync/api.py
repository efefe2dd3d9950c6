"""The contract between a vehicle and the cloud, whatever carries it.

Two backends implement :class:`CloudApi`: :class:`cloud_sync.service.local.LocalCloud` (in
process, over a folder) and :class:`cloud_sync.vehicle.client.HttpCloud` (``pacc cloud
serve``). Both raise the same errors, each with its HTTP status: AuthError 401, ForbiddenError
403, NotFoundError 404, PayloadTooLargeError 413, BadBatchError 422, CloudUnavailableError 503
(the only one worth a retry). :func:`check_plausible` is what both sides accept as a batch.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from cloud_sync.errors import CloudSyncError

if TYPE_CHECKING:
    from dbc.vocab.triplog import Trip


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


#: status -> error class (the six above), for the HTTP client
ERRORS_BY_STATUS: dict[int, type[CloudError]] = {c.status: c for c in CloudError.__subclasses__()}


def is_plain_name(value: object) -> bool:
    """True for a vehicle id, driver id or condition: :data:`dbc.vocab.dgpt.PLAIN_NAME`."""
    from dbc.vocab.dgpt import PLAIN_NAME  # noqa: PLC0415 - numpy: `pacc cloud --help` skips it

    return isinstance(value, str) and PLAIN_NAME.fullmatch(value) is not None


def check_plain(error: type[CloudSyncError], /, **names: object) -> None:
    """Raise ``error`` naming the first of ``names`` (what=value) that is not plain."""
    for what, name in names.items():
        if not is_plain_name(name):
            raise error(f"{what} {name!r} is not a plain name (letters, digits, _.-)")


#: the most samples of one batch: 2 hours at the trip logs' 10 Hz
MAX_SAMPLES = 72_000
#: sample times, s: within ±MAX_T_S (an MCAP log time, ns in 64 bits, holds ±292 years)
MAX_T_S = 1e9
#: the fastest plausible speed, m/s (360 km/h)
MAX_SPEED_MPS = 100.0
#: the gap range, m: a collision's last sample may be a little negative
MIN_GAP_M, MAX_GAP_M = -10.0, 1000.0
#: the largest plausible acceleration magnitude, m/s² (about 2 g)
MAX_ACCEL_MPS2 = 20.0


def check_plausible(trip: Trip) -> None:
    """Refuse a trip whose samples no car recorded (module docstring); BadBatchError."""
    import numpy as np  # noqa: PLC0415 - loaded with any Trip; `pacc cloud --help` skips it

    n = len(trip)
    if not 1 <= n <= MAX_SAMPLES:
        raise BadBatchError(f"a batch holds 1 to {MAX_SAMPLES} samples, this one {n}")
    ranges = {
        "t_s": (-MAX_T_S, MAX_T_S),
        "v_mps": (0.0, MAX_SPEED_MPS),
        "v_lead_mps": (0.0, MAX_SPEED_MPS),
        "gap_m": (MIN_GAP_M, MAX_GAP_M),
        "a_mps2": (-MAX_ACCEL_MPS2, MAX_ACCEL_MPS2),
    }
    for name, (lo, hi) in ranges.items():
        column = getattr(trip, name)
        known = column[~np.isnan(column)]
        if known.size and not (known.min() >= lo and known.max() <= hi):
            bad = known[(known < lo) | (known > hi)][0]
            raise BadBatchError(
                f"implausible trip log: {name} = {bad:g} outside {lo:g}..{hi:g} "
                "(finite values or null only)"
            )


@dataclass(frozen=True)
class Receipt:
    """The cloud's receipt of one batch: its SHA-256 (hex), driver, kind (``takeover``,
    ``manual``, ``acc``) and whether the cloud held it already."""

    digest: str
    driver_id: str
    kind: str
    duplicate: bool


@dataclass(frozen=True)
class TripReceipt:
    """The cloud's receipt of one trip report: trip id, driver, held already."""

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
