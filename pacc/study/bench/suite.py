"""``pacc bench``: every selected method on a suite that is hard to overfit.

Population seeds drawn fresh at run time (stored in ``OUT/bench.json``), d1..d5 and the real
OpenACC pairs; two resumable parts on one executor: the closed loop (``OUT/drives``, a study)
and the held-out gap error (``OUT/heldout``); then ``leaderboard.md``, ``.csv``, ``.png``.
"""

from __future__ import annotations

import json
import secrets
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from cloud_sync.engine import open_executor
from pacc.study.bench.heldout import HeldOutTask, heldout_task, real_tasks
from pacc.study.bench.leaderboard import leaderboard, markdown, plot, write_csv
from pacc.study.manifest import write_manifest
from pacc.study.pipeline import ROWS, run, run_resumable
from pacc.study.spec import StudyFileError, StudySpec, resolve, spec_of
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.population import draw_population

BENCH_FILE = "bench.json"
#: the methods of a bench unless a study file names others: the paper's (IRL table +
#: Algorithm 1) first, its predefined baseline, and the alternatives through the interfaces
DEFAULT_METHODS: list[dict[str, Any]] = [
    {"name": "paper", "table": "irl", "adaptation": "paper"},
    {"name": "predefined+paper", "table": "predefined", "adaptation": "paper"},
    {"name": "irl+timegap", "table": "irl", "adaptation": "timegap"},
    {"name": "empirical+timegap", "table": "empirical", "adaptation": "timegap"},
    {"name": "gp+bayes", "table": "gp", "adaptation": "bayes"},
]


@dataclass(frozen=True)
class BenchOptions:
    """What a bench runs (stored in ``OUT/bench.json``; defaults fit a few minutes on 2
    cores)."""

    seeds: tuple[int, ...]
    drivers_per_seed: int = 3
    builtin: bool = True
    scenarios: tuple[str, ...] = ("B",)
    duration_s: float | None = 120.0
    trials: int = 1
    csvs: tuple[str, ...] = ()
    methods: tuple[Mapping[str, Any], ...] = field(default_factory=lambda: tuple(DEFAULT_METHODS))


def fresh_seeds(k: int) -> tuple[int, ...]:
    """``k`` distinct population seeds in [0, 10^6), drawn now from the OS's entropy."""
    return tuple(secrets.SystemRandom().sample(range(10**6), k))


def stored_options(out: Path) -> BenchOptions | None:
    """The options of an earlier bench in ``out`` (None: none there)."""
    path = out / BENCH_FILE
    if not path.is_file():
        return None
    try:
        raw = json.loads(path.read_text(encoding="utf-8"))
        tuples = {k: tuple(raw[k]) for k in ("seeds", "scenarios", "csvs", "methods")}
        return BenchOptions(**{**raw, **tuples})
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise StudyFileError(f"{path} is damaged ({exc}): use another --out") from exc


def study_config(opts: BenchOptions, workers: int, scheduler: str) -> dict[str, Any]:
    """The closed-loop part as a resolved study config."""
    raw = {
        "name": "bench",
        "seed": 0,
        "trials": opts.trials,
        "duration_s": opts.duration_s,
        "workers": workers,
        "scheduler": scheduler,
        "drivers": {
            "builtin": sorted(BUILTIN_DRIVERS) if opts.builtin else [],
            "population": [{"n": opts.drivers_per_seed, "seed": s} for s in opts.seeds],
        },
        "scenarios": {"names": list(opts.scenarios)},
        "methods": [dict(m) for m in opts.methods],
    }
    return resolve(raw, Path.cwd())


def heldout_tasks(opts: BenchOptions, spec: StudySpec) -> list[HeldOutTask]:
    """One task per real pair, built-in and drawn driver; every learner of the methods."""
    learners = tuple(
        dict.fromkeys((m.table, m.learner_args) for m in spec.methods if m.table != "predefined")
    )
    tasks = real_tasks(opts.csvs, learners, 0)
    if opts.builtin:
        tasks += [HeldOutTask(n, "builtin", learners, 0, driver=d)
                  for n, d in sorted(BUILTIN_DRIVERS.items())]  # fmt: skip
    for s in opts.seeds:
        tasks += [HeldOutTask(d.driver_id, "drawn", learners, 0, driver=d, group=str(s))
                  for d in draw_population(opts.drivers_per_seed, s)]  # fmt: skip
    return tasks


def run_bench(
    opts: BenchOptions,
    out: Path,
    *,
    workers: int = 2,
    scheduler: str = "",
    executor: Executor | None = None,
    progress: bool = True,
) -> list[dict[str, Any]]:
    """Run the suite into ``out`` (module docstring); the leaderboard's lines."""
    out.mkdir(parents=True, exist_ok=True)
    (out / BENCH_FILE).write_text(json.dumps(asdict(opts), indent=2, default=list) + "\n",
                                  encoding="utf-8")  # fmt: skip
    config = study_config(opts, workers, scheduler)
    spec = spec_of(config)
    tasks = heldout_tasks(opts, spec)
    own = executor is None
    running = executor or open_executor(scheduler or None, workers)
    try:
        write_manifest(out / "drives", config)
        rows = run(spec, out / "drives", progress=progress, executor=running)
        (out / "heldout").mkdir(exist_ok=True)
        keys = [t.name for t in tasks]
        path = out / "heldout" / ROWS
        records = run_resumable(tasks, heldout_task, keys, path, {"bench": asdict(opts)}, running)
    finally:
        if own:
            running.shutdown(wait=True)
    board = leaderboard(rows, records, config["methods"])
    (out / "leaderboard.md").write_text(markdown(board, header(opts, rows)), encoding="utf-8")
    write_csv(out / "leaderboard.csv", board)
    plot(out / "leaderboard.png", board)
    return board


def header(opts: BenchOptions, rows: Sequence[Mapping[str, Any]]) -> str:
    """What the leaderboard was measured on."""
    drivers = len({r["driver"] for r in rows})
    return (
        f"pacc bench: population seeds {', '.join(map(str, opts.seeds))} (drawn fresh at run "
        f"time), {opts.drivers_per_seed} drivers each"
        + (", plus d1..d5" if opts.builtin else "")
        + f" ({drivers} drivers); scenarios {', '.join(opts.scenarios)}, "
        f"{opts.duration_s or 'full'} s, {opts.trials} trial(s); held out: the OpenACC pairs "
        f"shipped{' and ' + ', '.join(opts.csvs) if opts.csvs else ''}, 70 % train / 30 % test"
    )
