"""``pacc sim``: the simulator alone, in real time, on a CAN bus.

It plays ESC, PEDAL, RADAR and HMI against an ACC ECU elsewhere on the bus and drives the ego
car with its ACC_Command frames; at the end (or Ctrl-C) it prints the drive's figures. Exit
status: 0, 1 after a collision, 2 on bad options, input files or a bus that cannot be opened.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from dbc.errors import DbcError, UsageError
from dbc.network import add_network_arguments, codec_of
from dbc.vocab import FormatError
from dbc.vocab.acc_state import AccState
from ecu import EcuError
from pacc.commands._args import (
    CommandParser,
    add_bus_arguments,
    add_foxglove_argument,
    add_world_arguments,
    bus_error,
    bus_kwargs,
    check_distinct_outputs,
    check_writable_file,
    fail,
)
from sim_bus.errors import SimError

if TYPE_CHECKING:
    from ecu.buslog.format import TimeBase
    from ecu.buslog.writer import CanLogWriter
    from pacc.study.drive_recording import WorldFeed
    from sim_bus.faults import FaultSpec
    from sim_bus.node import SimNode
    from sim_bus.world import World, WorldLog

#: seconds between two progress lines
PROGRESS_EVERY_S = 5.0


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(prog="pacc sim", description=__doc__.split("\n\n")[0])
    add_bus_arguments(p)
    add_world_arguments(p)
    p.add_argument("--can-log", type=Path, metavar="FILE", help="record the bus to this MCAP")
    p.add_argument("--quiet", action="store_true", help="no progress line")
    add_network_arguments(p)
    add_foxglove_argument(p)
    return p


def _setup(args: argparse.Namespace) -> tuple[World, FaultSpec]:
    """The world (driver, lead profile) and the faults of the run; SimError on bad options."""
    from pacc.study.drive import resolve_profile, with_condition  # noqa: PLC0415
    from sim_bus.drivers import load_driver  # noqa: PLC0415
    from sim_bus.faults import parse_faults  # noqa: PLC0415
    from sim_bus.lead.scenarios import shorten  # noqa: PLC0415
    from sim_bus.world import World  # noqa: PLC0415

    driver = with_condition(load_driver(args.driver), args.condition_factor)
    faults = parse_faults(args.faults)
    profile = resolve_profile(args.scenario, args.seed)
    if args.duration is not None:
        profile = shorten(profile, args.duration)
    check_writable_file(args.log, "--log")  # now, not after the drive when it would be lost
    check_writable_file(args.can_log, "--can-log")
    return World(driver, profile, args.seed), faults


def _state_name(code: int) -> str:
    """The ACC state's name (OFF, STANDBY, ACTIVE …) of a code on the bus."""
    try:
        return AccState(code).name
    except ValueError:
        return f"state {code}"


def _run(node: SimNode, duration_s: float, quiet: bool, feed: WorldFeed | None = None) -> None:
    """Run ``node`` in real time, a progress line every few seconds unless ``quiet``;
    ``feed``: the world streamed to a live view as it runs."""
    world = node.world
    last_print = [time.monotonic()]

    def progress() -> bool:
        if feed is not None:
            feed()
        now = time.monotonic()
        if not quiet and now - last_print[0] >= PROGRESS_EVERY_S:
            last_print[0] = now
            print(
                f"t {node.t_s:6.1f} s  v {world.plant.v_mps:5.1f} m/s  gap "
                f"{world.plant.gap_m:6.1f} m  ACC {_state_name(node.acc_state)}",
                file=sys.stderr,
            )
        return False

    try:
        node.run_realtime(duration_s, stop=progress)
    except KeyboardInterrupt:
        print("pacc sim: interrupted", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc sim``; returns the exit status."""
    args = _parser().parse_args(argv)
    check_distinct_outputs(log=args.log, can_log=args.can_log)
    import can  # noqa: PLC0415

    from ecu.buslog.format import TimeBase  # noqa: PLC0415
    from ecu.buslog.live import live_sinks  # noqa: PLC0415
    from ecu.buslog.recording import open_recording  # noqa: PLC0415
    from pacc.study.drive_recording import WorldFeed  # noqa: PLC0415
    from sim_bus.drivers import GAP_SETTING_CODE  # noqa: PLC0415
    from sim_bus.faults import fault_rng  # noqa: PLC0415
    from sim_bus.node import SimNode  # noqa: PLC0415

    try:
        world, faults = _setup(args)
        codec = codec_of(args)
    except (SimError, DbcError, UsageError) as exc:
        return fail("pacc sim", exc)
    try:
        # only given flags are passed: a None bitrate would hide the one of ~/.canrc
        bus = can.Bus(**bus_kwargs(args))
    except (can.CanError, ValueError, OSError, ImportError) as exc:
        return fail("pacc sim", bus_error(args, exc))
    gap = GAP_SETTING_CODE[world.driver.predefined_setting]
    node = SimNode(
        bus, world, codec=codec, faults=faults, rng=fault_rng(args.seed), gap_setting=gap
    )
    base = TimeBase.now(0.0)  # simulated time 0 is now
    try:
        live = live_sinks(args.foxglove, print)
        recorder = (
            open_recording(args.can_log, node.codec, base, node="sim", sinks=live)
            if args.can_log is not None or live
            else None
        )
    except (EcuError, FormatError, OSError) as exc:
        bus.shutdown()
        text = exc.strerror if isinstance(exc, OSError) and exc.strerror else exc
        where = f"--can-log {args.can_log}" if args.can_log is not None else "--foxglove"
        print(f"pacc sim: error: {where}: {text}", file=sys.stderr)
        return 2
    feed: WorldFeed | None = None
    if recorder is not None:
        rec = recorder

        def tap(t: float, key: int, data: bytes, rx: bool) -> None:
            rec.frame_raw(t, key, data, rx)
            rec.tick(t)

        node.tap = tap
        feed = WorldFeed(recorder, world) if live else None
    start = time.monotonic()
    try:
        _run(node, world.profile.duration_s, args.quiet, feed)
    finally:
        bus.shutdown()
        if feed is not None:
            feed()  # the rows of the last ticks (the loop feeds before each tick)
    log = world.log()
    _print_figures(args, node, log, start)
    return _save(args, log, world, node, base, recorder, feed is not None)


def _print_figures(args: argparse.Namespace, node: SimNode, log: WorldLog, start: float) -> None:
    """The drive's summary and figures (``start``: its monotonic start time, s)."""
    from pacc.commands.drive.report import fig  # noqa: PLC0415

    world, m = node.world, log.metrics()
    print(
        f"sim: scenario {args.scenario}, driver {world.driver.driver_id}, {world.t_s:.1f} s in "
        f"{time.monotonic() - start:.1f} s wall; {node.commands_ok} ACC commands received"
        + (f"; {node.send_errors} frames refused by the bus" if node.send_errors else "")
    )
    print(
        f"  PoI {fig(m.poi_pct, '.2f', ' %', 'n/a')}  "
        f"NIM {fig(m.nim_per_min, '.2f', ' /min', 'n/a')}  min gap {m.min_gap_m:.2f} m  "
        f"min TTC {m.min_ttc_s:.2f} s  RMS jerk {m.rms_jerk_mps3:.3f} m/s^3  presses "
        f"{m.press_onsets}  collisions {int(world.plant.collided)}"
    )


def _save(
    args: argparse.Namespace,
    log: WorldLog,
    world: World,
    node: SimNode,
    base: TimeBase,
    recorder: CanLogWriter | None,
    streamed: bool,
) -> int:
    """Write ``--log`` and close ``--can-log`` (``streamed``: its world was fed live); the
    exit status (1 collision, 2 a failed output)."""
    from dbc.vocab.pedals import PedalScale  # noqa: PLC0415
    from dbc.vocab.triplog import TripLogError  # noqa: PLC0415
    from dbc.vocab.triplog_file import write_trip  # noqa: PLC0415
    from pacc.study.drive_recording import finish_recording  # noqa: PLC0415
    from sim_bus.trip import world_trip  # noqa: PLC0415

    collided = world.plant.collided
    status = 1 if collided else 0
    if args.log is not None:
        meta = {
            "scenario": args.scenario,
            "seed": args.seed,
            "collision": collided,
            "source": "pacc.commands.sim",
            "start_utc": base.iso(0.0),
        }
        try:
            write_trip(
                args.log, world_trip(log, world.driver, PedalScale.from_codec(node.codec), meta)
            )
        except (TripLogError, OSError) as exc:
            print(f"pacc sim: error: cannot write {args.log}: {exc}", file=sys.stderr)
            status = 2
    if recorder is not None:
        failed = finish_recording(recorder, log, streamed)
        if failed is not None:
            print(f"pacc sim: error: bus recording failed: {failed}", file=sys.stderr)
            return 2
        if args.can_log is not None:
            print(f"bus recording: {recorder.frames} frames written to {args.can_log}")
    return status
