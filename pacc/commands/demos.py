"""``pacc demos extract LOG... -o trips/``: a real car's bus logs as IRL demonstrations.

Every LOG (any python-can format or pacc's ``.mcap``) is decoded through the car's binding and
its manual car-following stretches (``--min-s`` or longer) are written as manual trip logs
``OUT/<log>_<k>.mcap`` (:mod:`cloud_sync.irl.sources.bus_demos`), with a report per log. Exit
status: 0, 1 when no log gave a demonstration, 2 on a bad log, network or output folder.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from dbc.errors import DbcError, PaccError
from dbc.network import add_network_arguments, codec_of
from dbc.vocab.sampling import MANUAL_MIN_S
from pacc.commands._args import CommandParser, fail, number


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(
        prog="pacc demos", description="demonstrations for the cloud from real bus logs"
    )
    sub = p.add_subparsers(dest="action", required=True)
    ex = sub.add_parser(
        "extract",
        help="the manual car-following stretches of bus logs as trip logs",
        description=__doc__.splitlines()[0] if __doc__ else None,
    )
    ex.add_argument("logs", nargs="+", type=Path, metavar="LOG", help="bus logs (BLF, ASC ...)")
    ex.add_argument("-o", "--out", type=Path, required=True, help="folder of the trip logs")
    ex.add_argument("--driver", default="guest", help="driver id of the trips (default guest)")
    ex.add_argument("--condition", default="default", help="condition (default 'default')")
    ex.add_argument("--min-s", type=number(0.0, 1e6), default=MANUAL_MIN_S, help="shortest kept, s")
    add_network_arguments(ex)
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc demos``; returns the exit status."""
    args = _parser().parse_args(argv)
    if not math.isfinite(args.min_s) or args.min_s <= 0:
        print("pacc demos: error: --min-s must be a positive number", file=sys.stderr)
        return 2
    from cloud_sync.irl.sources.bus_demos import extract_demos  # noqa: PLC0415 - numpy, python-can
    from dbc.vocab.triplog_file import write_trip  # noqa: PLC0415

    written = 0
    try:
        codec = codec_of(args)
        args.out.mkdir(parents=True, exist_ok=True)
        for log in args.logs:
            if not log.is_file():
                raise FileNotFoundError(f"{log}: no such log")
            report = extract_demos(
                log, codec, driver_id=args.driver, condition=args.condition, min_s=args.min_s
            )
            for k, trip in enumerate(report.trips):
                path = args.out / f"{log.stem}_{k:03d}.mcap"
                write_trip(path, trip)
                written += 1
            print("\n".join(report.lines()))
    except (PaccError, DbcError, OSError, ValueError) as exc:
        return fail("pacc demos", exc)
    print(f"demos: {written} trip logs written to {args.out}")
    return 0 if written else 1
