"""The embedded cloud: the service in-process over a local folder, as a :class:`CloudApi`.

``LocalCloud.open(DIR, token)``: the rules of ``pacc cloud serve`` without a network; its
learning jobs are deferred until a table is asked for, in the caller's thread. A folder has one
learner at a time (:func:`hold_folder`): ``pacc cloud serve`` holds ``DIR/serving.lock``
exclusively (its URL inside), an embedded cloud shared.
"""

from __future__ import annotations

import fcntl
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from cloud_sync.api import Receipt, TripReceipt
from cloud_sync.errors import CloudSyncError
from cloud_sync.service.rules import CloudService, DeferredExecutor, ServiceConfig
from cloud_sync.service.trips import record_trip


class LocalCloud:
    """One vehicle's view of an in-process :class:`CloudService` (its token bound in)."""

    def __init__(self, service: CloudService, token: str) -> None:
        self.service = service
        self.token = token
        self.lock_fd: int | None = None

    @classmethod
    def open(
        cls, data_dir: str | os.PathLike[str], token: str, config: ServiceConfig | None = None
    ) -> LocalCloud:
        """The embedded cloud over ``data_dir`` (created with its key if new); CloudSyncError
        while a server serves the folder."""
        Path(data_dir).mkdir(parents=True, exist_ok=True)
        lock_fd = hold_folder(data_dir)  # released when the process ends
        cloud = cls(CloudService.open(data_dir, DeferredExecutor(), config), token)
        cloud.lock_fd = lock_fd
        return cloud

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


def hold_folder(data_dir: str | os.PathLike[str], server_url: str | None = None) -> int:
    """Lock the data folder: shared for an embedded cloud, exclusive for a server at
    ``server_url``; the lock's file descriptor. CloudSyncError if the other kind holds it."""
    path = Path(data_dir) / "serving.lock"
    fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, (fcntl.LOCK_EX if server_url else fcntl.LOCK_SH) | fcntl.LOCK_NB)
    except BlockingIOError:
        url = os.pread(fd, 200, 0).decode(errors="replace").strip()
        os.close(fd)
        if server_url:
            raise CloudSyncError(
                f"{data_dir} is in use by an embedded cloud (pacc ... --cloud {data_dir}): "
                "serve it when that has finished"
            ) from None
        raise CloudSyncError(
            f"{data_dir} is served by pacc cloud serve at {url or 'another process'}: "
            f"use --cloud {url or 'URL'} (an embedded sync would store batches it never learns)"
        ) from None
    if server_url:
        os.ftruncate(fd, 0)
        os.pwrite(fd, server_url.encode(), 0)
    return fd
