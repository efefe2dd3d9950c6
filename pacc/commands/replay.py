"""``pacc replay LOG``: a bus recording through the ECU (deterministic) or onto a bus (real time).

``--ecu`` rebuilds the recorded ECU, feeds it its recorded inputs at their times and compares
the frames it sends with the recorded ones (:mod:`ecu.buslog.replay`). Without ``--ecu`` the
frames go onto a bus (another process's: ``-i virtual`` is refused) at their recorded spacing
and the answering ECU's ACC commands are counted. Exit status: 0 (the same frames), 1 (they
differ: the first difference printed), 2 on a bad recording or options.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dbc.vocab import FormatError
from ecu import EcuError
from pacc.commands._args import CommandParser, add_bus_arguments, bus_error, bus_kwargs, fail

#: state changes printed in full; the rest are counted
MAX_STATES_SHOWN = 12


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(
        prog="pacc replay",
        description="replay a bus recording through the ECU (--ecu, deterministic) or onto a "
        "CAN bus in real time",
    )
    p.add_argument("log", type=Path, metavar="LOG", help="a pacc bus recording (.mcap)")
    p.add_argument("--ecu", action="store_true", help="through the ECU; compare its frames")
    p.add_argument("--events", action="store_true", help="--ecu: print every ECU event")
    add_bus_arguments(p, "real time (omitted: python-can's own configuration applies)")
    p.add_argument("--frames", choices=("all", "rx", "tx"), default="all", help="frames to send")
    return p


def _ecu(args: argparse.Namespace) -> int:
    from ecu.buslog.reader import read_recording  # noqa: PLC0415 - numpy, mcap only when run
    from ecu.buslog.replay import replay_through_ecu  # noqa: PLC0415

    log = read_recording(args.log, _warn)
    result = replay_through_ecu(log)
    n_rx = int(log.frames.rx.sum())
    print(
        f"replay: {args.log} (recorded by {log.node or '?'} from "
        f"{log.metadata.get('pacc', {}).get('start_utc', '?')}), {len(log.frames)} frames, "
        "through the ECU"
    )
    print(f"  fed to the ECU   {n_rx} received frames at their recorded times")
    diff = result.first_difference()
    verdict = (
        f"identical to the recording ({len(result.recorded)} of {len(result.recorded)})"
        if diff is None
        else f"DIFFERENT from the recording from frame {diff} on"
    )
    print(f"  ECU sent         {len(result.sent)} frames: {verdict}")
    if result.unreplayed:
        print(
            f"    (the recording was killed: the {result.unreplayed} frames its node sent "
            "after its last recorded cycle are not compared)"
        )
    if diff is not None:
        mine = result.sent[diff] if diff < len(result.sent) else None
        theirs = result.recorded[diff] if diff < len(result.recorded) else None
        print(f"    replayed {_frame(mine)}\n    recorded {_frame(theirs)}")
    shown = ", ".join(f"{t:.2f} s {s}" for t, s in result.states[:MAX_STATES_SHOWN])
    more = len(result.states) - MAX_STATES_SHOWN
    print(f"  ACC states       {shown}" + (f" (+{more} more)" if more > 0 else ""))
    if args.events:
        for t, text in result.events:
            print(f"    t={t:.2f} s  {text}")
    # the compute time of a cycle means nothing in a lockstep replay: left out
    summary = str(result.summary).splitlines()
    print("\n".join("  " + line for line in summary if not line.startswith("max cycle time")))
    return 0 if diff is None else 1


def _frame(f: tuple[float, int, bytes] | None) -> str:
    return "none" if f is None else f"t={f[0]:.3f} s id={f[1]:#x} data={f[2].hex()}"


def _realtime(args: argparse.Namespace) -> int:
    import can  # noqa: PLC0415

    from ecu.buslog.reader import read_recording  # noqa: PLC0415
    from ecu.buslog.replay import play  # noqa: PLC0415

    log = read_recording(args.log, _warn)
    try:
        bus = can.Bus(**bus_kwargs(args))
    except (can.CanError, OSError, ValueError, ImportError) as exc:
        return fail("pacc replay", bus_error(args, exc))
    with bus:
        try:
            result = play(log, bus, which=args.frames)
        except KeyboardInterrupt:
            print("pacc replay: interrupted", file=sys.stderr)
            return 0
    states = ", ".join(f"{k} {v}" for k, v in sorted(result.states.items())) or "none"
    print(
        f"replay: {result.frames_sent} frames of {args.log} sent on {bus.channel_info}"
        + (f" ({result.send_errors} refused by the bus)" if result.send_errors else "")
    )
    print(f"  ACC commands received: {result.commands} (by state: {states})")
    return 0


def _warn(text: str) -> None:
    print(f"pacc replay: warning: {text}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc replay``; returns the exit status."""
    args = _parser().parse_args(argv)
    if args.ecu and (args.interface or args.channel or args.bitrate):
        print("pacc replay: error: --ecu needs no bus: drop the bus options", file=sys.stderr)
        return 2
    if not args.ecu and args.interface == "virtual":
        print(
            "pacc replay: error: -i virtual is this process's own bus: no other ECU can listen; "
            "use a bus that crosses processes, -i socketcan -c vcan0 or -i remote -c "
            "ws://127.0.0.1:54701/ (docs/vehicles.md), or --ecu",
            file=sys.stderr,
        )
        return 2
    try:
        return _ecu(args) if args.ecu else _realtime(args)
    except (EcuError, FormatError) as exc:
        return fail("pacc replay", exc)
