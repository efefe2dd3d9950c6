"""``pacc study``: the paper's human-in-the-loop study (its Table I), end to end on the bus.

For every synthetic driver the IRL table is learned from its manual drives on the four
manual profiles (``cloud_sync.trainer`` via :func:`sim_bus.irl_table.irl_table`, cached);
then every driver × scenario (A seen, B unseen) × controller (Predefined, Predefined + OA,
IRL, IRL + OA) × trial is one lockstep closed-loop drive through the python-can virtual bus
with the DBC codec and the full ECU (:func:`sim_bus.drive.run_drive`). Each cell averages
its trials, as the paper's cells average three.

Every drive is a pure function of (driver, scenario, controller, study seed, trial): the
scenarios and the IRL tables come from the study seed, the drive's noise from
``seed + trial``. Drives run in a process pool and the results do not depend on the number
of workers. Output folder: ``table1.md`` (the table, averages, reductions, the paper's
figures beside ours), ``drives.csv`` (one row per drive), ``study.png`` (averages, ours vs
the paper), ``irl/<driver>.json`` (the learned tables) and ``logs/*.mcap`` (every drive as
a trip log).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sim_bus.drive import ADAPTATION_MODE_CHOICES, CONTROLLERS

if TYPE_CHECKING:
    from ecu.adaptation import AdaptationParams
    from ecu.dgpt import Dgpt

#: Averages of the paper's Table I (PoI %, NIM per minute), for comparison.
PAPER_AVERAGES: dict[str, tuple[float, float]] = {
    "predefined": (20.3, 10.7),
    "predefined+oa": (8.2, 6.3),
    "irl": (14.5, 6.4),
    "irl+oa": (7.5, 4.1),
}
CONTROLLER_TITLES = {
    "predefined": "Predefined",
    "predefined+oa": "Predefined + OA",
    "irl": "IRL",
    "irl+oa": "IRL + OA",
}
SCENARIO_TITLES = {"A": "Seen (A)", "B": "Unseen (B)"}
#: Per-drive columns of drives.csv.
FIELDS = (
    "driver",
    "scenario",
    "controller",
    "trial",
    "seed",
    "poi_pct",
    "nim_per_min",
    "press_onsets",
    "acc_on_s",
    "min_gap_m",
    "min_ttc_s",
    "rms_jerk_mps3",
    "gap_error_rms_m",
    "takeovers",
    "adaptations",
    "collision",
    "sim_s",
    "wall_s",
)


@dataclass(frozen=True)
class StudyConfig:
    """What to run. ``seed`` fixes the scenarios and the IRL tables; trial k drives with
    noise seed ``seed + k``. ``duration_s`` shortens every drive (None: the full 300 s).
    ``adaptation``: the online adaptation of the +oa controllers (None: the ECU's default)."""

    drivers: tuple[str, ...] = ("d1", "d2", "d3", "d4", "d5")
    scenarios: tuple[str, ...] = ("A", "B")
    controllers: tuple[str, ...] = CONTROLLERS
    trials: int = 3
    seed: int = 0
    duration_s: float | None = None
    workers: int = 2
    logs: bool = True
    adaptation: AdaptationParams | None = None


@dataclass(frozen=True)
class DriveJob:
    """One drive of the study; everything a worker process needs, picklable."""

    driver: str
    scenario: str
    controller: str
    trial: int
    study_seed: int
    duration_s: float | None
    table: Dgpt
    log_path: str | None
    adaptation: AdaptationParams | None = None


def run_job(job: DriveJob) -> dict[str, Any]:
    """Run one drive (in a worker process) and return its row of drives.csv."""
    from sim_bus.drive import DriveConfig, log_to_trip, run_drive
    from sim_bus.drivers import load_driver
    from sim_bus.scenarios import canonical_profiles

    driver = load_driver(job.driver)
    seed = job.study_seed + job.trial
    cfg = DriveConfig(
        scenario=job.scenario,
        driver_id=driver.driver_id,
        controller=job.controller,
        seed=seed,  # type: ignore[arg-type]
        duration_s=job.duration_s,
        adaptation=job.adaptation,
    )
    profile = canonical_profiles(job.study_seed)[job.scenario]
    result = run_drive(cfg, driver, job.table, profile)
    if job.log_path is not None:
        from ecu.triplog import write_trip

        write_trip(Path(job.log_path), log_to_trip(result, driver))
    m = result.metrics
    return {
        "driver": job.driver,
        "scenario": job.scenario,
        "controller": job.controller,
        "trial": job.trial,
        "seed": seed,
        "poi_pct": m.poi_pct,
        "nim_per_min": m.nim_per_min,
        "press_onsets": m.press_onsets,
        "acc_on_s": m.acc_on_s,
        "min_gap_m": m.min_gap_m,
        "min_ttc_s": m.min_ttc_s,
        "rms_jerk_mps3": m.rms_jerk_mps3,
        "gap_error_rms_m": m.gap_error_rms_m,
        "takeovers": result.takeovers,
        "adaptations": result.adaptations,
        "collision": int(result.collision),
        "sim_s": result.sim_s,
        "wall_s": result.wall_s,
    }


def tables_for(cfg: StudyConfig, cache_dir: Path | None) -> dict[tuple[str, str], Dgpt]:
    """The control table of every (driver, controller kind): predefined or learned by IRL."""
    from sim_bus.drive import predefined_table
    from sim_bus.drivers import load_driver
    from sim_bus.irl_table import irl_table

    tables: dict[tuple[str, str], Dgpt] = {}
    for name in cfg.drivers:
        driver = load_driver(name)
        if any(c.startswith("predefined") for c in cfg.controllers):
            tables[(name, "predefined")] = predefined_table(driver)
        if any(c.startswith("irl") for c in cfg.controllers):
            tables[(name, "irl")] = irl_table(driver, cfg.seed, cache_dir)
    return tables


def plan(cfg: StudyConfig, tables: dict[tuple[str, str], Dgpt], out: Path) -> list[DriveJob]:
    """Every drive of the study, in a fixed order."""
    jobs = []
    for name in cfg.drivers:
        for scenario in cfg.scenarios:
            for controller in cfg.controllers:
                kind = "irl" if controller.startswith("irl") else "predefined"
                for trial in range(cfg.trials):
                    log = (
                        (
                            out / "logs" / f"{name}_{scenario}_{controller.replace('+', '_')}"
                            f"_t{trial}.mcap"
                        )
                        if cfg.logs
                        else None
                    )
                    jobs.append(
                        DriveJob(
                            name,
                            scenario,
                            controller,
                            trial,
                            cfg.seed,
                            cfg.duration_s,
                            tables[(name, kind)],
                            None if log is None else str(log),
                            cfg.adaptation,
                        )
                    )
    return jobs


def run_jobs(jobs: Sequence[DriveJob], workers: int, progress: bool = True) -> list[dict[str, Any]]:
    """Run ``jobs`` on ``workers`` processes (1: in this process); rows in job order."""
    from tqdm import tqdm

    bar = tqdm(total=len(jobs), desc="drives", unit="drive", disable=not progress, file=sys.stderr)
    try:
        if workers <= 1:
            rows = []
            for job in jobs:
                rows.append(run_job(job))
                bar.update()
            return rows
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        ctx = multiprocessing.get_context("spawn" if sys.platform != "linux" else "fork")
        with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
            rows = []
            for row in pool.map(run_job, jobs, chunksize=1):
                rows.append(row)
                bar.update()
            return rows
    finally:
        bar.close()


def cell_means(rows: Iterable[dict[str, Any]]) -> dict[tuple[str, str, str], tuple[float, float]]:
    """(driver, scenario, controller) -> (mean PoI %, mean NIM /min) over the trials."""
    acc: dict[tuple[str, str, str], list[tuple[float, float]]] = {}
    for r in rows:
        acc.setdefault((r["driver"], r["scenario"], r["controller"]), []).append(
            (float(r["poi_pct"]), float(r["nim_per_min"]))
        )
    return {
        k: (sum(p for p, _ in v) / len(v), sum(n for _, n in v) / len(v)) for k, v in acc.items()
    }


def averages(
    means: dict[tuple[str, str, str], tuple[float, float]],
) -> dict[str, tuple[float, float]]:
    """controller -> (PoI %, NIM) averaged over every driver and scenario cell."""
    out: dict[str, tuple[float, float]] = {}
    for controller in CONTROLLERS:
        cells = [v for (_, _, c), v in means.items() if c == controller]
        if cells:
            out[controller] = (
                sum(p for p, _ in cells) / len(cells),
                sum(n for _, n in cells) / len(cells),
            )
    return out


def reduction_pct(base: float, value: float) -> float:
    """Relative reduction of ``value`` against ``base`` in percent (nan if base is 0)."""
    return (base - value) / base * 100.0 if base > 0 else math.nan


def format_table(cfg: StudyConfig, rows: Sequence[dict[str, Any]]) -> str:
    """Table I in Markdown: driver × scenario rows, PoI / NIM per controller, the average,
    the reductions against Predefined and the paper's averages beside ours."""
    means = cell_means(rows)
    controllers = [c for c in CONTROLLERS if c in cfg.controllers]
    head = (
        "| driver | scenario | "
        + " | ".join(f"{CONTROLLER_TITLES[c]} PoI | NIM" for c in controllers)
        + " |"
    )
    lines = [head, "|" + "---|" * (2 + 2 * len(controllers))]
    for name in cfg.drivers:
        for scenario in cfg.scenarios:
            cells = []
            for c in controllers:
                poi, nim = means[(name, scenario, c)]
                cells.append(f"{poi:.1f} % | {nim:.1f}")
            lines.append(
                f"| {name} | {SCENARIO_TITLES.get(scenario, scenario)} | "
                + " | ".join(cells)
                + " |"
            )
    avg = averages(means)
    lines.append(
        "| **average** | | "
        + " | ".join(f"**{avg[c][0]:.1f} %** | **{avg[c][1]:.1f}**" for c in controllers)
        + " |"
    )
    lines.append(
        "| paper (average) | | "
        + " | ".join(
            f"{PAPER_AVERAGES[c][0]:.1f} % | {PAPER_AVERAGES[c][1]:.1f}" for c in controllers
        )
        + " |"
    )
    out = [
        "# Table I — interventions per controller (synthetic drivers, CAN bus)",
        "",
        f"{len(cfg.drivers)} drivers × {len(cfg.scenarios)} scenarios × "
        f"{len(controllers)} controllers × {cfg.trials} trials = {len(rows)} drives, "
        f"study seed {cfg.seed}"
        + ("" if cfg.duration_s is None else f", {cfg.duration_s:g} s each")
        + ("" if cfg.adaptation is None else f", {cfg.adaptation.mode} adaptation")
        + ".",
        "PoI: % of ACC-ON time with a pedal pressed; NIM: pedal presses per minute.",
        "",
        *lines,
        "",
    ]
    if "predefined" in avg:
        base = avg["predefined"]
        out.append("Reduction against Predefined (ours; paper in brackets):")
        out.append("")
        for c in controllers:
            if c == "predefined":
                continue
            ours = (reduction_pct(base[0], avg[c][0]), reduction_pct(base[1], avg[c][1]))
            p = PAPER_AVERAGES
            paper = (
                reduction_pct(p["predefined"][0], p[c][0]),
                reduction_pct(p["predefined"][1], p[c][1]),
            )
            out.append(
                f"- {CONTROLLER_TITLES[c]}: PoI {ours[0]:.1f} % ({paper[0]:.1f} %), "
                f"NIM {ours[1]:.1f} % ({paper[1]:.1f} %)"
            )
        out.append("")
    collisions = sum(int(r["collision"]) for r in rows)
    min_gap = min(float(r["min_gap_m"]) for r in rows)
    min_ttc = min(float(r["min_ttc_s"]) for r in rows)
    out.append(
        f"Safety over all drives: {collisions} collisions, min gap {min_gap:.2f} m, "
        f"min TTC {min_ttc:.2f} s."
    )
    return "\n".join(out) + "\n"


def write_csv(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """One row per drive, columns :data:`FIELDS`."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=FIELDS)
        writer.writeheader()
        writer.writerows(rows)


def plot(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """Bar charts of the average PoI and NIM per controller, ours beside the paper's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    avg = averages(cell_means(rows))
    controllers = [c for c in CONTROLLERS if c in avg]
    x = np.arange(len(controllers))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, k, label in ((axes[0], 0, "PoI (%)"), (axes[1], 1, "NIM (presses / min)")):
        ax.bar(x - 0.2, [avg[c][k] for c in controllers], 0.4, label="pacc (synthetic drivers)")
        ax.bar(
            x + 0.2, [PAPER_AVERAGES[c][k] for c in controllers], 0.4, label="paper (human drivers)"
        )
        ax.set_xticks(x, [CONTROLLER_TITLES[c] for c in controllers], rotation=15)
        ax.set_ylabel(label)
        ax.grid(axis="y", alpha=0.3)
    axes[0].legend()
    fig.suptitle("Interventions per controller (Table I averages)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def run_study(
    cfg: StudyConfig, out: Path, *, cache_dir: Path | None = None, progress: bool = True
) -> list[dict[str, Any]]:
    """Learn the tables, run every drive, write the outputs to ``out``; the rows."""
    from ecu.dgpt import save_dgpt

    out.mkdir(parents=True, exist_ok=True)
    if cfg.logs:
        (out / "logs").mkdir(exist_ok=True)
    tables = tables_for(cfg, cache_dir)
    (out / "irl").mkdir(exist_ok=True)
    for (name, kind), table in tables.items():
        if kind == "irl":
            save_dgpt(table, out / "irl" / f"{name}.json")
    rows = run_jobs(plan(cfg, tables, out), cfg.workers, progress)
    write_csv(out / "drives.csv", rows)
    (out / "table1.md").write_text(format_table(cfg, rows), encoding="utf-8")
    plot(out / "study.png", rows)
    return rows


def _names(text: str) -> tuple[str, ...]:
    return tuple(x.strip() for x in text.split(",") if x.strip())


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="pacc study", description=__doc__.split("\n\n")[0])
    p.add_argument(
        "--drivers", default="d1,d2,d3,d4,d5", help="comma-separated (d1..d5 or driver files)"
    )
    p.add_argument("--scenarios", default="A,B", help="comma-separated (default A,B)")
    p.add_argument(
        "--controllers",
        default=",".join(CONTROLLERS),
        help="comma-separated subset of " + ",".join(CONTROLLERS),
    )
    p.add_argument("--trials", type=int, default=3, help="drives per cell (default 3)")
    p.add_argument("--seed", type=int, default=0, help="study seed (default 0)")
    p.add_argument("--duration", type=float, help="shorten every drive to N s")
    p.add_argument(
        "--workers",
        type=int,
        default=min(2, os.cpu_count() or 1),
        help="parallel drive processes (default: 2 or the core count)",
    )
    p.add_argument("--out", type=Path, default=Path("out/study"), help="output folder")
    p.add_argument("--no-logs", action="store_true", help="do not write MCAP logs")
    p.add_argument("--cache", type=Path, help="cache folder of learned IRL tables")
    p.add_argument(
        "--adaptation-mode",
        choices=ADAPTATION_MODE_CHOICES,
        help="online adaptation of the +oa controllers (default: the ECU's, see docs/ecu.md)",
    )
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc study``; 0 on success, 1 if a drive collided, 2 on bad input."""
    args = _parser().parse_args(argv)
    from ecu import EcuError
    from sim_bus.drive import adaptation_params
    from sim_bus.drivers import load_driver
    from sim_bus.errors import SimError

    cfg = StudyConfig(
        drivers=_names(args.drivers),
        scenarios=_names(args.scenarios),
        controllers=_names(args.controllers),
        trials=args.trials,
        seed=args.seed,
        duration_s=args.duration,
        workers=max(1, args.workers),
        logs=not args.no_logs,
        adaptation=adaptation_params(args.adaptation_mode),
    )
    try:
        bad = [c for c in cfg.controllers if c not in CONTROLLERS]
        if bad or not cfg.controllers:
            raise SimError(f"unknown controllers {bad}: choose from {', '.join(CONTROLLERS)}")
        if not cfg.drivers or not cfg.scenarios:
            raise SimError("give at least one driver and one scenario")
        if cfg.trials < 1:
            raise SimError("--trials must be >= 1")
        if cfg.duration_s is not None and not cfg.duration_s > 0:
            raise SimError("--duration must be > 0")
        for name in cfg.drivers:
            load_driver(name)
        from sim_bus.scenarios import canonical_profiles

        unknown = [s for s in cfg.scenarios if s not in canonical_profiles(cfg.seed)]
        if unknown:
            raise SimError(f"unknown scenarios {unknown}: A, B or manual1..manual4")
        start = time.perf_counter()
        rows = run_study(cfg, args.out, cache_dir=args.cache, progress=not args.quiet)
    except (SimError, EcuError, OSError) as exc:
        print(f"pacc study: error: {exc}", file=sys.stderr)
        return 2
    print((args.out / "table1.md").read_text(encoding="utf-8"))
    print(
        f"{len(rows)} drives in {time.perf_counter() - start:.1f} s; outputs in {args.out}/ "
        "(table1.md, drives.csv, study.png, irl/, " + ("logs/)" if cfg.logs else "no logs)")
    )
    return 1 if any(int(r["collision"]) for r in rows) else 0


if __name__ == "__main__":
    raise SystemExit(main())
