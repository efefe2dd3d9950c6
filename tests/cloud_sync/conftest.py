"""Fixtures of the cloud tests: the synthetic follower of :mod:`cloud_sync.irl.sources.synthetic`
and the service served over HTTP on 127.0.0.1."""

from __future__ import annotations

import dataclasses
import hashlib
import socket
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any

import httpx
import numpy as np
import pytest
import uvicorn

from cloud_sync.irl.sources.synthetic import follower_trip, lead_speed
from cloud_sync.irl.trainer import LearnResult, learn_dgpt
from cloud_sync.service.http import create_app
from cloud_sync.service.rules import CloudService
from dbc.vocab.acc_state import AccState
from dbc.vocab.triplog import Trip

__all__ = ["follower_trip", "lead_speed", "takeover_segment"]

#: the operator's token of every served cloud
OPERATOR = "operator-secret-token"


class Served:
    """The app of a service under uvicorn in a thread, on an ephemeral loopback port;
    :meth:`serve` points the running server at another service (a module shares one)."""

    def __init__(self, service: CloudService | None = None) -> None:
        self.app: Any = None
        if service is not None:
            self.serve(service)
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.url = f"http://127.0.0.1:{self.sock.getsockname()[1]}"
        config = uvicorn.Config(
            self._dispatch, log_level="warning", lifespan="off", interface="asgi3"
        )
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(
            target=self.server.run, kwargs={"sockets": [self.sock]}, daemon=True
        )
        self.thread.start()
        deadline = time.monotonic() + 10.0
        while not self.server.started and time.monotonic() < deadline:
            time.sleep(0.01)
        assert self.server.started

    def serve(self, service: CloudService) -> None:
        """Answer every later request with ``service``'s app."""
        self.app = create_app(service, hashlib.sha256(OPERATOR.encode()).hexdigest())

    async def _dispatch(self, scope: Any, receive: Any, send: Any) -> None:
        await self.app(scope, receive, send)

    def get(self, path: str, token: str | None) -> Any:
        headers = {"Authorization": f"Bearer {token}"} if token else {}
        return httpx.get(self.url + path, headers=headers, timeout=30.0)

    def stop(self) -> None:
        self.server.should_exit = True
        self.thread.join(10.0)
        self.sock.close()


@pytest.fixture(scope="module")
def http_server() -> Iterator[Served]:
    """One served cloud for a module's tests, each pointing it at its own service."""
    served = Served()
    yield served
    served.stop()


def takeover_segment(
    seed: int, presses: list[tuple[int, int, str]], n: int = 200, driver_id: str = "syn"
) -> Trip:
    """A 10 Hz takeover segment of ``n`` samples of the follower: the ACC Active, and each
    press ``(first, end, pedal)`` a pedal held on samples ``first..end-1`` (``accel``:
    Override; ``brake``: cancelled to Standby, as ``brake_mode="cancel"`` does). Known answer:
    ``sum(end - first) * 0.1`` s of intervention and ``len(presses)`` takeovers (presses
    apart)."""
    base = follower_trip(seed, minutes=n / 600.0)
    state = np.full(n, int(AccState.ACTIVE), dtype=np.int64)
    accel, brake = np.zeros(n), np.zeros(n)
    for first, end, pedal in presses:
        if pedal == "accel":
            state[first:end], accel[first:end] = int(AccState.OVERRIDE), 0.3
        else:
            state[first:end], brake[first:end] = int(AccState.STANDBY), 0.4
    return dataclasses.replace(
        base,
        acc_state=state,
        accel_pedal=accel,
        brake_pedal=brake,
        meta={"driver_id": driver_id, "condition": "default", "mode": "takeover", "seed": seed},
    )


@pytest.fixture(scope="session")
def follower() -> Callable[..., Trip]:
    """The :func:`follower_trip` factory."""
    return follower_trip


@pytest.fixture(scope="session")
def syn_trips() -> list[Trip]:
    """Four 5-minute manual drives of the follower with preference 4 m + 1.6 s·v."""
    return [follower_trip(s) for s in range(4)]


@pytest.fixture(scope="session")
def syn_learned_one(syn_trips: list[Trip]) -> LearnResult:
    """What driver syn's first drive learns with seed 0 (tests only read it)."""
    return learn_dgpt(syn_trips[:1], driver_id="syn", seed=0)
