"""``pacc ecu``'s run (part of :mod:`pacc.commands.ecu`, imported when it runs): the node
from the options, the bus recording, the real-time loop, SIGTERM, the summary."""

from __future__ import annotations

import argparse
import re
import signal
import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING

from cloud_sync.errors import CloudSyncError
from dbc.codec import Codec
from dbc.errors import CodecError, UsageError
from dbc.network import codec_of
from dbc.vocab import FormatError
from dbc.vocab.dgpt import PLAIN_NAME, Dgpt, DgptError, predefined
from dbc.vocab.dgpt_file import load_dgpt, save_dgpt
from dbc.vocab.sampling import MANUAL_MIN_S
from ecu import EcuError
from ecu.adaptation import AdaptationParams
from ecu.buslog.format import TimeBase
from ecu.config import EcuConfig
from ecu.methods import make_adaptation, make_controller
from ecu.node import EcuNode
from ecu.recorder import SinkQueue, TripSink
from pacc.commands._args import bus_error as bus_error_text
from pacc.commands._args import bus_kwargs, check_writable_file
from pacc.commands.ecu.cloud import Exit, cloud_link, cloud_table, say, spool_sinks, warn_guest

if TYPE_CHECKING:
    from cloud_sync.vehicle.link import VehicleLink
    from ecu.buslog.writer import CanLogWriter
    from ecu.runtime import EcuRuntime


def _stop_on_sigterm(stop: Callable[[], None]) -> Callable[[], None]:
    """Make SIGTERM call ``stop`` (a service stop ends the run like Ctrl-C: the open takeover
    segment is written, the profile saved); return a function restoring the old handler.
    Off the main thread signals cannot be handled: nothing is installed."""
    try:
        previous = signal.signal(signal.SIGTERM, lambda signum, frame: stop())
    except ValueError:  # not the main thread
        return lambda: None

    def restore() -> None:
        signal.signal(signal.SIGTERM, previous if previous is not None else signal.SIG_DFL)

    return restore


def open_recorder(
    args: argparse.Namespace, codec: Codec, node: EcuNode, base: TimeBase
) -> CanLogWriter:
    """The bus recorder of ``--can-log`` (opened now: a bad path fails before the run)."""
    from ecu.buslog.live import live_sinks  # noqa: PLC0415 - foxglove only for a live view
    from ecu.buslog.recording import open_recording  # noqa: PLC0415 - python-can, mcap: only to record

    try:
        return open_recording(
            args.can_log,
            codec,
            base,
            node="ecu",
            config=node.config,
            table=node.table,
            dbc_path=args.dbc,
            binding_path=getattr(args, "binding", None),
            sinks=live_sinks(args.foxglove, say),
        )
    except (EcuError, FormatError, OSError) as exc:
        text = _one_line(exc)
        if args.can_log is not None and str(args.can_log) not in text:
            text = f"--can-log {args.can_log}: {text}"
        raise Exit(1, text) from None


def _one_line(exc: BaseException) -> str:
    """An error's text on one line (an OSError as its strerror)."""
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return " ".join(str(exc).split())


def close_recorder(recorder: CanLogWriter) -> str | None:
    """Close the recording; the failure's text (None: written)."""
    try:
        recorder.close()
    except (EcuError, FormatError, OSError) as exc:
        return _one_line(exc)
    if recorder.path is not None:
        say(f"bus recording: {recorder.frames} frames written to {recorder.path}")
    return None


def run_on_bus(
    args: argparse.Namespace,
    node: EcuNode,
    codec: Codec,
    base: TimeBase,
    link: VehicleLink | None = None,
    recorder: CanLogWriter | None = None,
) -> str | None:
    """Open the bus, run the node on it until done and print the summary; return the bus
    failure's text (None: clean end)."""
    import can  # noqa: PLC0415

    from ecu.runtime import EcuRuntime  # noqa: PLC0415

    try:
        bus = can.Bus(**bus_kwargs(args))
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        raise Exit(1, bus_error_text(args, exc)) from None
    with bus:
        try:
            rt = EcuRuntime(bus, node, codec, on_event=utc_events(base), profile_dir=args.profiles)
        except (EcuError, FormatError) as exc:  # a DBC that cannot carry the outputs
            raise Exit(1, f"{exc}") from None
        if link is not None:
            link.start(rt.offer_table)
        rt.record_to(recorder)
        mode = args.adaptation_mode if args.adaptation else "off"
        say(f"adaptation: {mode}; brake press: {args.brake}")
        say(
            f"set speed at SET: {args.set_speed:g} m/s"
            if args.set_speed is not None
            else "set speed at SET: the current speed (--set-speed M/S fixes it; "
            "pacc drive uses 40 so that the lead governs)"
        )
        say(f"ECU running on {bus.channel_info} (Ctrl-C to stop)")
        bus_error = run_until_done(rt, args.duration)
    say(rt.summary())
    return bus_error


def utc_events(base: TimeBase) -> Callable[[str], None]:
    """Print the runtime's events (``t=<node clock> s  text``) stamped with the wall clock's
    UTC time of day instead of the node's boot clock."""

    def stamped(text: str) -> None:
        match = _EVENT.fullmatch(text)
        if match is not None:
            text = f"{base.iso(float(match[1]))[11:23]} UTC  {match[2]}"
        say(text)

    return stamped


_EVENT = re.compile(r"t=(-?[0-9.]+) s  (.*)", re.S)


def run_until_done(rt: EcuRuntime, duration_s: float | None) -> str | None:
    """Run ``rt`` in real time until ``duration_s``, Ctrl-C or SIGTERM, flushing the open
    takeover segment; a bus failure ends the run like a stop and its text is returned (None: a
    clean end).
    """
    import can  # noqa: PLC0415 - see run_on_bus: python-can only when the ECU runs

    restore_sigterm = _stop_on_sigterm(rt.stop)
    try:
        rt.run_realtime(duration_s)
    except KeyboardInterrupt:
        say("interrupted")
    except can.CanError as exc:
        return str(exc) or type(exc).__name__
    finally:
        restore_sigterm()
        rt.node.finish()
    return None


def serve(args: argparse.Namespace) -> int:
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
