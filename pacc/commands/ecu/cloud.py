"""``pacc ecu``'s link to the cloud: the takeover and manual spools, the vehicle link, the
start table.

Part of :mod:`pacc.commands.ecu` (one concept per module): everything here runs only with
``--takeovers``, ``--manual`` or ``--cloud``, and imports the cloud side lazily.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog import Trip
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.recorder import TripSink

if TYPE_CHECKING:
    from cloud_sync.vehicle.link import VehicleLink


def say(text: object) -> None:
    """Print ``text`` to stdout now. If the reader has gone (``pacc ecu | head``, a dead log
    pipe) the ECU keeps running: stdout is pointed at devnull and the run goes on to its end,
    writing takeovers and the profile."""
    try:
        print(text, flush=True)
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


class Exit(Exception):
    """Ends ``pacc ecu`` with exit ``code`` after ``pacc ecu: error: TEXT`` on stderr."""

    def __init__(self, code: int, text: str) -> None:
        super().__init__(f"pacc ecu: error: {text}")
        self.code = code


def spool_sinks(
    takeovers: str | None, manual: str | None
) -> tuple[TripSink | None, TripSink | None]:
    """The sinks of ``--takeovers DIR`` and ``--manual DIR`` (None where not given): each
    trip one batch of the spool in its DIR, its kind from the trip's mode; the same DIR
    twice is one spool (a spool has one writer). SpoolError if a DIR cannot be a spool."""
    from cloud_sync.vehicle.spool import Spool  # noqa: PLC0415 - only with a spool

    spools: dict[Path, Spool] = {}

    def sink(directory: str | None) -> TripSink | None:
        if not directory:
            return None
        key = Path(directory).resolve()
        if key not in spools:
            spools[key] = Spool(directory)
        spool = spools[key]

        def put(trip: Trip) -> None:
            spool.put_trip(trip)

        return put

    return sink(takeovers), sink(manual)


def warn_guest(args: argparse.Namespace, node: EcuNode) -> None:
    """Say so when takeover segments or manual trips will carry no real driver (the cloud
    refuses them)."""
    recorders = [
        (what, rec)
        for what, rec in (("takeover segments", node.recorder), ("manual trips", node.manual))
        if rec is not None
    ]
    if (args.takeovers or args.cloud or args.manual is not None) and recorders:
        driver = recorders[0][1].meta.get("driver_id")
        if driver in (None, "", "guest"):
            what = " and ".join(w for w, _ in recorders)
            print(
                f"pacc ecu: warning: {what} are tagged driver {driver!r}: the cloud "
                "refuses them (403) and they stay spooled; pass --driver ID (a driver "
                "registered to this vehicle)",
                file=sys.stderr,
            )


def cloud_link(args: argparse.Namespace, config: EcuConfig) -> VehicleLink:
    """The vehicle's cloud link of ``--cloud`` (usage and set-up errors raise Exit)."""
    # the cloud side (httpx, cryptography, the embedded service) is only for --cloud runs
    from cloud_sync.api import is_plain_name  # noqa: PLC0415
    from cloud_sync.errors import CloudSyncError  # noqa: PLC0415
    from cloud_sync.signing import load_public_key  # noqa: PLC0415
    from cloud_sync.vehicle.connect import connect, is_url, read_token  # noqa: PLC0415
    from cloud_sync.vehicle.download import ProfileDownloader  # noqa: PLC0415
    from cloud_sync.vehicle.link import VehicleLink  # noqa: PLC0415
    from cloud_sync.vehicle.spool import Spool  # noqa: PLC0415

    if not (args.vehicle and args.token_file):
        raise Exit(2, "--cloud needs --vehicle ID and --token-file F")
    if not is_plain_name(args.vehicle):
        raise Exit(2, f"--vehicle {args.vehicle!a}: not a plain name (letters, digits, _.-)")
    if args.takeovers:
        raise Exit(2, "--cloud spools the takeovers: drop --takeovers")
    if args.driver and args.profile:
        raise Exit(2, "--driver (the cloud's tables) or --profile, not both")
    trust = args.trust or (None if is_url(args.cloud) else Path(args.cloud) / "keys" / "cloud.pub")
    if args.driver and trust is None:
        raise Exit(2, "--driver with a cloud URL needs --trust KEY.pub")
    try:
        # short calls: the start-up download must not hold the control loop back for long
        cloud = connect(args.cloud, read_token(args.token_file), timeout_s=5.0)
        downloader = None
        if args.driver:
            assert trust is not None
            downloader = ProfileDownloader(
                cloud, load_public_key(trust), Path(args.spool) / "profiles", config.bounds
            )
        link = VehicleLink(
            cloud,
            Spool(args.spool),
            args.vehicle,
            downloader=downloader,
            driver_id=args.driver,
            condition=args.condition,
            sync_every_s=args.sync_every,
        )
    except (CloudSyncError, OSError) as exc:
        raise Exit(1, f"{exc}") from None
    say(f"cloud: {args.cloud} as vehicle {args.vehicle}, spool {args.spool}")
    return link


def cloud_table(link: VehicleLink, table: Dgpt) -> Dgpt:
    """The driver's newest verified cloud table, else ``table`` (never raises)."""
    try:
        cloud_table = link.initial_table()
    except Exception as exc:  # the start table must not depend on the cloud's health
        say(f"cloud: start-up download failed ({type(exc).__name__}: {exc})")
        cloud_table = None
    if cloud_table is None:
        say("cloud: no verified table for the driver yet; keeping the start table")
        return table
    say(f"profile: cloud {cloud_table.driver_id} {cloud_table.source} v{cloud_table.version}")
    return cloud_table
