"""``pacc study``: the command line builds one :class:`~pacc.study.spec.StudySpec` (every mode
is a choice of it), the pipeline runs it (:func:`pacc.study.pipeline.run`)."""

from __future__ import annotations

import argparse
import os
import socket
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from cloud_sync.errors import CloudSyncError, EngineError
from dbc.errors import DbcError, error_line
from dbc.network import add_network_arguments, codec_of
from dbc.vocab import FormatError
from ecu import EcuError
from pacc.commands._args import (
    ADAPTATION_MODES,
    BUSES,
    CONTROLLERS,
    DEFAULT_POPULATION,
    POPULATIONS,
    ROADS,
    CommandParser,
    add_cloud_arguments,
    fail,
    integer,
    number,
)
from sim_bus.errors import SimError

if TYPE_CHECKING:
    from pacc.study.spec import StudySpec

_DESCRIPTION = "the paper's human-in-the-loop study (its Table I), end to end on the bus"


def _name_list(text: str) -> tuple[str, ...]:
    """An argparse ``type``: a comma-separated list naming at least one thing."""
    names = tuple(x.strip() for x in text.split(",") if x.strip())
    if not names:
        raise argparse.ArgumentTypeError(f"{text!r} names nothing (a comma-separated list)")
    return names


def _parser() -> argparse.ArgumentParser:
    p = CommandParser(prog="pacc study", description=_DESCRIPTION)
    p.add_argument("--drivers", type=_name_list, help="d1..d5, driver files or KIND:N:SEED")
    p.add_argument("--scenarios", type=_name_list, help="comma-separated (default A,B)")
    p.add_argument(
        "--controllers", type=_name_list, default=CONTROLLERS, help=",".join(CONTROLLERS)
    )
    p.add_argument("--trials", type=integer(1, 1000), help="drives per cell (default 3)")
    p.add_argument("--seed", type=integer(0), default=0, help="study seed (default 0)")
    p.add_argument("--duration", type=number(0.0, 1e5, lo_open=True), help="s per drive")
    p.add_argument("--workers", type=integer(1, 256), default=min(2, os.cpu_count() or 1))
    p.add_argument("--scheduler", metavar="local|tcp://HOST:8786", help="Dask (docs/scale.md)")
    p.add_argument("--out", type=Path, default=Path("out/study"), help="output folder")
    p.add_argument("--config", type=Path, metavar="FILE", help="a study file or a manifest.json")
    p.add_argument("--no-logs", action="store_true", help="do not write MCAP logs")
    p.add_argument("--can-logs", action="store_true", help="record every drive's bus (OUT/can/)")
    p.add_argument("--cache", type=Path, help="cache folder of learned IRL tables")
    p.add_argument("--adaptation", "--adaptation-mode", choices=ADAPTATION_MODES)
    cloud = p.add_argument_group("the vehicle-cloud loop (docs/cloud.md)")
    add_cloud_arguments(cloud)
    cloud.add_argument("--direct", action="store_true", help="no cloud: learn in-process")
    cloud.add_argument("--incremental", type=integer(1, 1000), default=0, metavar="N")
    p.add_argument("--population", type=integer(1, 100_000), default=0, metavar="N")
    p.add_argument("--population-kind", choices=POPULATIONS, default=DEFAULT_POPULATION)
    p.add_argument(
        "--roads",
        choices=ROADS,
        help="one lead road per seed or per driver "
        "(default: per-driver with --population, else shared)",
    )
    p.add_argument("--bus", choices=BUSES, default=BUSES[0], help="python-can bus of each drive")
    p.add_argument("--hil", type=Path, metavar="SESSIONS", help="Table I of pacc hil sessions")
    p.add_argument("--beside", type=Path, metavar="DRIVES_CSV", help="with --hil: a drives.csv")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    add_network_arguments(p)
    return p


def _check_scheduler(address: str | None) -> None:
    """EngineError unless the Dask scheduler at a ``tcp://HOST:PORT`` address accepts a
    connection (5 s); ``local`` and other schemes are left to the engine."""
    if address is None or not address.startswith("tcp://"):
        return
    host, _, port = address.removeprefix("tcp://").rpartition(":")
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=5.0).close()
    except (OSError, ValueError) as exc:
        raise EngineError(f"no Dask scheduler answers at {address}: {exc}") from exc


def _spec(args: argparse.Namespace, argv: list[str]) -> tuple[StudySpec, dict[str, Any] | None]:
    """The spec of the command line and the study file's config (``--config``; ``--workers``
    and ``--scheduler`` given here replace its own), or HIL sessions', a population's, Table I's."""
    from pacc.study.drive import adaptation_params  # noqa: PLC0415 - the harness: not for --help
    from pacc.study.spec import StudySpec, load_study_file, spec_of, table1_method  # noqa: PLC0415

    if args.hil is not None:
        beside = None if args.beside is None else str(args.beside)
        return StudySpec(report="hil", sessions=str(args.hil), beside=beside), None
    if args.config is not None:
        config = load_study_file(args.config)
        spec = spec_of(config)
        workers = args.workers if "--workers" in argv else spec.workers
        scheduler = args.scheduler or spec.scheduler
        return replace(spec, workers=workers, scheduler=scheduler), config
    bad = [c for c in args.controllers if c not in CONTROLLERS]
    if bad:
        raise SimError(f"unknown controllers {bad}: choose from {', '.join(CONTROLLERS)}")
    pop = args.population != 0
    if pop and (args.drivers is not None or args.cloud is not None or args.incremental):
        raise SimError("--population: not with --drivers, --cloud or --incremental")
    if pop and args.can_logs:
        raise SimError("--population keeps no logs: not with --can-logs")
    drawn = (f"{args.population_kind}:{args.population if pop else 5}:{args.seed}",)
    return StudySpec(
        drivers=drawn if pop else args.drivers or drawn,
        scenarios=args.scenarios or (("B",) if pop else ("A", "B")),
        methods=tuple(table1_method(c) for c in args.controllers),
        trials=args.trials if args.trials is not None else (1 if pop else 3),
        seed=args.seed,
        duration_s=args.duration if args.duration is not None or not pop else 120.0,
        report="incremental" if args.incremental else "population" if pop else "table1",
        learn_in="direct" if args.direct or pop else "cloud",
        logs=not (args.no_logs or pop),
        can_logs=args.can_logs,
        adaptation=adaptation_params(args.adaptation),
        cloud=args.cloud,
        token_file=args.token_file,
        trust=args.trust,
        incremental=args.incremental,
        dbc=args.dbc,
        binding=args.binding,
        bus=args.bus,
        roads=args.roads or ("per-driver" if pop else "shared"),
        workers=args.workers,
        scheduler=args.scheduler,
    ), None


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc study``; 0 on success, 1 if a drive collided, 2 on bad input."""
    args = _parser().parse_args(argv)
    from pacc.study.manifest import write_manifest  # noqa: PLC0415
    from pacc.study.pipeline import StudyInterrupted, run  # noqa: PLC0415

    start = time.perf_counter()
    try:
        spec, config = _spec(args, list(sys.argv[1:] if argv is None else argv))
        if spec.report == "hil":
            return _hil_table(spec, args.out)
        codec_of(args)  # a DBC without its binding, a binding that does not fit: refused now
        if config is not None:
            extra = {"workers": spec.workers, "scheduler": spec.scheduler or ""}
            write_manifest(args.out, {**config, **extra})
        _check_scheduler(spec.scheduler)  # now, not after every table is learned
        if any(m.table != "predefined" for m in spec.methods) and not args.quiet:
            cloud = f"in the cloud ({spec.cloud or args.out / 'cloud'})"
            where = "in-process" if spec.learn_in == "direct" else cloud
            print(f"pacc study: learning the drivers' tables {where} ...", file=sys.stderr)
        rows = run(spec, args.out, cache_dir=args.cache, progress=not args.quiet)
    except StudyInterrupted as exc:
        print(f"pacc study: {exc}", file=sys.stderr)
        return 130
    except (SimError, EcuError, FormatError, CloudSyncError, DbcError, OSError) as exc:
        return fail("pacc study", error_line(exc))
    report, files = _OUTPUTS[spec.report]
    print((args.out / report).read_text(encoding="utf-8"))
    files += (", logs/" if spec.logs else "") + (", can/" if spec.can_logs else "")
    files += ", cloud/" if spec.learn_in == "cloud" else ""
    took = time.perf_counter() - start
    print(f"{len(rows)} drives in {took:.1f} s; outputs in {args.out}/ ({files})")
    if args.config is not None:
        print(f"run it again with 'pacc study --config {args.out}/manifest.json'")
    return 1 if any(int(r["collision"]) for r in rows) else 0


#: what each report prints, and the files it names
_OUTPUTS = {
    "table1": ("table1.md", "table1.md, drives.csv, study.png, irl/"),
    "population": ("population.md", "population.md, drives.csv, rows.jsonl"),
    "summary": ("summary.md", "manifest.json, drives.csv, timings.csv, summary.md"),
    "incremental": ("incremental.md", "incremental.md, incremental.csv, incremental.png"),
}


def _hil_table(spec: StudySpec, out: Path) -> int:
    """``pacc study --hil SESSIONS``: Table I of real participants (pacc.hil.report)."""
    from pacc.hil.report import build_table  # noqa: PLC0415 - only this path needs it

    assert spec.sessions is not None
    try:
        beside = None if spec.beside is None else Path(spec.beside)
        print(build_table(Path(spec.sessions), out, beside), end="")
    except (SimError, FormatError, OSError) as exc:
        return fail("pacc study", exc)
    print(f"outputs in {out}/ (table1.md, drives.csv, table1.png)")
    return 0
