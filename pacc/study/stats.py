"""Statistics over drivers: bootstrap confidence intervals and paired tests (pure functions).

A population study gives one value per driver and controller (the mean over its drives).
Drivers are the unit of replication: intervals resample drivers, and two controllers are
compared on the same drivers (paired).

- :func:`bootstrap_ci`: percentile bootstrap interval of the mean over drivers.
- :func:`paired_comparison`: mean difference ``b - a`` with its paired bootstrap interval, the
  Wilcoxon signed-rank test (``scipy.stats.wilcoxon``, two-sided, zero differences dropped as
  in Wilcoxon's original method) and how many drivers did better, worse, the same.
- :func:`holm`: Holm's step-down adjustment of a family of p-values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from sim_bus.errors import SimError

#: resamples of every bootstrap (2000: the percentile interval's ends move < 0.1 % of the
#: spread between seeds)
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
    """Controller ``b`` against ``a`` on the same drivers (differences ``b - a``).

    Attributes:
        mean_diff: mean of the per-driver differences.
        ci: paired bootstrap 95 % interval of ``mean_diff``.
        p_value: two-sided Wilcoxon signed-rank p-value (1.0 if every difference is 0).
        better, worse, ties: drivers with ``b < a``, ``b > a``, ``b == a`` (lower is better).
    """

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
    order = sorted(range(m), key=lambda i: p_values[i])
    adjusted = [0.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p_values[i]))
        adjusted[i] = running
    return adjusted


__all__ = ["N_BOOT", "Paired", "bootstrap_ci", "holm", "paired_comparison"]
