"""Outputs of ``pacc study --incremental N``: the per-trip table, CSV and the learning curve.

Pure functions of the rows of :func:`pacc.study.loop.run_incremental` (dicts with the
columns :data:`INCREMENTAL_FIELDS`); nothing here runs a drive.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

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


def per_trip(rows: Sequence[dict[str, Any]]) -> list[tuple[int, float, float, int]]:
    """(trip, mean PoI %, mean NIM /min, drives) over the drivers, by trip number."""
    trips = sorted({int(r["trip"]) for r in rows})
    out = []
    for k in trips:
        sel = [r for r in rows if int(r["trip"]) == k]
        poi = float(np.mean([float(r["poi_pct"]) for r in sel]))
        nim = float(np.mean([float(r["nim_per_min"]) for r in sel]))
        out.append((k, poi, nim, len(sel)))
    return out


def format_incremental(rows: Sequence[dict[str, Any]]) -> str:
    """Markdown: the mean over drivers per trip, then every driver's trips."""
    lines = [
        "# Incremental learning (IRL + OA, scenario B): takeovers -> cloud fine-tune -> next trip",
        "",
        "| trip | PoI (%) | NIM (/min) | drivers |",
        "|---:|---:|---:|---:|",
    ]
    lines += [f"| {k} | {poi:.1f} | {nim:.2f} | {n} |" for k, poi, nim, n in per_trip(rows)]
    lines += [
        "",
        "| driver | trip | DGPT version | PoI (%) | NIM (/min) | takeovers | min TTC (s) |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    lines += [
        f"| {r['driver']} | {r['trip']} | {r['dgpt_version']} | {float(r['poi_pct']):.1f} "
        f"| {float(r['nim_per_min']):.2f} | {r['takeovers']} | {float(r['min_ttc_s']):.1f} |"
        for r in rows
    ]
    return "\n".join(lines) + "\n"


def plot_incremental(path: Path, rows: Sequence[dict[str, Any]]) -> None:
    """The learning curve: PoI and NIM per trip, each driver thin, the mean thick."""
    # matplotlib costs about a second of start-up and only the plot needs it
    import matplotlib  # noqa: PLC0415

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415

    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    curve = per_trip(rows)
    for ax, key, k, label in (
        (axes[0], "poi_pct", 1, "PoI (%)"),
        (axes[1], "nim_per_min", 2, "NIM (presses / min)"),
    ):
        for driver in sorted({str(r["driver"]) for r in rows}):
            sel = [r for r in rows if r["driver"] == driver]
            trips = [int(r["trip"]) for r in sel]
            ax.plot(trips, [float(r[key]) for r in sel], alpha=0.5, lw=1, label=driver)
        ax.plot([c[0] for c in curve], [c[k] for c in curve], "k-o", lw=2.5, label="mean")
        ax.set_xticks([c[0] for c in curve])
        ax.set_xlabel("trip (each after the cloud fine-tuned on the previous takeovers)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle("Incremental learning through the cloud (IRL + OA)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


__all__ = [
    "INCREMENTAL_FIELDS",
    "format_incremental",
    "per_trip",
    "plot_incremental",
]
