"""``pacc ecu``'s run on the bus: the bus recording, the real-time loop, SIGTERM, the summary.

Part of :mod:`pacc.commands.ecu` (one concept per module): python-can, the runtime, MCAP
and Foxglove are imported only when the ECU runs, never for ``--help`` or a usage error.
"""

from __future__ import annotations

import argparse
import re
import signal
from collections.abc import Callable
from typing import TYPE_CHECKING

from dbc.codec import Codec
from dbc.vocab import FormatError
from ecu import EcuError
from ecu.buslog.format import TimeBase
from ecu.node import EcuNode
from pacc.commands._args import bus_error as bus_error_text
from pacc.commands._args import bus_kwargs
from pacc.commands.ecu.cloud import Exit, say

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
    # python-can and the runtime cost ~0.3 s of start-up that --help and usage errors skip
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
