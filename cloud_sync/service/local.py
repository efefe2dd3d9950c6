"""The embedded cloud: the service in-process over a local folder, as a :class:`CloudApi`.

``LocalCloud.open(DIR, token)`` is what ``pacc study`` and ``pacc ecu --cloud DIR`` use when
no server runs: the same rules (tokens, driver ownership, size limit, validation, signing) as
``pacc cloud serve``, without a network. Its learning jobs are deferred until a table is asked
for (:class:`~cloud_sync.service.rules.DeferredExecutor`): a sync pass of many batches learns once,
in the caller's thread, deterministically.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from cloud_sync.api import Receipt, TripReceipt
from cloud_sync.service.rules import CloudService, DeferredExecutor, ServiceConfig
from cloud_sync.service.trips import record_trip


class LocalCloud:
    """One vehicle's view of an in-process :class:`CloudService` (its token bound in)."""

    def __init__(self, service: CloudService, token: str) -> None:
        self.service = service
        self.token = token

    @classmethod
    def open(
        cls, data_dir: str | os.PathLike[str], token: str, config: ServiceConfig | None = None
    ) -> LocalCloud:
        """The embedded cloud over ``data_dir`` (created with its key if new)."""
        return cls(CloudService.open(data_dir, DeferredExecutor(), config), token)

    def upload(self, data: bytes) -> Receipt:
        """Deliver one batch (its learning job waits for the next :meth:`latest_dgpt`)."""
        return self.service.upload(self.service.authenticate(self.token), data)

    def latest_dgpt(self, driver_id: str, condition: str = "default") -> bytes:
        """The newest signed DGPT of one of this vehicle's drivers (learning what is due)."""
        vehicle = self.service.authenticate(self.token)
        self.service.wait_idle()
        return self.service.latest_signed(vehicle, driver_id, condition)

    def public_key_pem(self) -> bytes:
        """The cloud's public signing key (PEM)."""
        return self.service.public_key_pem()

    def wait_learned(
        self, driver_id: str, condition: str = "default", timeout_s: float = 120.0
    ) -> None:
        """Run the learning due now (every driver's: the jobs are deferred), up to ``timeout_s``."""
        self.service.authenticate(self.token)
        self.service.wait_idle(timeout_s)

    def report_trip(self, report: Mapping[str, Any]) -> TripReceipt:
        """Report one ACC trip (:mod:`cloud_sync.service.trips`), after its segments."""
        vehicle = self.service.authenticate(self.token)
        return record_trip(self.service, vehicle, dict(report))


__all__ = ["LocalCloud"]
