"""``pacc bench``: every method on fresh population seeds, d1..d5 and real human data.

Draws ``--seeds K`` population seeds at run time (printed, stored in ``OUT/bench.json``),
runs each method (the default set, or the ``[[methods]]`` of ``--methods study.toml``)
closed-loop on the drawn drivers and d1..d5, measures each learner's held-out gap error
against the empirical baseline on the real OpenACC pairs (and ``--csv`` files), the built-in
and the drawn drivers, and writes ``leaderboard.md``, ``.csv`` and ``.png`` (docs/bench.md).
A run into a folder that holds a bench resumes it with the stored seeds and options.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import tomllib
from pathlib import Path
from typing import TYPE_CHECKING

from cloud_sync.errors import CloudSyncError
from dbc.vocab import FormatError
from ecu import EcuError
from pacc.commands._args import CommandParser, fail, integer, number
from sim_bus.errors import SimError

if TYPE_CHECKING:
    from pacc.study.bench.suite import BenchOptions


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(prog="pacc bench", description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=integer(1, 1000), default=2, metavar="K", help="fresh seeds")
    p.add_argument("--seed-list", metavar="S1,S2", help="these population seeds instead")
    p.add_argument("--drivers-per-seed", type=integer(1, 100_000), default=3, metavar="N")
    p.add_argument("--no-builtin", action="store_true", help="leave d1..d5 out")
    p.add_argument("--scenarios", default="B", help="comma-separated (default B)")
    p.add_argument(
        "--duration",
        type=number(0.0, 1e5, lo_open=True),
        default=120.0,
        help="s per drive (default 120)",
    )
    p.add_argument("--trials", type=integer(1, 1000), default=1)
    p.add_argument("--csv", action="append", default=[], metavar="FILE", help="a real driver")
    p.add_argument("--methods", type=Path, metavar="STUDY.toml", help="its [[methods]]")
    p.add_argument("--out", type=Path, default=Path("out/bench"))
    p.add_argument("--workers", type=integer(1, 512), default=min(2, os.cpu_count() or 1))
    p.add_argument("--scheduler", default="", metavar="local|tcp://HOST:8786")
    p.add_argument("-q", "--quiet", action="store_true")
    return p


def _options(args: argparse.Namespace) -> BenchOptions:
    from pacc.study.bench.suite import (  # noqa: PLC0415 - the harness: not for --help
        DEFAULT_METHODS,
        BenchOptions,
        fresh_seeds,
        stored_options,
    )

    stored = stored_options(args.out)
    if stored is not None:
        print(f"resuming the bench in {args.out} (seeds {list(stored.seeds)})", file=sys.stderr)
        return stored
    try:
        seeds = tuple(int(s) for s in (args.seed_list or "").split(",") if s.strip())
    except ValueError as exc:
        raise SimError(f"--seed-list {args.seed_list}: whole numbers, comma-separated") from exc
    seeds = seeds or fresh_seeds(args.seeds)
    methods = DEFAULT_METHODS
    if args.methods is not None:
        try:
            methods = tomllib.loads(args.methods.read_text(encoding="utf-8"))["methods"]
        except (OSError, ValueError, KeyError) as exc:
            raise SimError(f"--methods {args.methods}: no [[methods]] ({exc})") from exc
    return BenchOptions(
        seeds=seeds,
        drivers_per_seed=args.drivers_per_seed,
        builtin=not args.no_builtin,
        scenarios=tuple(s.strip() for s in args.scenarios.split(",") if s.strip()),
        duration_s=args.duration,
        trials=args.trials,
        csvs=tuple(str(Path(c).resolve()) for c in args.csv),
        methods=tuple(methods),
    )


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc bench``; 0 on success, 2 on bad input."""
    args = _parser().parse_args(argv)
    from pacc.study.bench.suite import run_bench  # noqa: PLC0415

    start = time.perf_counter()
    try:
        opts = _options(args)
        print(f"population seeds (drawn fresh): {', '.join(map(str, opts.seeds))}")
        workers, progress = max(1, args.workers), not args.quiet
        run_bench(opts, args.out, workers=workers, scheduler=args.scheduler, progress=progress)
    except (SimError, EcuError, FormatError, CloudSyncError, OSError) as exc:
        return fail("pacc bench", exc)
    print((args.out / "leaderboard.md").read_text(encoding="utf-8"))
    print(f"took {time.perf_counter() - start:.0f} s; {args.out}/leaderboard.md, .csv, .png")
    return 0
