"""The study's one report writer: every mode's Markdown, CSV and plots, from the per-drive rows.

:func:`write` writes the outputs of the spec's mode: ``table1`` (``table1.md``, ``drives.csv``,
``study.png``, ``irl/<driver>.json``), ``population`` (``population.md``: bootstrap intervals
and paired tests over drivers, :mod:`pacc.study.stats`), ``summary`` (a study file or ``pacc
bench``: ``summary.md``, ``drives.csv`` without wall times, ``timings.csv``); :func:`incremental`
runs and writes ``--incremental N`` (``incremental.md``, ``.csv``, ``.png``).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from dbc.vocab.dgpt import Dgpt
from dbc.vocab.dgpt_file import save_dgpt
from pacc.study.drive import CONTROLLERS
from pacc.study.loop import StudyCloud, cloud_irl_tables, run_incremental
from pacc.study.spec import StudySpec
from pacc.study.stats import (
    Paired,
    averages,
    bootstrap_ci,
    cell_means,
    comparisons,
    holm,
    per_driver,
    per_trip,
    reduction_pct,
)
from sim_bus.drivers import DriverParams
from sim_bus.errors import SimError
from sim_bus.metrics import METRIC_FIELDS

#: averages of the paper's Table I (PoI %, NIM /min), for comparison
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
#: Table I's drives.csv
FIELDS = (
    *("driver", "scenario", "controller", "trial", "seed"),
    *METRIC_FIELDS,
    *("takeovers", "adaptations", "collision", "sim_s", "wall_s"),
)
#: a study file's drives.csv
SUMMARY_FIELDS = (
    *("driver", "scenario", "method", "table", "adaptation", "controller", "trial", "seed"),
    *(f for f in METRIC_FIELDS if f != "acc_on_s"),
    *("takeovers", "adaptations", "collision", "plugin_faults"),
)
INCREMENTAL_FIELDS = (
    "driver",
    "trip",
    "dgpt_version",
    "poi_pct",
    "nim_per_min",
    "takeovers",
    "uploaded",
    "min_ttc_s",
    "collision",
)
#: a drive whose minimum time-to-collision is below this is reported by name, s
TTC_FLOOR_S = 2.0
METRICS = (("poi_pct", "PoI %"), ("nim_per_min", "NIM /min"))


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
        (out / "table1.md").write_text(format_table(spec, rows), encoding="utf-8")
        plot(out / "study.png", rows)
    elif spec.report == "population":
        (out / "population.md").write_text(format_population(spec, rows), encoding="utf-8")
    else:
        write_timings(out / "timings.csv", tables, rows)
        names = [m.name for m in spec.methods]
        (out / "summary.md").write_text(summary_table(rows, names), encoding="utf-8")


def write_csv(
    path: Path, rows: Sequence[Mapping[str, Any]], fields: Sequence[str] = FIELDS
) -> None:
    """One row per line, columns ``fields`` (other keys left out): every study CSV."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def read_drives(path: Path) -> list[dict[str, Any]]:
    """The rows of a study's ``drives.csv``; SimError naming the file if it has none."""
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            rows = [dict(r) for r in csv.DictReader(fh)]
    except (OSError, UnicodeError, csv.Error) as exc:
        raise SimError(f"{path}: cannot read a study's drives.csv ({exc})") from exc
    if not rows or not {"driver", "controller", "poi_pct", "nim_per_min"} <= set(rows[0]):
        raise SimError(f"{path}: not a study's drives.csv (no driver/controller/PoI/NIM rows)")
    return rows


def write_rows(path: Path, rows: Sequence[Mapping[str, Any]], kind: str) -> None:
    """``drives.csv`` of a report ``kind``: Table I's columns, or a study file's."""
    if kind == "summary":  # a study file's "controller" is the gap controller
        rows = [{**r, "controller": r["gap_controller"]} for r in rows]
    write_csv(path, rows, SUMMARY_FIELDS if kind == "summary" else FIELDS)


def incremental(
    spec: StudySpec, drivers: Mapping[str, DriverParams], out: Path, cloud: StudyCloud
) -> list[dict[str, Any]]:
    """Run the incremental-learning experiment (:func:`pacc.study.loop.run_incremental`) and
    write its report; the rows."""
    rows = run_incremental(spec, drivers, cloud, cloud_irl_tables(cloud, drivers, spec.seed))
    write_csv(out / "incremental.csv", rows, INCREMENTAL_FIELDS)
    (out / "incremental.md").write_text(format_incremental(rows), encoding="utf-8")
    plot_incremental(out / "incremental.png", rows)
    return rows


def pct(value: float) -> str:
    """``value`` as ``12.3 %``, or ``n/a`` when it is not a number (a reduction against 0)."""
    return f"{value:.1f} %" if math.isfinite(value) else "n/a"


def md_table(head: str, rows: Iterable[str], right: int = 0) -> list[str]:
    """A Markdown table's lines: ``head`` and ``rows`` (cells joined by `` | ``) around the rule
    (the last ``right`` columns right-aligned)."""
    rule = "|" + "---|" * (head.count(" | ") + 1 - right) + "---:|" * right
    return [f"| {head} |", rule, *(f"| {row} |" for row in rows)]


def poi_nim(pairs: Iterable[tuple[float, float]], bold: str = "") -> str:
    """The PoI and NIM cells of each (PoI %, NIM /min) pair."""
    return " | ".join(f"{bold}{p:.1f} %{bold} | {bold}{n:.1f}{bold}" for p, n in pairs)


def format_table(cfg: StudySpec, rows: Sequence[dict[str, Any]]) -> str:
    """Table I in Markdown: driver × scenario rows (row order), PoI / NIM per controller, the
    average, the reductions against Predefined and the paper's averages beside ours."""
    means = cell_means(rows)
    avg = averages(means)
    drivers = list(dict.fromkeys(str(r["driver"]) for r in rows))
    controllers = [c for c in CONTROLLERS if c in cfg.controllers]
    body = [
        f"{d} | {SCENARIO_TITLES.get(s, s)} | " + poi_nim(means[(d, s, c)] for c in controllers)
        for d in drivers
        for s in cfg.scenarios
    ]
    body.append("**average** | | " + poi_nim((avg[c] for c in controllers), "**"))
    body.append("paper (average) | | " + poi_nim(PAPER_AVERAGES[c] for c in controllers))
    titles = (f"{CONTROLLER_TITLES[c]} PoI | NIM" for c in controllers)
    head = " | ".join(["driver | scenario", *titles])
    out = [
        "# Table I — interventions per controller (synthetic drivers, CAN bus)",
        "",
        f"{len(drivers)} drivers × {len(cfg.scenarios)} scenarios × "
        f"{len(controllers)} controllers × {cfg.trials} trials = {len(rows)} drives, "
        f"study seed {cfg.seed}"
        + ("" if cfg.duration_s is None else f", {cfg.duration_s:g} s each")
        + ("" if cfg.adaptation is None else f", {cfg.adaptation.mode} adaptation")
        + ".",
        "PoI: % of ACC-ON time with a pedal pressed; NIM: pedal presses per minute.",
        "",
        *md_table(head, body),
        "",
    ]
    if "predefined" in avg:
        base, p = avg["predefined"], PAPER_AVERAGES
        out += ["Reduction against Predefined (ours; paper in brackets):", ""]
        for c in (c for c in controllers if c != "predefined"):
            ours = [pct(reduction_pct(base[k], avg[c][k])) for k in (0, 1)]
            paper = [pct(reduction_pct(p["predefined"][k], p[c][k])) for k in (0, 1)]
            out.append(
                f"- {CONTROLLER_TITLES[c]}: PoI {ours[0]} ({paper[0]}), NIM {ours[1]} ({paper[1]})"
            )
        out.append("")
    out.append(
        f"Safety over all drives: {_collisions(rows)} collisions, min gap "
        f"{_lowest(rows, 'min_gap_m'):.2f} m, min TTC {_lowest(rows, 'min_ttc_s'):.2f} s."
    )
    return "\n".join(out) + "\n"


def _collisions(rows: Iterable[Mapping[str, Any]]) -> int:
    return sum(int(r["collision"]) for r in rows)


def _never_on(rows: Sequence[Mapping[str, Any]]) -> int:
    """Drives without a PoI: the driver never had the ACC on."""
    return sum(not math.isfinite(float(r["poi_pct"])) for r in rows)


def _lowest(rows: Iterable[Mapping[str, Any]], key: str) -> float:
    return min(float(r[key]) for r in rows)


@contextmanager
def two_plots(path: Path, title: str) -> Iterator[Any]:
    """Two axes side by side, PoI (%) and NIM (/min), saved to ``path`` under ``title``."""
    import matplotlib  # noqa: PLC0415 - a second of start-up; only the plots need it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, label in zip(axes, ("PoI (%)", "NIM (presses / min)"), strict=True):
        ax.set_ylabel(label)
    yield axes
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def bars(
    path: Path, title: str, labels: Sequence[str], bars: Sequence[tuple[str, np.ndarray, Any]]
) -> None:
    """Two bar charts (PoI, NIM) side by side; ``bars``: (legend, values shape (2, n), yerr)."""
    x = np.arange(len(labels))
    width = 0.8 / len(bars)
    with two_plots(path, title) as axes:
        for k, ax in enumerate(axes):
            for i, (legend, values, err) in enumerate(bars):
                offset = (i - (len(bars) - 1) / 2) * width if len(bars) > 1 else 0.0
                yerr = None if err is None else err[k]
                ax.bar(x + offset, values[k], width, yerr=yerr, capsize=4, label=legend)
            ax.set_xticks(x, labels, rotation=15 if len(bars) > 1 else 30, fontsize=8)
            ax.grid(axis="y", alpha=0.3)
        if len(bars) > 1:
            axes[0].legend()


def plot(path: Path, rows: Sequence[dict[str, Any]], who: str = "synthetic drivers") -> None:
    """Bar charts of the average PoI and NIM per controller, ours beside the paper's."""
    avg = averages(cell_means(rows))
    controllers = [c for c in CONTROLLERS if c in avg]
    ours = np.array([[avg[c][k] for c in controllers] for k in (0, 1)])
    paper = np.array([[PAPER_AVERAGES[c][k] for c in controllers] for k in (0, 1)])
    bars(
        path,
        "Interventions per controller (Table I averages)",
        [CONTROLLER_TITLES[c] for c in controllers],
        [(f"pacc ({who})", ours, None), ("paper (human drivers)", paper, None)],
    )


def _fmt_ci(mean: float, ci: tuple[float, float]) -> str:
    return f"{mean:.2f} [{ci[0]:.2f}, {ci[1]:.2f}]"


def _population_tests(
    rows: Sequence[dict[str, Any]], rng: np.random.Generator
) -> list[tuple[str, tuple[str, str], Paired, float]]:
    """(metric, (a, b), b against a, Holm p) for every pair of controllers, PoI then NIM."""
    tests: list[tuple[str, tuple[str, str], Paired]] = []
    for metric, _ in METRICS:
        _, values = per_driver(rows, metric)
        tests += [(metric, pair, res) for pair, res in comparisons(values, rng).items()]
    adjusted = holm([t[2].p_value for t in tests])
    return [(*t, p) for t, p in zip(tests, adjusted, strict=True)]


def acceptance(rows: Sequence[dict[str, Any]], *, alpha: float = 0.05) -> list[str]:
    """The population study's goals, each ``met`` or ``NOT met`` with its figures."""
    tests = {
        (m, pair): (res, p) for m, pair, res, p in _population_tests(rows, np.random.default_rng(0))
    }
    out = []
    if all(c in {p for _, pair in tests for p in pair} for c in CONTROLLERS):
        for metric, name in METRICS:
            worse = []
            for other in CONTROLLERS[:-1]:
                res, p = tests[(metric, (other, "irl+oa"))]
                if not (res.mean_diff < 0 and p < alpha):
                    worse.append(f"{CONTROLLER_TITLES[other]} ({res.mean_diff:+.2f}, p {p:.2g})")
            verdict = "met" if not worse else "NOT met against " + ", ".join(worse)
            out.append(f"- IRL + OA lowest mean {name}, Holm p < {alpha:g}: {verdict}")
        for base in ("predefined", "irl"):
            res, p = tests[("poi_pct", (base, f"{base}+oa"))]
            verdict = "met" if res.mean_diff < 0 and p < alpha else "NOT met"
            out.append(
                f"- {CONTROLLER_TITLES[base + '+oa']} lowers PoI against "
                f"{CONTROLLER_TITLES[base]}: {verdict} ({res.mean_diff:+.2f} points, "
                f"Holm p {p:.2g})"
            )
    collisions = _collisions(rows)
    out.append(f"- no collision: {'met' if collisions == 0 else 'NOT met'} ({collisions})")
    return out


def format_population(cfg: StudySpec, rows: Sequence[dict[str, Any]]) -> str:
    """The population report in Markdown: means with bootstrap intervals over drivers, paired
    tests, goals, the drives below :data:`TTC_FLOOR_S` (a fixed generator: same rows, same text)."""
    rng = np.random.default_rng(0)
    drivers, poi = per_driver(rows, "poi_pct")
    _, nim = per_driver(rows, "nim_per_min")
    summary = []
    for c in poi:
        mine = [r for r in rows if r["controller"] == c]
        summary.append(
            f"{CONTROLLER_TITLES[c]} | {_fmt_ci(float(poi[c].mean()), bootstrap_ci(poi[c], rng))} "
            f"| {_fmt_ci(float(nim[c].mean()), bootstrap_ci(nim[c], rng))} "
            f"| {_lowest(mine, 'min_ttc_s'):.2f} "
            f"| {sum(float(r['min_ttc_s']) < TTC_FLOOR_S for r in mine)} "
            f"| {_lowest(mine, 'min_gap_m'):.2f} | {_collisions(mine)}"
        )
    paired = [
        f"{dict(METRICS)[metric]} | {CONTROLLER_TITLES[b]} vs {CONTROLLER_TITLES[a]} "
        f"| {_fmt_ci(res.mean_diff, res.ci)} | {res.better} / {res.worse} / {res.ties} "
        f"| {res.p_value:.2g} | {p_adj:.2g}"
        for metric, (a, b), res, p_adj in _population_tests(rows, rng)
    ]
    low = sorted(
        (r for r in rows if float(r["min_ttc_s"]) < TTC_FLOOR_S),
        key=lambda r: float(r["min_ttc_s"]),
    )
    out = [
        f"# Population study — {len(drivers)} drawn drivers, population seed {cfg.seed}",
        "",
        f"Scenarios {', '.join(cfg.scenarios)}; {cfg.trials} trial(s) per cell; "
        + ("full-length drives" if cfg.duration_s is None else f"{cfg.duration_s:g}-s drives")
        + ("" if cfg.adaptation is None else f"; {cfg.adaptation.mode} adaptation")
        + f"; {len(rows)} drives"
        + (f" ({idle} never had the ACC on: left out)" if (idle := _never_on(rows)) else "")
        + ". A driver's value is its mean over scenarios and trials;",
        "intervals: percentile bootstrap over drivers (2000 resamples); tests: paired "
        "Wilcoxon signed-rank over drivers, Holm-adjusted over the 12 comparisons.",
        "",
        *md_table(
            "controller | PoI % (mean, 95 % CI) | NIM /min (mean, 95 % CI) | min TTC s | "
            f"drives < {TTC_FLOOR_S:g} s TTC | min gap m | collisions",
            summary,
        ),
        "",
        "Paired comparisons (lower is better; B better = lower for B):",
        "",
        *md_table(
            "metric | B vs A | mean B − A (95 % CI) | B better / worse / same | Wilcoxon p "
            "| Holm p",
            paired,
        ),
        "",
        "Goals:",
        "",
        *acceptance(rows),
        "",
    ]
    if low:
        out += [f"Drives below {TTC_FLOOR_S:g} s TTC:", ""]
        out += [
            f"- {r['driver']} {r['scenario']} {r['controller']} t{r['trial']}: "
            f"min TTC {float(r['min_ttc_s']):.2f} s, min gap {float(r['min_gap_m']):.2f} m"
            for r in low[:20]
        ]
        out.append("")
    return "\n".join(out)


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
    body = []
    for name in methods:
        mine = [r for r in rows if r["method"] == name]
        body.append(
            f"{name} | 0 | – | – | – | – | –"
            if not mine
            else f"{name} | {len(mine)} | {np.mean([r['poi_pct'] for r in mine]):.2f} | "
            f"{np.mean([r['nim_per_min'] for r in mine]):.2f} | "
            f"{_lowest(mine, 'min_ttc_s'):.2f} | {_collisions(mine)} | "
            f"{sum(1 for r in mine if r['plugin_faults'])}"
        )
    head = "method | drives | PoI % | NIM /min | min TTC s | collisions | plug-in faults"
    return "\n".join(md_table(head, body)) + "\n"


def format_incremental(rows: Sequence[dict[str, Any]]) -> str:
    """Markdown: the mean over drivers per trip, then every driver's trips."""
    trips = [f"{k} | {poi:.1f} | {nim:.2f} | {n}" for k, poi, nim, n in per_trip(rows)]
    drives = [
        f"{r['driver']} | {r['trip']} | {r['dgpt_version']} | {float(r['poi_pct']):.1f} "
        f"| {float(r['nim_per_min']):.2f} | {r['takeovers']} | {float(r['min_ttc_s']):.1f}"
        for r in rows
    ]
    lines = [
        "# Incremental learning (IRL + OA, scenario B): takeovers -> cloud fine-tune -> next trip",
        "",
        *md_table("trip | PoI (%) | NIM (/min) | drivers", trips, right=4),
        "",
        *md_table(
            "driver | trip | DGPT version | PoI (%) | NIM (/min) | takeovers | min TTC (s)",
            drives,
            right=6,
        ),
    ]
    return "\n".join(lines) + "\n"


def plot_incremental(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """The learning curve: PoI and NIM per trip, each driver thin, the mean thick."""
    curve = per_trip(rows)
    with two_plots(path, "Incremental learning through the cloud (IRL + OA)") as axes:
        for ax, key, k in ((axes[0], "poi_pct", 1), (axes[1], "nim_per_min", 2)):
            for driver in sorted({str(r["driver"]) for r in rows}):
                sel = [r for r in rows if r["driver"] == driver]
                trips, values = [int(r["trip"]) for r in sel], [float(r[key]) for r in sel]
                ax.plot(trips, values, alpha=0.5, lw=1, label=driver)
            ax.plot([c[0] for c in curve], [c[k] for c in curve], "k-o", lw=2.5, label="mean")
            ax.set_xticks([c[0] for c in curve])
            ax.set_xlabel("trip (each after the cloud fine-tuned on the previous takeovers)")
            ax.grid(alpha=0.3)
        axes[0].legend(fontsize=8)
