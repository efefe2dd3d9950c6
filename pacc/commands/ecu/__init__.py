"""``pacc ecu``: run the ACC ECU node on a CAN bus in real time.

    pacc ecu -i virtual -c vcan0 --headway 1.5 --driver d2 --takeovers spool/ --duration 300

It starts from ``--profile`` (refused: the predefined table, FaultCode Profile) or a
constant-headway table, prints state changes, faults and adaptations, and at exit writes the
open takeover segment and manual stretch (``--takeovers``/``--manual`` spools, ``--cloud``:
docs/cloud.md) and a summary. Exit: 0 done, 1 bus/DBC/spool error, 2 usage error. Modules:
:mod:`pacc.commands.ecu.cloud` (spool, vehicle link, start table), :mod:`pacc.commands.ecu.run`
(recording, real-time loop, SIGTERM, summary).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time

from cloud_sync.errors import CloudSyncError
from dbc.codec import Codec
from dbc.errors import BindingError, CodecError, UsageError
from dbc.network import add_network_arguments, codec_of, network_of
from dbc.vocab import FormatError
from dbc.vocab.dgpt import PLAIN_NAME, Dgpt, DgptError, predefined
from dbc.vocab.dgpt_file import load_dgpt, save_dgpt
from dbc.vocab.sampling import MANUAL_MAX_S, MANUAL_MIN_S
from ecu import EcuError
from ecu.adaptation import ADAPTATION_MODES, AdaptationParams
from ecu.buslog.format import TimeBase
from ecu.buslog.live import add_foxglove_argument
from ecu.config import EcuConfig
from ecu.methods import make_adaptation, make_controller
from ecu.node import EcuNode
from ecu.recorder import SinkQueue, TripSink
from pacc.commands._args import (
    CommandParser,
    add_bus_arguments,
    add_cloud_arguments,
    check_distinct_outputs,
    check_writable_file,
    fail,
    number,
)
from pacc.commands.ecu.cloud import Exit, cloud_link, cloud_table, say, spool_sinks, warn_guest
from pacc.commands.ecu.run import close_recorder, open_recorder, run_on_bus


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
    try:
        network_of(args)  # --dbc without a binding for it: a usage error
        return _serve(args)
    except BindingError as exc:
        return fail("pacc ecu", exc)
    except Exit as exc:
        print(exc, file=sys.stderr)
        return exc.code


def _serve(args: argparse.Namespace) -> int:
    """Build the node, run it on the bus until done, report and save; raise :class:`Exit`."""
    config, fallback = _config(args)
    link = cloud_link(args, config) if args.cloud else None
    table, profile_fault = _initial_table(args, config, fallback)
    if link is not None and not args.profile:
        table = cloud_table(link, table)
    codec, sink, manual = _codec_and_sinks(args)
    if link is not None:
        sink, manual = link.sink, (link.sink if args.manual == "" else None)
    try:  # refuse now, not after the drive when the table would be lost
        check_writable_file(args.save_profile, "--save-profile")
    except UsageError as exc:
        raise Exit(1, f"{exc}") from None
    base = TimeBase.now(time.monotonic())  # the real-time clock against the wall clock
    min_s = MANUAL_MIN_S if args.manual_min is None else args.manual_min
    node = EcuNode(config, table, sink, utc_of=base.iso, manual_sink=manual, manual_min_s=min_s)
    if profile_fault:
        node.report_profile_fault()
    warn_guest(args, node)
    recorder = open_recorder(args, codec, node, base) if args.can_log or args.foxglove else None
    recording_error = None
    try:
        bus_error = run_on_bus(args, node, codec, base, link, recorder)
    finally:
        if link is not None:
            acc_on_s = node.recorder.acc_on_s if node.recorder is not None else 0.0
            say(link.end_trip(acc_on_s, base.iso(base.clock_origin_s)))
            link.stop()
            say(link.report())
        if recorder is not None:  # before anything can fail: the recording is kept
            recording_error = close_recorder(recorder)
    _report_recorders(args, node)
    if args.save_profile:
        try:
            save_dgpt(node.table, args.save_profile)
        except DgptError as exc:
            raise Exit(1, f"{exc}") from None
        say(f"profile saved: {args.save_profile} (v{node.table.version})")
    if bus_error is not None:
        raise Exit(1, f"the CAN bus failed: {bus_error}")
    if recording_error is not None:  # after the takeovers and the profile are saved
        raise Exit(1, f"{recording_error}")
    return 0


def _lost(queue: SinkQueue) -> str:
    """``, N lost`` when the queue lost trips (not built, or dropped while the sink failed)."""
    return f", {queue.lost} lost" if queue.lost else ""


def _report_recorders(args: argparse.Namespace, node: EcuNode) -> None:
    """Say what the takeover and manual recorders handed over."""
    if args.takeovers and node.recorder is not None:
        rec = node.recorder
        say(
            f"takeover segments: {rec.queue.stored} of {rec.segments} written to"
            f" {args.takeovers} ({rec.queue.sink_errors} failed attempts{_lost(rec.queue)})"
        )
    if node.manual is not None:
        man = node.manual
        where = args.manual or f"the cloud spool {args.spool}"
        say(
            f"manual trips: {man.queue.stored} of {man.trips} written to "
            f"{where} ({man.kept_s:.1f} s kept, {man.short_s:.1f} s in stretches shorter than "
            f"{man.min_s:g} s, {man.queue.sink_errors} failed attempts{_lost(man.queue)})"
        )


def _config(args: argparse.Namespace) -> tuple[EcuConfig, Dgpt]:
    """The node's configuration and the predefined fallback table (usage errors: exit 2)."""
    if args.manual == "" and not args.cloud:
        raise Exit(2, "--manual needs a DIR (or --cloud: the link's spool)")
    if args.manual and args.cloud:
        raise Exit(2, "--cloud spools the manual trips: --manual without DIR")
    if args.manual_min is not None and args.manual is None:
        raise Exit(2, "--manual-min is for --manual (the manual trips)")
    if not args.adaptation and args.adaptation_method:
        raise Exit(2, "--adaptation-method with --no-adaptation: nothing adapts")
    for option, name in (("--driver", args.driver), ("--condition", args.condition)):
        if name is not None and PLAIN_NAME.fullmatch(name) is None:
            raise Exit(2, f"{option} {name!a}: not a plain name (letters, digits, _.-)")
    try:
        config = EcuConfig(
            adaptation=args.adaptation,
            brake_mode=args.brake,
            set_speed_mps=args.set_speed,
            adaptation_params=AdaptationParams(mode=args.adaptation_mode),
            trip_meta={"driver_id": args.driver} if args.driver else {},
            gap_controller=args.gap_controller,
            adaptation_method=args.adaptation_method,
        )
        if config.gap_controller:  # a spec that names nothing: refused before the bus opens
            make_controller(config.gap_controller, {})
        if config.adaptation_method:
            make_adaptation(config.adaptation_method, {})
        return config, predefined(args.headway, args.standstill)
    except (EcuError, FormatError) as exc:
        raise Exit(2, f"{exc}") from None


def _initial_table(
    args: argparse.Namespace, config: EcuConfig, fallback: Dgpt
) -> tuple[Dgpt, bool]:
    """The table to start with, and whether ``--profile`` was refused (then: the fallback)."""
    if not args.profile:
        say(f"profile: predefined {args.headway:g} s headway, {args.standstill:g} m standstill")
        return fallback, False
    try:
        table = load_dgpt(args.profile, config.bounds)
    except DgptError as exc:
        print(f"pacc ecu: profile refused: {exc}", file=sys.stderr)
        print(
            f"pacc ecu: running on the predefined table ({args.headway:g} s headway, "
            f"{args.standstill:g} m standstill) instead",
            file=sys.stderr,
        )
        return fallback, True
    say(f"profile: {args.profile} ({table.driver_id}, {table.source}, v{table.version})")
    if args.driver and table.driver_id not in (args.driver, "guest"):
        print(
            f"pacc ecu: warning: --profile is driver {table.driver_id!r}'s table, the "
            f"takeovers are tagged {args.driver!r}",
            file=sys.stderr,
        )
    return table, False


def _codec_and_sinks(
    args: argparse.Namespace,
) -> tuple[Codec, TripSink | None, TripSink | None]:
    """The network codec (``--dbc``/``--binding`` or the packaged one), the takeover sink
    and the manual trips' sink (both None with ``--cloud``: the link's spool takes them)."""
    try:
        codec = codec_of(args)
        takeovers, manual = spool_sinks(None if args.cloud else args.takeovers, args.manual)
    except (CodecError, EcuError, FormatError, CloudSyncError) as exc:
        raise Exit(1, f"{exc}") from None
    return codec, takeovers, manual
