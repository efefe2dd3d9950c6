"""Statistics of a study's rows, the one module every report uses (pure functions).

Drivers are the unit of replication: a driver's value per controller or method is the mean of
its drives; intervals resample drivers (:func:`bootstrap_ci`), two controllers are compared on
the same drivers (:func:`paired_comparison`: the paired bootstrap and ``scipy.stats.wilcoxon``,
zero differences dropped) and a family of p-values is Holm-adjusted (:func:`holm`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from pacc.study.drive import CONTROLLERS
from sim_bus.errors import SimError

#: resamples of every bootstrap (2000: the interval's ends move < 0.1 % of the seeds' spread)
N_BOOT = 2000


def bootstrap_ci(
    values: np.ndarray, rng: np.random.Generator, *, level: float = 0.95, n_boot: int = N_BOOT
) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``values`` (shape ``(n,)``); NaNs if n < 2."""
    x = np.asarray(values, dtype=np.float64)
    if x.size < 2:
        return math.nan, math.nan
    idx = rng.integers(0, x.size, size=(n_boot, x.size))
    means = x[idx].mean(axis=1)
    tail = (1.0 - level) / 2.0 * 100.0
    lo, hi = np.percentile(means, [tail, 100.0 - tail])
    return float(lo), float(hi)


@dataclass(frozen=True)
class Paired:
    """``b`` against ``a`` on the same drivers (differences ``b - a``, lower is better):
    mean difference, its paired bootstrap 95 % interval, the two-sided Wilcoxon p (1.0 if
    every difference is 0), and the drivers with ``b < a``, ``b > a``, ``b == a``."""

    mean_diff: float
    ci: tuple[float, float]
    p_value: float
    better: int
    worse: int
    ties: int


def paired_comparison(a: np.ndarray, b: np.ndarray, rng: np.random.Generator) -> Paired:
    """Compare per-driver values ``b`` against ``a`` (shape ``(n,)`` each, same drivers)."""
    x, y = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1:
        raise SimError(f"paired values need one shape (n,), got {x.shape} and {y.shape}")
    d = y - x
    nonzero = d[np.abs(d) > 1e-12]
    from scipy import stats  # noqa: PLC0415 - ~0.5 s of start-up, only for this test

    p = float(stats.wilcoxon(nonzero).pvalue) if nonzero.size >= 1 else 1.0
    return Paired(
        mean_diff=float(d.mean()) if d.size else math.nan,
        ci=bootstrap_ci(d, rng),
        p_value=p,
        better=int(np.sum(d < -1e-12)),
        worse=int(np.sum(d > 1e-12)),
        ties=int(np.sum(np.abs(d) <= 1e-12)),
    )


def holm(p_values: list[float]) -> list[float]:
    """Holm-adjusted p-values of a family (same order as given; each at most 1)."""
    m = len(p_values)
    adjusted = [0.0] * m
    running = 0.0
    for rank, i in enumerate(sorted(range(m), key=lambda i: p_values[i])):
        running = max(running, min(1.0, (m - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted


def driver_means(
    rows: Iterable[Mapping[str, Any]], metric: str, by: str = "controller"
) -> dict[str, dict[str, float]]:
    """Group (a row's ``by``) -> driver -> mean ``metric`` of its drives (first-seen order);
    a drive without the figure (NaN: the ACC was never on) is left out, and so is a driver
    with none."""
    acc: dict[str, dict[str, list[float]]] = {}
    for r in rows:
        if math.isfinite(value := float(r[metric])):
            acc.setdefault(str(r[by]), {}).setdefault(str(r["driver"]), []).append(value)
    return {g: {d: float(np.mean(v)) for d, v in ds.items()} for g, ds in acc.items()}


def per_driver(
    rows: Sequence[Mapping[str, Any]], metric: str
) -> tuple[list[str], dict[str, np.ndarray]]:
    """(drivers in row order, controller -> their mean ``metric``, shape (n,)): only drivers
    with drives of every controller present (paired data), controllers in Table I order."""
    means = driver_means(rows, metric)
    controllers = [c for c in CONTROLLERS if c in means]
    drivers = [
        d
        for d in dict.fromkeys(str(r["driver"]) for r in rows)
        if all(d in means[c] for c in controllers)
    ]
    return drivers, {c: np.array([means[c][d] for d in drivers]) for c in controllers}


def comparisons(
    values: dict[str, np.ndarray], rng: np.random.Generator
) -> dict[tuple[str, str], Paired]:
    """Every pair (a, b) of the controllers in ``values``' order: b against a."""
    return {
        (a, b): paired_comparison(values[a], values[b], rng)
        for a, b in itertools.combinations(list(values), 2)
    }


def cell_means(
    rows: Iterable[Mapping[str, Any]],
) -> dict[tuple[str, str, str], tuple[float, float]]:
    """(driver, scenario, controller) -> (mean PoI %, mean NIM /min) over the trials whose ACC
    was on (a cell with none is left out)."""
    acc: dict[tuple[str, str, str], list[tuple[float, float]]] = {}
    for r in rows:
        if not math.isfinite(float(r["poi_pct"])):
            continue
        acc.setdefault((r["driver"], r["scenario"], r["controller"]), []).append(
            (float(r["poi_pct"]), float(r["nim_per_min"]))
        )
    return {k: _mean_pair(v) for k, v in acc.items()}


def _mean_pair(pairs: Sequence[tuple[float, float]]) -> tuple[float, float]:
    return sum(p for p, _ in pairs) / len(pairs), sum(n for _, n in pairs) / len(pairs)


def averages(
    means: dict[tuple[str, str, str], tuple[float, float]],
) -> dict[str, tuple[float, float]]:
    """Controller -> (PoI %, NIM /min) averaged over every driver and scenario cell."""
    cells = {c: [v for (_, _, k), v in means.items() if k == c] for c in CONTROLLERS}
    return {c: _mean_pair(v) for c, v in cells.items() if v}


def reduction_pct(base: float, value: float) -> float:
    """Relative reduction of ``value`` against ``base``, % (nan if base is 0)."""
    return (base - value) / base * 100.0 if base > 0 else math.nan


def per_trip(rows: Sequence[Mapping[str, Any]]) -> list[tuple[int, float, float, int]]:
    """(trip, mean PoI %, mean NIM /min, drives) over the drivers, by trip number."""
    out = []
    for k in sorted({int(r["trip"]) for r in rows}):
        sel = [r for r in rows if int(r["trip"]) == k]
        poi = float(np.mean([float(r["poi_pct"]) for r in sel]))
        nim = float(np.mean([float(r["nim_per_min"]) for r in sel]))
        out.append((k, poi, nim, len(sel)))
    return out
