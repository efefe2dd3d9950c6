"""The reports a study spec names, from its rows: one place that writes a study's outputs.

- ``table1``: ``table1.md``, ``drives.csv``, ``study.png`` and ``irl/<driver>.json``
  (:mod:`pacc.study.report`);
- ``population``: ``population.md`` and ``drives.csv`` (:mod:`pacc.study.population_report`);
- ``summary`` (a study file, ``pacc bench``): ``summary.md``, ``drives.csv`` with the
  method's columns and no wall times (the same spec gives the same file, in-process or on
  Dask), ``timings.csv``;
- ``incremental``: ``incremental.md``, ``.csv`` and ``.png`` (:mod:`pacc.study.incremental_report`).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from dbc.vocab.dgpt import Dgpt
from dbc.vocab.dgpt_file import save_dgpt
from pacc.study import incremental_report, report
from pacc.study.loop import StudyCloud, cloud_irl_tables, run_incremental
from pacc.study.population_report import format_population
from pacc.study.spec import StudySpec
from sim_bus.drivers import DriverParams

#: the columns of a study file's drives.csv
SUMMARY_FIELDS = (
    "driver", "scenario", "method", "table", "adaptation", "controller", "trial", "seed",
    "poi_pct", "nim_per_min", "press_onsets", "min_gap_m", "min_ttc_s", "rms_jerk_mps3",
    "gap_error_rms_m", "takeovers", "adaptations", "collision", "plugin_faults",
)  # fmt: skip


def write_rows(path: Path, rows: Sequence[Mapping[str, Any]], kind: str) -> None:
    """``drives.csv`` of a report ``kind``: Table I's columns, or a study file's."""
    if kind == "summary":  # a study file's "controller" is the gap controller
        rows = [{**r, "controller": r["gap_controller"]} for r in rows]
    report.write_csv(path, rows, SUMMARY_FIELDS if kind == "summary" else report.FIELDS)


def write(
    spec: StudySpec,
    drivers: Mapping[str, DriverParams],
    tables: Mapping[tuple[str, str], Dgpt | str],
    rows: Sequence[dict[str, Any]],
    out: Path,
) -> None:
    """The outputs of ``spec.report`` (module docstring) into ``out``."""
    write_rows(out / "drives.csv", rows, spec.report)
    if spec.report == "table1":
        (out / "irl").mkdir(exist_ok=True)
        for m in spec.methods:
            if m.table != "predefined":
                for d in drivers:
                    table = tables[(d, m.table_key)]
                    if isinstance(table, Dgpt):
                        save_dgpt(table, out / "irl" / f"{d}.json")
        (out / "table1.md").write_text(report.format_table(spec, rows), encoding="utf-8")
        report.plot(out / "study.png", rows)
    elif spec.report == "population":
        (out / "population.md").write_text(format_population(spec, rows), encoding="utf-8")
    else:
        write_timings(out / "timings.csv", tables, rows)
        names = [m.name for m in spec.methods]
        (out / "summary.md").write_text(summary_table(rows, names), encoding="utf-8")


def incremental(
    spec: StudySpec, drivers: Mapping[str, DriverParams], out: Path, cloud: StudyCloud
) -> list[dict[str, Any]]:
    """The incremental-learning experiment (:func:`pacc.study.loop.run_incremental`) and its
    report; the rows."""
    rows = run_incremental(spec, drivers, cloud, cloud_irl_tables(cloud, drivers, spec.seed))
    report.write_csv(out / "incremental.csv", rows, incremental_report.INCREMENTAL_FIELDS)
    text = incremental_report.format_incremental(rows)
    (out / "incremental.md").write_text(text, encoding="utf-8")
    incremental_report.plot_incremental(out / "incremental.png", rows)
    return rows


def write_timings(
    path: Path, tables: Mapping[tuple[str, str], Dgpt | str], rows: Sequence[Mapping[str, Any]]
) -> None:
    """Learning and drive wall times (s), and why a learner learned no table."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["driver", "what", "name", "wall_s", "error"])
        for (driver, key), table in tables.items():
            name = key.split('"')[1]
            if isinstance(table, str):
                w.writerow([driver, "learn", name, "", table])
            elif "learn_s" in table.meta:
                w.writerow([driver, "learn", name, table.meta["learn_s"], ""])
        for r in rows:
            what = f"{r['method']} {r['scenario']} {r['trial']}"
            w.writerow([r["driver"], "drive", what, f"{float(r['wall_s']):.3f}", ""])


def summary_table(rows: Sequence[Mapping[str, Any]], methods: Sequence[str]) -> str:
    """Markdown: per method, drives, mean PoI and NIM, lowest TTC, collisions, plug-in faults."""
    lines = [
        "| method | drives | PoI % | NIM /min | min TTC s | collisions | plug-in faults |",
        "|---|---|---|---|---|---|---|",
    ]
    for name in methods:
        mine = [r for r in rows if r["method"] == name]
        if not mine:
            lines.append(f"| {name} | 0 | – | – | – | – | – |")
            continue
        ttc = min(float(r["min_ttc_s"]) for r in mine)
        lines.append(
            f"| {name} | {len(mine)} | {np.mean([r['poi_pct'] for r in mine]):.2f} | "
            f"{np.mean([r['nim_per_min'] for r in mine]):.2f} | "
            f"{ttc:.2f}{'' if math.isfinite(ttc) else ''} | "
            f"{sum(int(r['collision']) for r in mine)} | "
            f"{sum(1 for r in mine if r['plugin_faults'])} |"
        )
    return "\n".join(lines) + "\n"


__all__ = ["SUMMARY_FIELDS", "incremental", "summary_table", "write", "write_rows", "write_timings"]
