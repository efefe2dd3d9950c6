"""``pacc drive``: the ECU node and the simulator in one process, lockstep, one bus.

Prints PoI, NIM, min gap, min TTC, RMS jerk, takeovers, adaptations, collisions.
``--manual`` drives by hand (ACC off) and writes the trip to ``--log``, a demonstration; with
``--can-log`` it drives by hand on the bus, the ECU on and never engaged. ``--foxglove``
streams the drive live at ``--pace`` times real time. Exit status: 0, 1 after a collision,
2 on bad options, input files or an output not written; 130 after Ctrl-C. The figures as text:
:mod:`pacc.commands.drive.report`.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dbc.errors import DbcError, UsageError, error_line
from dbc.network import add_network_arguments
from dbc.vocab import FormatError
from ecu import EcuError
from pacc.commands._args import (
    ADAPTATION_MODES,
    BUSES,
    CONDITIONS,
    CONTROLLERS,
    CommandParser,
    add_foxglove_argument,
    add_world_arguments,
    check_distinct_outputs,
    check_writable_dir,
    check_writable_file,
    fail,
    json_parameters,
    number,
)
from sim_bus.errors import SimError

if TYPE_CHECKING:
    from dbc.vocab.dgpt import Dgpt
    from dbc.vocab.triplog import Trip
    from sim_bus.drivers import DriverParams


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(prog="pacc drive", description=__doc__.split("\n\n")[0])
    add_world_arguments(p)
    p.add_argument("--controller", default="predefined", choices=CONTROLLERS)
    p.add_argument("--profile", type=Path, help="DGPT JSON for the irl controllers")
    p.add_argument("--manual", action="store_true", help="drive by hand, ACC off (needs --log)")
    p.add_argument("--can-log", type=Path, metavar="FILE", help="record the bus to this MCAP")
    p.add_argument("--manual-trips", type=Path, metavar="DIR", help="record manual stretches here")
    add_foxglove_argument(p)
    p.add_argument("--pace", type=number(0.0, 1e6), metavar="X", help="X times real time (0: fast)")
    p.add_argument("--brake-mode", choices=("resume", "cancel"), default="resume")
    p.add_argument("--condition", choices=CONDITIONS, default="dry")
    p.add_argument("--cache", type=Path, help="cache folder of learned IRL tables")
    p.add_argument("--adaptation-mode", choices=ADAPTATION_MODES)
    p.add_argument("--bus", choices=BUSES, default=BUSES[0], help="ECU-simulator python-can bus")
    p.add_argument("--gap-controller", default="", metavar="SPEC", help="see pacc plugins")
    p.add_argument("--adaptation", default="", metavar="SPEC", help="see pacc plugins")
    for name in ("--gap-controller-args", "--adaptation-args"):
        p.add_argument(
            name,
            type=json_parameters,
            default=(),
            metavar="JSON",
            help="the plug-in's parameters, a JSON object",
        )
    add_network_arguments(p)
    return p


class _ManualTrips:
    """The ECU's manual-trip sink of ``--manual-trips DIR``: writes each trip to DIR and
    keeps what it did, for the drive's report. RecorderError if DIR cannot be written."""

    def __init__(self, directory: Path) -> None:
        from ecu.recorder import directory_sink  # noqa: PLC0415 - not for --help

        self.directory = directory
        self._write = directory_sink(directory, "manual")
        #: sample counts of the trips written
        self.written: list[int] = []
        #: the last write's failure (None: none failed)
        self.error: str | None = None

    def __call__(self, trip: Trip) -> None:
        try:
            self._write(trip)
        except Exception as exc:
            self.error = error_line(exc)
            raise  # the ECU's queue keeps the trip for a retry
        self.written.append(len(trip))

    def report(self, made: int, period_s: float) -> bool:
        """Print what was written of the ``made`` trips the ECU made (``period_s``: its
        recording period, s); False (said on stderr) if one was not written."""
        seconds = sum(self.written) * period_s
        print(f"  manual trips   {len(self.written)} ({seconds:.1f} s) in {self.directory}")
        lost = made - len(self.written)
        if lost <= 0:
            return True
        why = self.error or "not built (see the log)"
        print(f"pacc drive: error: {lost} manual trip(s) not written: {why}", file=sys.stderr)
        return False


def _check_options(args: argparse.Namespace) -> None:
    """Options that contradict each other or outputs that cannot be written: UsageError
    (the error boundary prints it, exit 2), before anything runs."""
    check_distinct_outputs(
        log=args.log, can_log=args.can_log, profile=args.profile, manual_trips=args.manual_trips
    )
    check_writable_file(args.log, "--log")  # now, not after the drive
    check_writable_file(args.can_log, "--can-log")
    check_writable_dir(args.manual_trips, "--manual-trips")
    if args.profile is not None and not args.manual and not args.controller.startswith("irl"):
        raise UsageError(
            f"--profile is for the irl controllers; --controller {args.controller} drives "
            "the driver's predefined table"
        )
    adapts = (
        "--adaptation" if args.adaptation else "--adaptation-mode" if args.adaptation_mode else ""
    )
    if adapts and not args.manual and not args.controller.endswith("+oa"):
        raise UsageError(
            f"{adapts} is for the +oa controllers; --controller {args.controller} never "
            f"adapts its table (--controller {args.controller}+oa)"
        )
    for spec in ("--gap-controller", "--adaptation"):
        name = spec[2:].replace("-", "_")
        if getattr(args, f"{name}_args") and not getattr(args, name):
            raise UsageError(f"{spec}-args gives the parameters of a {spec} SPEC: name the plug-in")


def _table(args: argparse.Namespace, base: DriverParams, driver: DriverParams) -> Dgpt:
    """The drive's table: ``--profile`` or the learned IRL one for the irl controllers (the
    IRL table is learned in normal conditions, from ``base``), else the predefined one."""
    from dbc.vocab.dgpt_file import load_dgpt  # noqa: PLC0415
    from pacc.study.drive import predefined_table  # noqa: PLC0415
    from pacc.study.irl_table import irl_table  # noqa: PLC0415

    if not args.controller.startswith("irl"):
        return predefined_table(driver)
    if args.profile is None:
        print("learning the IRL table from the driver's manual trips (cached) ...", file=sys.stderr)
        return irl_table(base, args.seed, args.cache)
    table = load_dgpt(args.profile)
    if table.driver_id not in (driver.driver_id, "guest"):
        print(
            f"pacc drive: warning: --profile is driver {table.driver_id!r}'s table, the "
            f"drive's driver is {driver.driver_id!r}",
            file=sys.stderr,
        )
    return table


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc drive``; returns the exit status."""
    args = _parser().parse_args(argv)
    _check_options(args)
    if args.manual and (code := _manual(args)) is not None:
        return code
    from ecu.buslog.live import live_sinks  # noqa: PLC0415
    from pacc.study.drive import (  # noqa: PLC0415
        DriveConfig,
        adaptation_params,
        drive_codec,
        resolve_profile,
        run_drive,
        with_condition,
    )
    from sim_bus.drivers import CONDITION_FACTORS, load_driver  # noqa: PLC0415
    from sim_bus.faults import parse_faults  # noqa: PLC0415

    try:
        base = load_driver(args.driver)
        driver = with_condition(base, args.condition_factor * CONDITION_FACTORS[args.condition])
        parse_faults(args.faults)
        cfg = DriveConfig(
            args.scenario,
            driver.driver_id,
            args.controller,
            args.seed,
            args.duration,
            args.faults,
            args.brake_mode,
            adaptation=adaptation_params(args.adaptation_mode),
            dbc=args.dbc,
            binding=args.binding,
            gap_controller=args.gap_controller,
            controller_args=args.gap_controller_args,
            adaptation_method=args.adaptation,
            adaptation_args=args.adaptation_args,
            manual=args.manual,
        )
        drive_codec(cfg)  # a DBC without its binding: refused before any learning
        profile = resolve_profile(args.scenario, args.seed)
        table = _table(args, base, driver)
        manual = None if args.manual_trips is None else _ManualTrips(args.manual_trips)
        live = live_sinks(args.foxglove, print)
        pace = _pace(args)
        if pace is not None:
            print(f"drive: paced at {pace:g}x real time (--pace 0: as fast as it runs)")
        try:
            result = run_drive(
                cfg,
                driver,
                table,
                profile,
                can_log=args.can_log,
                live=live,
                bus=args.bus,
                manual_sink=manual,
                pace=pace,
            )
        finally:
            for sink in live:
                sink.close(complete=True)
    except KeyboardInterrupt:  # an unpaced drive (a paced one ends with its results)
        print("pacc drive: interrupted", file=sys.stderr)
        return 130
    except (SimError, EcuError, FormatError, DbcError, OSError) as exc:
        text = error_line(exc)
        if isinstance(exc, OSError) and exc.filename is None and args.can_log is not None:
            text = f"--can-log {args.can_log}: {text}"  # the recording's write, unnamed
        return fail("pacc drive", text)
    return _outputs(args, result, driver, manual, bool(live))


def _outputs(
    args: argparse.Namespace,
    result: Any,
    driver: DriverParams,
    manual: _ManualTrips | None,
    live: bool,
) -> int:
    """Print the drive's figures and write ``--log``; the exit status (130 for a drive
    Ctrl-C stopped, 2 for an output not written, 1 for a collision)."""
    from dbc.vocab.triplog import TripLogError  # noqa: PLC0415
    from dbc.vocab.triplog_file import write_trip  # noqa: PLC0415
    from ecu.config import EcuConfig  # noqa: PLC0415
    from pacc.commands.drive.report import format_result  # noqa: PLC0415
    from pacc.study.drive import log_to_trip  # noqa: PLC0415

    print(format_result(result))
    stopped = result.extra.get("interrupted_at_s")
    if stopped is not None:
        print(f"pacc drive: interrupted at t = {stopped:.2f} s: the drive so far", file=sys.stderr)
    if args.log is not None:
        try:
            write_trip(args.log, log_to_trip(result, driver))
        except (TripLogError, OSError) as exc:
            print(f"pacc drive: error: cannot write {args.log}: {error_line(exc)}", file=sys.stderr)
            return 2
        print(f"  log            {args.log}")
    made = int(result.extra.get("manual_trips", 0))
    written = manual is None or manual.report(made, EcuConfig().record_period_s)
    failed = result.extra.get("can_log_error")
    if failed:
        print(f"pacc drive: error: bus recording failed: {failed}", file=sys.stderr)
    elif args.can_log is not None:
        print(f"  bus recording  {args.can_log}")
    if not written or failed:
        return 2
    if stopped is not None:
        return 130  # what an interrupted command exits with; its outputs are written
    return 1 if result.collision else 0


def _pace(args: argparse.Namespace) -> float | None:
    """The drive's pace (times real time; None: as fast as it runs) of ``--pace`` and
    ``--foxglove``; SimError for a pace above 0 and below :data:`MIN_PACE`.
    """
    from pacc.study.drive_recording import MIN_PACE  # noqa: PLC0415

    pace = args.pace if args.pace is not None else 1.0 if args.foxglove is not None else 0.0
    if 0 < pace < MIN_PACE:
        raise SimError(f"--pace {pace:g}: 0 or at least {MIN_PACE:g}")
    return pace if pace > 0 else None


def _manual(args: argparse.Namespace) -> int | None:
    """``pacc drive --manual``: the driver follows the scenario by hand, written to --log;
    with ``--can-log`` None: the bus drive runs with the ACC never engaged (the manual bus
    log ``pacc demos extract`` reads)."""
    from dbc.vocab.triplog_file import write_trip  # noqa: PLC0415
    from pacc.study.drive import resolve_profile, with_condition  # noqa: PLC0415
    from sim_bus.drivers import load_driver  # noqa: PLC0415
    from sim_bus.lead.scenarios import shorten  # noqa: PLC0415
    from sim_bus.manual import manual_trip  # noqa: PLC0415

    given = [
        opt
        for opt, on in (
            ("--controller", args.controller != "predefined"),
            ("--profile", args.profile is not None),
            ("--faults", bool(args.faults)),
            ("--manual-trips", args.manual_trips is not None),
            ("--adaptation-mode", args.adaptation_mode is not None),
            ("--gap-controller", bool(args.gap_controller)),
            ("--adaptation", bool(args.adaptation)),
            ("--foxglove", args.foxglove is not None),
            ("--pace", args.pace is not None),
            ("--bus", args.bus != BUSES[0]),
        )
        if on
    ]
    if (args.log is None) == (args.can_log is None) or given:
        why = (
            f"drives the ACC off: drop {', '.join(given)}"
            if given
            else "writes --log FILE (no bus) or --can-log FILE (the bus drive), one of them"
        )
        print(f"pacc drive: error: --manual {why}", file=sys.stderr)
        return 2
    if args.can_log is not None:
        return None
    try:
        driver = with_condition(load_driver(args.driver), args.condition_factor)
        profile = resolve_profile(args.scenario, args.seed)
        if args.duration is not None:
            profile = shorten(profile, args.duration)
        trip = manual_trip(driver, profile, args.seed)
        meta = {**trip.meta, "scenario": args.scenario, "seed": args.seed}
        trip = dataclasses.replace(trip, meta=meta)
        write_trip(args.log, trip)
    except (SimError, FormatError, DbcError, OSError) as exc:
        return fail("pacc drive", error_line(exc))
    collided = bool(trip.meta.get("collision"))
    print(
        f"manual drive: scenario {args.scenario}, driver {driver.driver_id} by hand (ACC off), "
        f"seed {args.seed}, {float(trip.t_s[-1] - trip.t_s[0]):.1f} s, condition "
        f"{trip.meta.get('condition')}{', collision' if collided else ''}"
    )
    print(f"  log            {args.log} (a demonstration for pacc cloud learn --demos)")
    return 1 if collided else 0
