"""``pacc ecu``: run the ACC ECU node on a CAN bus in real time.

    pacc ecu -i virtual -c vcan0 --headway 1.5 --driver d2 --takeovers spool/ --duration 300

It starts from ``--profile`` (refused: the predefined table, FaultCode Profile) or a
constant-headway table, prints state changes, faults and adaptations, and at exit writes the
open takeover segment and manual stretch (``--takeovers``/``--manual`` spools, ``--cloud``:
docs/cloud.md) and a summary. Exit: 0 done, 1 bus/DBC/spool error, 2 usage error. Modules:
:mod:`pacc.commands.ecu.cloud` (spool, vehicle link, start table), :mod:`pacc.commands.ecu.run`
(the node from the options, recording, real-time loop, SIGTERM, summary; imported only when it
runs).
"""

from __future__ import annotations

import argparse
import logging
import sys

from dbc.errors import BindingError
from dbc.network import add_network_arguments, network_of
from dbc.vocab.sampling import MANUAL_MAX_S
from pacc.commands._args import (
    ADAPTATION_MODES,
    CommandParser,
    add_bus_arguments,
    add_cloud_arguments,
    add_foxglove_argument,
    check_distinct_outputs,
    fail,
    number,
)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``pacc ecu`` (python-can flag conventions)."""
    p = CommandParser(prog="pacc ecu", description="Run the ACC ECU node on a CAN bus, 50 Hz.")
    add_bus_arguments(p)
    add_network_arguments(p)
    table = p.add_mutually_exclusive_group()
    table.add_argument("--profile", metavar="DGPT.json", help="driver gap preference table")
    table.add_argument("--headway", type=number(0.1, 10.0), default=1.5, help="headway, s (table)")
    p.add_argument("--standstill", type=number(0.5, 50.0), default=4.0, help="standstill gap, m")
    p.add_argument("--adaptation", action=argparse.BooleanOptionalAction, default=True)
    p.add_argument("--adaptation-mode", choices=ADAPTATION_MODES, default="timegap")
    p.add_argument("--brake", choices=("resume", "cancel"), default="resume", help="brake press")
    p.add_argument("--profiles", metavar="DIR", help="DriverProfileId n loads DIR/profile_<n>.json")
    p.add_argument("--set-speed", type=number(0.0, 60.0), help="SET speed, m/s (default: current)")
    p.add_argument("--gap-controller", default="", metavar="SPEC", help="see pacc plugins")
    p.add_argument("--adaptation-method", default="", metavar="SPEC", help="see pacc plugins")
    p.add_argument("--takeovers", metavar="DIR", help="spool takeover segments here")
    p.add_argument("--manual", nargs="?", const="", metavar="DIR", help="spool manual trips")
    p.add_argument("--manual-min", type=number(0.1, MANUAL_MAX_S), help="shortest kept, s")
    p.add_argument("--can-log", metavar="FILE", help="record frames and internals to this MCAP")
    add_foxglove_argument(p)
    p.add_argument("--save-profile", metavar="PATH", help="write the final DGPT here at exit")
    p.add_argument("--duration", type=number(0.0, 1e7), metavar="S", help="stop after S seconds")
    cloud = p.add_argument_group("cloud (docs/cloud.md)")
    add_cloud_arguments(cloud)
    cloud.add_argument("--vehicle", metavar="ID", help="this vehicle's id (with --cloud)")
    cloud.add_argument("--driver", metavar="ID", help="the driver: tags trips, picks its table")
    cloud.add_argument("--condition", default="default", help="driving condition of --driver")
    cloud.add_argument("--spool", metavar="DIR", default="pacc-spool", help="the spool folder")
    cloud.add_argument("--sync-every", type=number(0.0, 86400.0, lo_open=True), default=60.0)
    p.add_argument("-v", "--verbose", action="store_true", help="log at INFO level")
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc ecu``; returns the exit code."""
    args = build_parser().parse_args(argv)
    check_distinct_outputs(
        can_log=args.can_log, save_profile=args.save_profile, profile=args.profile
    )
    level = logging.INFO if args.verbose else logging.WARNING
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    from pacc.commands.ecu.cloud import Exit  # noqa: PLC0415
    from pacc.commands.ecu.run import serve  # noqa: PLC0415

    try:
        network_of(args)  # --dbc without a binding for it: a usage error
        return serve(args)
    except BindingError as exc:
        return fail("pacc ecu", exc)
    except Exit as exc:
        print(exc, file=sys.stderr)
        return exc.code
