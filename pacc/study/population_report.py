"""The report of a population study: means with bootstrap intervals, paired tests, safety.

Pure functions of the per-drive rows (the columns of ``drives.csv``). A driver's value per
controller is the mean over its scenarios and trials; intervals and tests are over drivers
(:mod:`pacc.study.stats`). The bootstrap uses a fixed generator (seed 0), so a report is
a function of the rows.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from pacc.study.drive import CONTROLLERS
from pacc.study.report import CONTROLLER_TITLES
from pacc.study.spec import StudySpec
from pacc.study.stats import Paired, bootstrap_ci, holm, paired_comparison

#: a drive whose minimum time-to-collision is below this is reported by name, s
TTC_FLOOR_S = 2.0
METRICS = (("poi_pct", "PoI %"), ("nim_per_min", "NIM /min"))


def per_driver(
    rows: Sequence[dict[str, Any]], metric: str
) -> tuple[list[str], dict[str, np.ndarray]]:
    """(driver ids in row order, controller -> per-driver mean of ``metric``, shape (n,)).

    Only drivers with rows for every controller present are kept (paired data)."""
    controllers = [c for c in CONTROLLERS if any(r["controller"] == c for r in rows)]
    acc: dict[tuple[str, str], list[float]] = {}
    for r in rows:
        acc.setdefault((str(r["driver"]), str(r["controller"])), []).append(float(r[metric]))
    drivers = [
        d
        for d in dict.fromkeys(str(r["driver"]) for r in rows)
        if all((d, c) in acc for c in controllers)
    ]
    return drivers, {
        c: np.array([float(np.mean(acc[(d, c)])) for d in drivers]) for c in controllers
    }


def comparisons(
    values: dict[str, np.ndarray], rng: np.random.Generator
) -> dict[tuple[str, str], Paired]:
    """Every pair (a, b) of controllers in CONTROLLERS order: b against a."""
    return {
        (a, b): paired_comparison(values[a], values[b], rng)
        for a, b in itertools.combinations(list(values), 2)
    }


def _fmt_ci(mean: float, ci: tuple[float, float]) -> str:
    return f"{mean:.2f} [{ci[0]:.2f}, {ci[1]:.2f}]"


def _summary_table(rows: Sequence[dict[str, Any]], rng: np.random.Generator) -> list[str]:
    _, poi = per_driver(rows, "poi_pct")
    _, nim = per_driver(rows, "nim_per_min")
    lines = [
        "| controller | PoI % (mean, 95 % CI) | NIM /min (mean, 95 % CI) | min TTC s | "
        f"drives < {TTC_FLOOR_S:g} s TTC | min gap m | collisions |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in poi:
        mine = [r for r in rows if r["controller"] == c]
        poi_ci = _fmt_ci(float(poi[c].mean()), bootstrap_ci(poi[c], rng))
        nim_ci = _fmt_ci(float(nim[c].mean()), bootstrap_ci(nim[c], rng))
        lines.append(
            f"| {CONTROLLER_TITLES[c]} | {poi_ci} | {nim_ci} "
            f"| {min(float(r['min_ttc_s']) for r in mine):.2f} "
            f"| {sum(float(r['min_ttc_s']) < TTC_FLOOR_S for r in mine)} "
            f"| {min(float(r['min_gap_m']) for r in mine):.2f} "
            f"| {sum(int(r['collision']) for r in mine)} |"
        )
    return lines


def _paired_table(rows: Sequence[dict[str, Any]], rng: np.random.Generator) -> list[str]:
    tests: list[tuple[str, tuple[str, str], Paired]] = []
    for metric, _ in METRICS:
        _, values = per_driver(rows, metric)
        tests += [(metric, pair, res) for pair, res in comparisons(values, rng).items()]
    adjusted = holm([t[2].p_value for t in tests])
    lines = [
        "| metric | B vs A | mean B − A (95 % CI) | B better / worse / same | Wilcoxon p "
        "| Holm p |",
        "|---|---|---|---|---|---|",
    ]
    for (metric, (a, b), res), p_adj in zip(tests, adjusted, strict=True):
        name = dict(METRICS)[metric]
        lines.append(
            f"| {name} | {CONTROLLER_TITLES[b]} vs {CONTROLLER_TITLES[a]} "
            f"| {_fmt_ci(res.mean_diff, res.ci)} | {res.better} / {res.worse} / {res.ties} "
            f"| {res.p_value:.2g} | {p_adj:.2g} |"
        )
    return lines


def acceptance(rows: Sequence[dict[str, Any]], *, alpha: float = 0.05) -> list[str]:
    """The issue's goals, each ``met`` or ``NOT met`` with its figures."""
    rng = np.random.default_rng(0)
    out = []
    tests: dict[tuple[str, tuple[str, str]], Paired] = {}
    for metric, _ in METRICS:
        _, values = per_driver(rows, metric)
        for pair, res in comparisons(values, rng).items():
            tests[(metric, pair)] = res
    keys = list(tests)
    adjusted = dict(zip(keys, holm([tests[k].p_value for k in keys]), strict=True))
    if all(c in {p for _, pair in keys for p in pair} for c in CONTROLLERS):
        for metric, name in METRICS:
            worse = []
            for other in CONTROLLERS[:-1]:
                key = (metric, (other, "irl+oa"))
                res = tests[key]
                if not (res.mean_diff < 0 and adjusted[key] < alpha):
                    worse.append(
                        f"{CONTROLLER_TITLES[other]} ({res.mean_diff:+.2f}, p {adjusted[key]:.2g})"
                    )
            verdict = "met" if not worse else "NOT met against " + ", ".join(worse)
            out.append(f"- IRL + OA lowest mean {name}, Holm p < {alpha:g}: {verdict}")
        for base in ("predefined", "irl"):
            key = ("poi_pct", (base, f"{base}+oa"))
            res = tests[key]
            ok = res.mean_diff < 0 and adjusted[key] < alpha
            verdict = "met" if ok else "NOT met"
            out.append(
                f"- {CONTROLLER_TITLES[base + '+oa']} lowers PoI against "
                f"{CONTROLLER_TITLES[base]}: {verdict} ({res.mean_diff:+.2f} points, "
                f"Holm p {adjusted[key]:.2g})"
            )
    collisions = sum(int(r["collision"]) for r in rows)
    out.append(f"- no collision: {'met' if collisions == 0 else 'NOT met'} ({collisions})")
    return out


def format_population(cfg: StudySpec, rows: Sequence[dict[str, Any]]) -> str:
    """The population report in Markdown."""
    rng = np.random.default_rng(0)
    drivers, _ = per_driver(rows, "poi_pct")
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
        + f"; {len(rows)} drives. A driver's value is its mean over scenarios and trials;",
        "intervals: percentile bootstrap over drivers (2000 resamples); tests: paired "
        "Wilcoxon signed-rank over drivers, Holm-adjusted over the 12 comparisons.",
        "",
        *_summary_table(rows, rng),
        "",
        "Paired comparisons (lower is better; B better = lower for B):",
        "",
        *_paired_table(rows, rng),
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


__all__ = ["TTC_FLOOR_S", "acceptance", "comparisons", "format_population", "per_driver"]
