"""``pacc cloud serve``, ``register`` and ``vehicle``: run the cloud service, enrol vehicles.

``register`` creates the data folder and its signing key if new, registers the vehicle and its
drivers, writes the vehicle's token to F (mode 0600) and names the public key file the vehicle
must trust (``DIR/keys/cloud.pub``); an existing F (perhaps another vehicle's token) is
replaced only with ``--force``. ``vehicle`` is the operator's later change to a registered
vehicle: add drivers, issue a new token (the old one stops working at once, also for a
running server) or revoke it. Exit 2 when refused (names, a taken driver, a file in the
way), 1 when the data folder fails. ``serve`` answers HTTP on HOST:PORT (see
:mod:`cloud_sync.service.http`) and runs learning jobs on a pool of WORKERS threads; with
``--scheduler`` each job's training runs on a Dask cluster (``local``: a LocalCluster of
WORKERS processes started here; an address: that cluster), the job threads as many as the
cluster's workers (docs/scale.md).
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import socket
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from cloud_sync.engine import open_executor, workers_of
from cloud_sync.errors import CloudSyncError
from cloud_sync.vehicle.connect import write_token
from dbc.errors import error_line
from pacc.commands._args import fail, integer, number


def _do_register(args: argparse.Namespace) -> int:
    from cloud_sync.service.rules import CloudService  # noqa: PLC0415

    def keep(token: str) -> None:
        write_token(args.token_file, token, force=args.force)

    try:
        service = CloudService.open(args.data)
        try:  # one transaction: the token file is written before the commit, or nothing is
            service.register(args.vehicle, args.driver, keep)
        finally:
            service.store.close()
    except (CloudSyncError, OSError) as exc:
        return _refused("register", exc)
    drivers = ", ".join(args.driver) or "none yet"
    print(f"vehicle {args.vehicle} registered (drivers: {drivers})")
    print(f"token written to {args.token_file}")
    public = Path(args.data) / "keys" / "cloud.pub"
    if public.is_file():
        print(f"the vehicle trusts the key {public}")
    return 0


def _do_vehicle(args: argparse.Namespace) -> int:
    from cloud_sync.service.rules import CloudService  # noqa: PLC0415 - see _do_register

    if not (args.driver or args.new_token or args.revoke):
        print("pacc cloud vehicle: error: give --driver, --new-token or --revoke", file=sys.stderr)
        return 2
    token = "new" if args.new_token else "revoke" if args.revoke else None
    try:
        service = CloudService.open(args.data)
        try:  # one transaction, as register
            service.update_vehicle(
                args.vehicle,
                args.driver,
                token=token,
                keep_token=lambda t: write_token(args.new_token, t, force=args.force),
            )
        finally:
            service.store.close()
    except (CloudSyncError, OSError) as exc:
        return _refused("vehicle", exc)
    if args.driver:
        print(f"vehicle {args.vehicle}: driver(s) {', '.join(args.driver)} added")
    if args.new_token:
        print(f"vehicle {args.vehicle}: new token written to {args.new_token}; the old one is void")
    if args.revoke:
        print(f"vehicle {args.vehicle}: token revoked (--new-token FILE issues another)")
    return 0


def _refused(command: str, exc: BaseException) -> int:
    """One error line; exit 2 for an answer about the input (names, taken, a file in the
    way), 1 for a storage failure."""
    print(f"pacc cloud {command}: error: {error_line(exc)}", file=sys.stderr)
    return 1 if isinstance(exc, OSError) else 2


def _operator_sha256(path: str | None) -> str | None:
    """SHA-256 of the operator token in ``path`` (a new one written there if none)."""
    import hashlib  # noqa: PLC0415
    import secrets  # noqa: PLC0415

    from cloud_sync.vehicle.connect import read_token  # noqa: PLC0415

    if path is None:
        return None
    if not Path(path).exists():
        write_token(path, secrets.token_urlsafe(32))
        print(f"operator token written to {path}")
    return hashlib.sha256(read_token(path).encode()).hexdigest()


def _listen(host: str, port: int) -> socket.socket:
    """A socket listening on ``host:port``; OSError naming them when taken or unknown."""
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    try:
        return socket.create_server((host, port), family=family)
    except OSError as exc:
        why = os.strerror(exc.errno) if exc.errno else str(exc)
        raise OSError(exc.errno, f"cannot listen on {host}:{port}: {why}") from exc


def _do_serve(args: argparse.Namespace) -> int:
    import uvicorn  # noqa: PLC0415

    from cloud_sync.service.http import create_app  # noqa: PLC0415
    from cloud_sync.service.local import hold_folder  # noqa: PLC0415
    from cloud_sync.service.rules import CloudService, ServiceConfig  # noqa: PLC0415

    try:  # the port and the folder first: nothing started when either is taken
        listener = _listen(args.host, args.port)
        Path(args.data).mkdir(parents=True, exist_ok=True)
        hold_folder(args.data, f"http://{args.host}:{args.port}")
    except (CloudSyncError, OSError) as exc:
        return fail("pacc cloud serve", error_line(exc))
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    logging.getLogger("distributed").setLevel(logging.WARNING)  # its INFO is every connection
    try:
        operator = _operator_sha256(args.operator_token_file)
    except (CloudSyncError, OSError) as exc:
        print(f"pacc cloud serve: error: operator token: {exc}", file=sys.stderr)
        return 2
    compute = None
    try:
        if args.scheduler is not None:
            compute = open_executor(args.scheduler, args.workers)
    except CloudSyncError as exc:
        return fail("pacc cloud serve", exc)
    threads = max(args.workers, workers_of(compute) if compute is not None else 1)
    pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="pacc-learn")
    config = ServiceConfig(
        max_upload_bytes=int(args.max_upload_mb * 1024 * 1024), seed=args.seed, settle_s=args.settle
    )
    try:
        service = CloudService.open(args.data, executor=pool, config=config, compute=compute)
    except (CloudSyncError, OSError) as exc:
        print(f"pacc cloud serve: error: {error_line(exc)}", file=sys.stderr)
        pool.shutdown(wait=True)
        if compute is not None:
            compute.shutdown()
        return 1
    where = f" training on Dask at {args.scheduler}" if compute is not None else ""
    print(
        f"pacc cloud serving {args.data} on http://{args.host}:{args.port} "
        f"(OpenAPI at /docs, dashboard at /dashboard), {threads} learning worker(s){where}",
        flush=True,
    )
    # uvicorn shuts down gracefully on SIGTERM/SIGINT, then raises the signal again under the
    # handlers it found: make those no-ops, so the store and the job pool close and we exit 0
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: None)
    try:
        app = create_app(service, operator)
        uvicorn.Server(uvicorn.Config(app, log_level="warning")).run(sockets=[listener])
    finally:
        pool.shutdown(wait=True)
        service.store.close()
        if compute is not None:
            compute.shutdown()
    print("pacc cloud stopped", flush=True)
    return 0


def add_subparser(subparsers: Any) -> None:
    """Register ``register`` and ``serve`` on the ``pacc cloud`` parser."""
    reg = subparsers.add_parser("register", help="register a vehicle and its drivers")
    veh = subparsers.add_parser("vehicle", help="add drivers, reissue or revoke a vehicle's token")
    for q in (reg, veh):
        q.add_argument("--data", required=True, help="the cloud's data folder")
        q.add_argument("--vehicle", required=True, help="vehicle id")
        q.add_argument("--driver", action="append", default=[], help="a driver id (repeatable)")
        q.add_argument("--force", action="store_true", help="replace an existing token file")
    reg.add_argument("--token-file", required=True, help="where to write the vehicle's token")
    reg.set_defaults(func=_do_register)
    what = veh.add_mutually_exclusive_group()
    what.add_argument("--new-token", metavar="FILE", help="issue a new token into FILE")
    what.add_argument("--revoke", action="store_true", help="void the token: no new one")
    veh.set_defaults(func=_do_vehicle)

    srv = subparsers.add_parser("serve", help="run the cloud service over HTTP")
    srv.add_argument("--data", required=True, help="the cloud's data folder")
    srv.add_argument("--host", default="127.0.0.1")
    srv.add_argument("--port", type=integer(1, 65535), default=8080)
    srv.add_argument("--workers", type=integer(1, 256), default=1, help="learning job threads")
    srv.add_argument("--max-upload-mb", type=number(0.0, 4096.0, lo_open=True), default=16.0)
    srv.add_argument("--seed", type=integer(0), default=0, help="seed of every learning job")
    srv.add_argument(
        "--settle",
        type=number(0.0, 600.0),
        default=1.0,
        help="seconds without uploads before a driver is learned (0: at once)",
    )
    srv.add_argument("--scheduler", metavar="local|tcp://HOST:8786", help="Dask (docs/scale.md)")
    srv.add_argument("--operator-token-file", metavar="FILE", help="the operator's token")
    srv.set_defaults(func=_do_serve)
