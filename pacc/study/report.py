"""The study's outputs: Table I in Markdown, ``drives.csv`` and the plot of the averages.

Pure functions of the per-drive rows (dicts with the columns :data:`FIELDS`); nothing here
runs a drive.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pacc.study.drive import CONTROLLERS
from pacc.study.spec import StudySpec

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
#: a drive's metrics, in the columns of drives.csv (also a hil session's records)
METRIC_FIELDS = (
    "poi_pct",
    "nim_per_min",
    "press_onsets",
    "acc_on_s",
    "min_gap_m",
    "min_ttc_s",
    "rms_jerk_mps3",
    "gap_error_rms_m",
)
FIELDS = (
    "driver",
    "scenario",
    "controller",
    "trial",
    "seed",
    *METRIC_FIELDS,
    "takeovers",
    "adaptations",
    "collision",
    "sim_s",
    "wall_s",
)


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


def pct(value: float) -> str:
    """``value`` as ``12.3 %``, or ``n/a`` when it is not a number (a reduction against 0)."""
    return f"{value:.1f} %" if math.isfinite(value) else "n/a"


def reduction_pct(base: float, value: float) -> float:
    """Relative reduction of ``value`` against ``base`` in percent (nan if base is 0)."""
    return (base - value) / base * 100.0 if base > 0 else math.nan


def format_table(cfg: StudySpec, rows: Sequence[dict[str, Any]]) -> str:
    """Table I in Markdown: driver × scenario rows (drivers by id, in the order of ``rows``),
    PoI / NIM per controller, the average, the reductions against Predefined and the paper's
    averages beside ours."""
    means = cell_means(rows)
    drivers = list(dict.fromkeys(str(r["driver"]) for r in rows))  # driver ids, plan order
    controllers = [c for c in CONTROLLERS if c in cfg.controllers]
    head = (
        "| driver | scenario | "
        + " | ".join(f"{CONTROLLER_TITLES[c]} PoI | NIM" for c in controllers)
        + " |"
    )
    lines = [head, "|" + "---|" * (2 + 2 * len(controllers))]
    for name in drivers:
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
        f"{len(drivers)} drivers × {len(cfg.scenarios)} scenarios × "
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
                f"- {CONTROLLER_TITLES[c]}: PoI {pct(ours[0])} ({pct(paper[0])}), "
                f"NIM {pct(ours[1])} ({pct(paper[1])})"
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


def write_csv(
    path: Path, rows: Sequence[Mapping[str, Any]], fields: Sequence[str] = FIELDS
) -> None:
    """One row per line, columns ``fields`` (other keys left out): every study CSV."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)


def plot(path: Path, rows: Sequence[dict[str, Any]], who: str = "synthetic drivers") -> None:
    """Bar charts of the average PoI and NIM per controller, ours beside the paper's."""
    # matplotlib costs about a second of start-up and only the plot needs it (not the
    # drives' worker processes, not a refused command line)
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    avg = averages(cell_means(rows))
    controllers = [c for c in CONTROLLERS if c in avg]
    x = np.arange(len(controllers))
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, k, label in ((axes[0], 0, "PoI (%)"), (axes[1], 1, "NIM (presses / min)")):
        ax.bar(x - 0.2, [avg[c][k] for c in controllers], 0.4, label=f"pacc ({who})")
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
