"""The web app of ``pacc hil``: the driving page, the gamepad calibration, one WebSocket.

``GET /`` and ``GET /calibrate`` (static, no CDN), ``GET/PUT /api/mapping`` (the gamepad
mapping file), ``WS /ws`` the session (:meth:`pacc.hil.session.Session.handle`: pedals,
buttons, frames, actions in; the view out). :class:`ServerThread` runs it with uvicorn.
"""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path
from typing import Any

import uvicorn
from fastapi import FastAPI, HTTPException, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles

from pacc.hil.records import save_json
from pacc.hil.session import Session
from sim_bus.errors import SimError

STATIC = Path(__file__).with_name("static")
#: the largest gamepad mapping accepted, bytes
MAPPING_MAX = 16_384


def default_mapping_path() -> Path:
    """``$XDG_CONFIG_HOME/pacc/gamepad.json`` or ``~/.config/pacc/gamepad.json``."""
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "pacc" / "gamepad.json"


def create_app(session: Session, mapping_path: Path) -> FastAPI:
    """The app around one ``session``; the gamepad mapping lives in ``mapping_path``."""
    app = FastAPI(title="pacc hil", docs_url=None, redoc_url=None, openapi_url=None)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")

    @app.get("/")
    def index() -> FileResponse:
        return FileResponse(STATIC / "index.html")

    @app.get("/favicon.ico")
    def favicon() -> Response:
        return Response(status_code=204)

    @app.get("/calibrate")
    def calibrate() -> FileResponse:
        return FileResponse(STATIC / "calibrate.html")

    @app.get("/api/mapping")
    def get_mapping() -> JSONResponse:
        return JSONResponse(read_mapping(mapping_path))

    @app.put("/api/mapping")
    async def put_mapping(request: Request) -> JSONResponse:
        return JSONResponse({"saved": str(save_mapping(await request.body(), mapping_path))})

    @app.websocket("/ws")
    async def ws(sock: WebSocket) -> None:
        await sock.accept()
        conn = session.connect()
        try:
            await sock.send_json(session.view())
            while True:
                msg = await sock.receive_json()
                if not isinstance(msg, dict):
                    continue
                reply = session.handle(msg)
                if reply is not None:
                    await sock.send_json(reply)
        except (WebSocketDisconnect, RuntimeError, ValueError):
            pass
        finally:
            session.disconnect(conn)

    return app


def read_mapping(path: Path) -> dict[str, Any] | None:
    """The saved gamepad mapping (None: none saved, or unreadable)."""
    try:
        return check_mapping(json.loads(path.read_text(encoding="utf-8")))
    except (OSError, ValueError, SimError):
        return None


def save_mapping(body: bytes, path: Path) -> Path:
    """Check a mapping (JSON ``body``) and write it atomically; HTTP 400/413 if refused."""
    if len(body) > MAPPING_MAX:
        raise HTTPException(413, "mapping too large")
    try:
        mapping = check_mapping(json.loads(body))
    except (ValueError, TypeError, KeyError, SimError) as exc:
        raise HTTPException(400, f"not a gamepad mapping: {exc}") from exc
    path.parent.mkdir(parents=True, exist_ok=True)
    save_json(path, mapping)
    return path


#: controls a mapping may bind: pedals (axes or buttons) and HMI buttons
CONTROLS = ("accel", "brake", "set", "resume", "cancel", "main", "gap")


def check_mapping(raw: Any) -> dict[str, Any]:
    """A gamepad mapping checked: control -> ``{"axis": i, "rest": x, "full": y}`` or
    ``{"button": i}``; SimError otherwise."""
    if not isinstance(raw, dict):
        raise SimError("a JSON object of controls")
    out: dict[str, Any] = {}
    for name, spec in raw.items():
        if name not in CONTROLS or not isinstance(spec, dict):
            raise SimError(f"unknown control {name!r}")
        if "axis" in spec:
            axis, rest, full = int(spec["axis"]), float(spec["rest"]), float(spec["full"])
            if not (0 <= axis < 64 and abs(full - rest) > 0.05):
                raise SimError(f"{name}: axis 0..63 with full travel, got {spec}")
            out[name] = {"axis": axis, "rest": rest, "full": full}
        elif "button" in spec:
            button = int(spec["button"])
            if not 0 <= button < 64:
                raise SimError(f"{name}: button 0..63")
            out[name] = {"button": button}
        else:
            raise SimError(f"{name}: needs an axis or a button")
    return out


class ServerThread:
    """uvicorn serving ``app`` on 127.0.0.1 (port 0: a free one) on a daemon thread."""

    def __init__(self, app: FastAPI, port: int = 0, host: str = "127.0.0.1") -> None:
        config = uvicorn.Config(app, host=host, port=port, log_level="warning")
        self.server = uvicorn.Server(config)
        self.thread = threading.Thread(target=self.server.run, name="pacc-hil-http", daemon=True)

    def start(self, timeout_s: float = 10.0) -> int:
        """Start serving; the port it listens on."""
        self.thread.start()
        deadline = time.monotonic() + timeout_s
        while not self.server.started:
            if time.monotonic() > deadline or not self.thread.is_alive():
                raise SimError("the hil web server did not start")
            time.sleep(0.02)
        port: int = self.server.servers[0].sockets[0].getsockname()[1]
        return port

    def stop(self) -> None:
        """Stop serving and wait for the thread."""
        self.server.should_exit = True
        self.thread.join(5.0)
