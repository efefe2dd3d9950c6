"""Where the demonstrations are, per DGPT speed bin, and how new evidence joins an earlier table.

Pure functions on the DGPT speed axis (shape (n,)): :func:`coverage_s` (s of usable
demonstration near each bin), :func:`evidence` (coverage, covered bins, the gap range the
search may take), :func:`blend` (new gaps mixed into an earlier table with weight
``c/(c + half_s)`` for ``c`` s of new evidence) and :func:`covered_ranges` (for the metadata).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cloud_sync.errors import DemoError
from cloud_sync.irl.demos import Samples, true_runs
from cloud_sync.irl.extract import gap_support
from dbc.vocab.dgpt import SafetyBounds, clamp_to_bounds


@dataclass(frozen=True)
class Evidence:
    """The demonstrations on the DGPT axis, (n,) each: ``coverage_s`` (s within ±0.5 m/s),
    ``covered``, ``support`` (lo, hi) m, ``previous_m`` (None: not continuing), ``window_s``."""

    coverage_s: np.ndarray
    covered: np.ndarray
    support: tuple[np.ndarray, np.ndarray]
    previous_m: np.ndarray | None = None
    window_s: np.ndarray | None = None


def coverage_s(
    axis_mps: np.ndarray, v_mps: np.ndarray, dt_s: np.ndarray, half_window_mps: float = 0.5
) -> np.ndarray:
    """Seconds of data per bin: Σ dt over samples with ``|v − v_i| ≤ half_window``; (n,)."""
    order = np.argsort(v_mps)
    v_sorted = v_mps[order]
    cum = np.concatenate([[0.0], np.cumsum(dt_s[order])])
    lo = np.searchsorted(v_sorted, axis_mps - half_window_mps, side="left")
    hi = np.searchsorted(v_sorted, axis_mps + half_window_mps, side="right")
    return np.asarray(cum[hi] - cum[lo])


def evidence(
    axis_mps: np.ndarray,
    samples: Samples,
    min_coverage_s: float,
    previous_m: np.ndarray | None,
    window_mps: float,
    support_ratio: float,
) -> Evidence:
    """The :class:`Evidence` of ``samples``: a bin is covered with ``min_coverage_s`` s within
    ±0.5 m/s (continuing ``previous_m``: within ±``window_mps``); DemoError if none moving is."""
    cov = coverage_s(axis_mps, samples.v_mps, samples.dt_s)
    support = gap_support(axis_mps, samples.v_mps, samples.gap_m)
    window: np.ndarray | None = None
    if previous_m is None:
        covered = cov >= min_coverage_s
    else:
        window = coverage_s(axis_mps, samples.v_mps, samples.dt_s, window_mps)
        covered = window >= min_coverage_s
        support = (
            np.fmin(support[0], previous_m * (1.0 - support_ratio)),
            np.fmax(support[1], previous_m * (1.0 + support_ratio)),
        )
    if not (covered & (axis_mps > 0.5)).any():
        raise DemoError(
            f"no speed bin above standstill has {min_coverage_s:g} s of demonstration; "
            "cannot build a table"
        )
    return Evidence(cov, covered, support, previous_m, window)


def blend(
    axis_mps: np.ndarray, gap_m: np.ndarray, ev: Evidence, *, half_s: float, bounds: SafetyBounds
) -> tuple[np.ndarray, np.ndarray]:
    """The gaps (n,) and touched bins (n,): continuing, ``w·gap + (1 − w)·previous`` with
    ``w = c/(c + half_s)`` where ``c > 0`` s (clamped), the earlier gaps elsewhere."""
    if ev.previous_m is None or ev.window_s is None:
        return gap_m, ev.covered
    weight = ev.window_s / (ev.window_s + half_s)
    mixed = np.where(weight > 0.0, weight * gap_m + (1.0 - weight) * ev.previous_m, ev.previous_m)
    return clamp_to_bounds(axis_mps, mixed, bounds), weight > 0.0


def covered_ranges(axis_mps: np.ndarray, mask: np.ndarray) -> list[list[float]]:
    """Contiguous True ranges of ``mask`` (n,) as ``[[v_from, v_to], ...]`` (m/s)."""
    return [[float(axis_mps[a]), float(axis_mps[b - 1])] for a, b in true_runs(mask)]
