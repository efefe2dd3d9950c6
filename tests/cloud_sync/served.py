"""The service served over HTTP on 127.0.0.1 for the cloud tests (uvicorn in a thread)."""

from __future__ import annotations

import hashlib
import socket
import threading
import time
from typing import Any

import httpx
import uvicorn

from cloud_sync.service.http import create_app
from cloud_sync.service.rules import CloudService

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
