"""The command line of ``pacc study`` (also ``python -m sim_bus.study``): ``main(argv)``."""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

from cloud_sync.errors import CloudSyncError
from dbc.errors import DbcError
from dbc.network import add_network_arguments, codec_of
from ecu import EcuError
from ecu.adaptation import ADAPTATION_MODES
from pacc.vocab import FormatError
from sim_bus.errors import SimError
from sim_bus.study.collect import StudyInterrupted
from sim_bus.study.config import StudyConfig
from sim_bus.study.drive import CONTROLLERS, adaptation_params
from sim_bus.study.population import run_population
from sim_bus.study.run import run_study

_DESCRIPTION = "the paper's human-in-the-loop study (its Table I), end to end on the bus"


def _names(text: str) -> tuple[str, ...]:
    return tuple(x.strip() for x in text.split(",") if x.strip())


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="pacc study", description=_DESCRIPTION)
    p.add_argument(
        "--drivers", help="comma-separated (d1..d5 or driver files; default d1,d2,d3,d4,d5)"
    )
    p.add_argument("--scenarios", help="comma-separated (default A,B; with --population: B)")
    p.add_argument(
        "--controllers",
        default=",".join(CONTROLLERS),
        help="comma-separated subset of " + ",".join(CONTROLLERS),
    )
    p.add_argument("--trials", type=int, help="drives per cell (default 3; with --population: 1)")
    p.add_argument("--seed", type=int, default=0, help="study seed (default 0)")
    p.add_argument(
        "--duration",
        type=float,
        help="shorten every drive to N s (default: the whole 300 s; with --population: 120)",
    )
    p.add_argument(
        "--workers",
        type=int,
        default=min(2, os.cpu_count() or 1),
        help="parallel drive processes (default: 2 or the core count)",
    )
    p.add_argument(
        "--scheduler",
        metavar="local|tcp://HOST:8786",
        help="run the drives and the learning on Dask: 'local' starts a LocalCluster of "
        "--workers processes, an address joins that cluster (docs/scale.md; needs pacc[dask])",
    )
    p.add_argument("--out", type=Path, default=Path("out/study"), help="output folder")
    p.add_argument("--no-logs", action="store_true", help="do not write MCAP logs")
    p.add_argument(
        "--can-logs",
        action="store_true",
        help="also record every drive's bus traffic, decoded, with the ECU's internals "
        "(MCAP, OUT/can/; pacc replay, pacc plot)",
    )
    p.add_argument("--cache", type=Path, help="cache folder of learned IRL tables")
    p.add_argument(
        "--adaptation-mode",
        choices=ADAPTATION_MODES,
        help="online adaptation of the +oa controllers (default: the ECU's, see docs/ecu.md)",
    )
    cloud = p.add_argument_group("the vehicle-cloud loop (docs/cloud.md)")
    cloud.add_argument(
        "--cloud",
        metavar="URL|DIR",
        help="learn the IRL tables in this cloud (default: a fresh embedded one in OUT/cloud)",
    )
    cloud.add_argument("--token-file", help="with --cloud: the vehicle's token file")
    cloud.add_argument("--trust", help="with --cloud: the cloud's public key (PEM)")
    cloud.add_argument(
        "--direct", action="store_true", help="no cloud: learn in-process (cached in --cache)"
    )
    cloud.add_argument(
        "--incremental",
        type=int,
        default=0,
        metavar="N",
        help="instead of Table I: N IRL+OA trips per driver, the cloud fine-tuning between",
    )
    p.add_argument(
        "--population",
        type=int,
        default=0,
        metavar="N",
        help="instead of d1..d5: N drivers drawn with --seed (docs/study.md), resumable",
    )
    p.add_argument(
        "--mismatch",
        type=float,
        default=0.0,
        metavar="S",
        help="with --population: drawn drivers want under ACC a time gap longer by S times "
        "a per-driver offset from the prior N(0.3, 0.3) s (docs/drivers.md; default 0)",
    )
    p.add_argument(
        "--trip-shift",
        type=float,
        default=0.0,
        metavar="SD",
        help="with --population: each trip shifts a driver's headway by N(0, SD) s",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    add_network_arguments(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc study``; 0 on success, 1 if a drive collided, 2 on bad input."""
    args = _parser().parse_args(argv)
    pop = args.population != 0
    if pop and args.drivers is not None:
        print(
            "pacc study: error: --population draws its drivers: not with --drivers", file=sys.stderr
        )
        return 2
    cfg = StudyConfig(
        drivers=_names(args.drivers or "d1,d2,d3,d4,d5"),
        scenarios=_names(args.scenarios or ("B" if pop else "A,B")),
        controllers=_names(args.controllers),
        trials=args.trials if args.trials is not None else (1 if pop else 3),
        seed=args.seed,
        duration_s=args.duration if args.duration is not None or not pop else 120.0,
        workers=max(1, args.workers),
        logs=not args.no_logs,
        can_logs=args.can_logs,
        adaptation=adaptation_params(args.adaptation_mode),
        cloud=args.cloud,
        token_file=args.token_file,
        trust=args.trust,
        direct=args.direct,
        incremental=args.incremental,
        dbc=args.dbc,
        binding=args.binding,
        scheduler=args.scheduler,
        population=args.population,
        mismatch=args.mismatch,
        trip_shift_s=args.trip_shift,
    )
    try:
        codec_of(args)  # a DBC without its binding, a binding that does not fit: refused now
        start = time.perf_counter()
        if pop:
            rows = run_population(cfg, args.out, cache_dir=args.cache, progress=not args.quiet)
            print((args.out / "population.md").read_text(encoding="utf-8"))
            print(
                f"{len(rows)} drives in {time.perf_counter() - start:.1f} s; outputs in "
                f"{args.out}/ (population.md, drives.csv, population.jsonl)"
            )
            return 1 if any(int(r["collision"]) for r in rows) else 0
        rows = run_study(cfg, args.out, cache_dir=args.cache, progress=not args.quiet)
    except StudyInterrupted as exc:
        print(f"pacc study: {exc}", file=sys.stderr)
        return 130
    except (SimError, EcuError, FormatError, CloudSyncError, DbcError, OSError) as exc:
        print(f"pacc study: error: {exc}", file=sys.stderr)
        return 2
    took = time.perf_counter() - start
    if cfg.incremental:
        print((args.out / "incremental.md").read_text(encoding="utf-8"))
        print(
            f"{len(rows)} drives in {took:.1f} s; outputs in {args.out}/ "
            "(incremental.md, incremental.csv, incremental.png, cloud/)"
        )
    else:
        print((args.out / "table1.md").read_text(encoding="utf-8"))
        print(
            f"{len(rows)} drives in {took:.1f} s; outputs in {args.out}/ "
            "(table1.md, drives.csv, study.png, irl/, "
            + ("logs/" if cfg.logs else "no logs")
            + (", can/" if cfg.can_logs else "")
            + (")" if cfg.direct else ", cloud/)")
        )
    return 1 if any(int(r["collision"]) for r in rows) else 0
