"""``pacc study --config study.toml`` (or ``--config OUT/manifest.json``): a study file run.

The file names drivers, scenarios, the methods as combinations (table source x learner x
adaptation x controller x parameters), trials and seeds (:mod:`pacc.study.files.studyfile`);
the run writes ``manifest.json``, ``drives.csv``, ``timings.csv`` and ``summary.md`` under
``--out`` and resumes a stopped run (:mod:`pacc.study.files.studyrun`). ``--workers`` and
``--scheduler`` given on the command line replace the file's (they change where the drives
run, never their rows).
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from cloud_sync.errors import CloudSyncError
from dbc.vocab import FormatError
from ecu import EcuError
from pacc.study.files.studyfile import load_study_file
from pacc.study.files.studyrun import run_study_file
from sim_bus.errors import SimError


def run(args: argparse.Namespace, argv: list[str]) -> int:
    """Run the study file ``args.config`` into ``args.out``; the exit status (1: a collision)."""
    start = time.perf_counter()
    try:
        config: dict[str, Any] = load_study_file(args.config)
        if args.scheduler is not None:
            config["scheduler"] = args.scheduler
        if "--workers" in argv:
            config["workers"] = max(1, args.workers)

        def say(text: str) -> None:
            if not args.quiet:
                print(f"  {text}", file=sys.stderr)

        rows = run_study_file(config, args.out, progress=say)
    except (SimError, EcuError, FormatError, CloudSyncError, OSError) as exc:
        print(f"pacc study: error: {exc}", file=sys.stderr)
        return 2
    print((args.out / "summary.md").read_text(encoding="utf-8"))
    print(
        f"{len(rows)} drives in {time.perf_counter() - start:.1f} s; outputs in {args.out}/ "
        "(manifest.json, drives.csv, timings.csv, summary.md); run it again with "
        f"'pacc study --config {args.out}/manifest.json'"
    )
    return 1 if any(int(r["collision"]) for r in rows) else 0


__all__ = ["run"]
