"""The command line of ``pacc hil``: a person drives in a browser against the ECU.

Free drive (default): one drive of ``--scenario`` with ``--controller`` (``manual``: ACC
off). Protocol mode (``--participant P01 --protocol paper --out sessions/``): the paper's
study for one participant, resumable (docs/hil.md). The page is served on 127.0.0.1.
"""

from __future__ import annotations

import argparse
import socket
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from cloud_sync.errors import CloudSyncError
from dbc.errors import DbcError
from dbc.vocab import FormatError
from ecu import EcuError
from pacc.commands._args import (
    CONTROLLERS,
    CommandParser,
    add_bus_arguments,
    add_cloud_arguments,
    add_foxglove_argument,
    bus_error,
    bus_kwargs,
    fail,
    integer,
    number,
)
from sim_bus.errors import SimError

if TYPE_CHECKING:
    import can

    from pacc.hil.session import Session

#: the page's default port (not 8765: Foxglove's, which ``--foxglove`` takes by default)
DEFAULT_PORT = 8770
#: the protocol's set speed, km/h: the German advisory Autobahn speed, above every lead's
PROTOCOL_SET_KMH = 130.0


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(
        prog="pacc hil", description="a person drives in a browser page against the ECU"
    )
    p.add_argument(
        "--port", type=integer(0, 65535), default=DEFAULT_PORT, help=f"(default {DEFAULT_PORT})"
    )
    p.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1)")
    p.add_argument("--participant", help="participant id with a number, e.g. P01")
    p.add_argument("--protocol", choices=("paper",), help="run the paper's study protocol")
    p.add_argument("--out", type=Path, default=Path("sessions"), help="session folders")
    p.add_argument("--incremental", type=integer(0, 100), default=0, metavar="N")
    p.add_argument("--scenario", default="B", help="free drive: A, B, manual1..4 or a CSV")
    p.add_argument("--controller", default="predefined", choices=(*CONTROLLERS, "manual"))
    p.add_argument("--setting", choices=("low", "medium", "high"), default="medium")
    p.add_argument("--table", type=Path, help="free drive with irl/irl+oa: the DGPT file")
    p.add_argument("--fov", type=number(10.0, 150.0), default=50.0, help="field of view, degrees")
    p.add_argument("--set-speed", type=number(30.0, 180.0), metavar="KMH", help="SET speed, km/h")
    p.add_argument("--brake", choices=("resume", "cancel"), default="resume", help="brake press")
    p.add_argument("--weather", default="day", metavar="W[,W...]", help="day, rain or night")
    p.add_argument("--seed", type=integer(0), default=0, help="scenario and plant-noise seed")
    p.add_argument("--short", type=number(1.0, 1e6), metavar="S", help="shorten each drive to S s")
    p.add_argument("--lockstep", action="store_true", help="the page steps the world")
    p.add_argument("--mapping", type=Path, help="gamepad mapping file (default: ~/.config/pacc)")
    add_cloud_arguments(p, paths=True)
    add_bus_arguments(p, "the bus of a separate pacc ecu (omitted: the ECU in-process)")
    add_foxglove_argument(p)
    return p


def _bus_factory(args: argparse.Namespace) -> Callable[[], can.BusABC] | None:
    """What opens the bus to a separate ECU (None: the ECU runs in-process)."""
    if not bus_kwargs(args):
        return None
    import can  # noqa: PLC0415 - python-can, the session and its server: not for --help

    def open_bus() -> can.BusABC:
        try:
            return can.Bus(**bus_kwargs(args))
        except (can.CanError, ValueError, OSError, ImportError) as exc:
            raise SimError(bus_error(args, exc)) from exc

    return open_bus


def session_of(args: argparse.Namespace) -> Session:
    """The session the options ask for; SimError on bad options."""
    from dbc.vocab.dgpt_file import load_dgpt  # noqa: PLC0415
    from ecu.buslog.live import parse_address  # noqa: PLC0415
    from pacc.hil.plan import (  # noqa: PLC0415
        free_plan,
        paper_plan,
        participant_index,
        with_weather,
    )
    from pacc.hil.session import Session, SessionConfig  # noqa: PLC0415

    if args.protocol is not None:
        if args.participant is None:
            raise SimError("--protocol needs --participant")
        participant_index(args.participant)
        plan = paper_plan(args.participant, args.incremental)
    else:
        plan = free_plan(args.scenario, None if args.controller == "manual" else args.controller)
        if args.controller.startswith("irl"):
            if args.table is None:
                raise SimError(f"--controller {args.controller} needs --table DGPT")
            load_dgpt(args.table)  # a missing or broken table is refused now (DgptError)
    plan = with_weather(plan, args.weather)
    if args.foxglove is not None:
        fox_host, fox_port = parse_address(args.foxglove)
        if fox_port == args.port:
            raise SimError(f"--foxglove {args.foxglove}: that is the page's port, pick another")
        with socket.socket() as sock:  # refused now if another server holds it
            try:
                sock.bind((fox_host, fox_port))
            except OSError as exc:
                raise SimError(
                    f"--foxglove {fox_host}:{fox_port}: cannot listen there ({exc})"
                ) from None
    # a free drive without --participant is a new one each time (its own folder)
    free_id = "free-" + time.strftime("%Y%m%dT%H%M%S", time.gmtime())
    cfg = SessionConfig(
        participant=args.participant or free_id,
        protocol=args.protocol or "free",
        out=args.out,
        seed=args.seed,
        short_s=args.short,
        lockstep=args.lockstep,
        cloud=args.cloud,
        token_file=args.token_file,
        trust=args.trust,
        bus=_bus_factory(args),
        setting=args.setting,
        table=args.table if args.protocol is None else None,
        foxglove=args.foxglove,
        brake_mode=args.brake,
        fov_deg=args.fov,
        set_speed_kmh=args.set_speed or (PROTOCOL_SET_KMH if args.protocol else None),
    )
    return Session(cfg, plan)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc hil``; serves until Ctrl-C. 0 on success, 2 on bad input."""
    args = _parser().parse_args(argv)
    from pacc.hil.server import ServerThread, create_app, default_mapping_path  # noqa: PLC0415

    try:
        session = session_of(args)
        server = ServerThread(
            create_app(session, args.mapping or default_mapping_path()), args.port, args.host
        )
        port = server.start()
    except (SimError, EcuError, FormatError, CloudSyncError, DbcError, OSError) as exc:
        return fail("pacc hil", exc)
    url = f"http://{args.host}:{port}/"
    print(f"pacc hil: open {url} (session folder {session.folder})", flush=True)
    try:
        threading.Event().wait()
    except KeyboardInterrupt:
        print("pacc hil: stopped; the session can be resumed", file=sys.stderr)
    finally:
        session.close()
        server.stop()
    return 0
