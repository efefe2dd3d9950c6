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
from cloud_sync.irl.demos import Samples
from cloud_sync.irl.extract import gap_support
from dbc.vocab.dgpt import SafetyBounds, clamp_to_bounds

__all__ = ["Evidence", "coverage_s", "evidence", "blend", "covered_ranges"]


@dataclass(frozen=True)
class Evidence:
    """The demonstrations seen from the DGPT axis; arrays of shape (n,).

    Attributes:
        coverage_s: seconds of demonstration within ±0.5 m/s of each bin.
        covered: bins whose learned gaps are kept. support: (lo, hi) gap range of the argmax,
            m (NaN: no sample nearby). previous_m: the earlier table's gaps on the axis, None
            when not continuing. window_s: seconds within ±window of each bin (continuing).
    """

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
    *,
    min_coverage_s: float,
    previous_m: np.ndarray | None,
    window_mps: float,
    support_ratio: float,
) -> Evidence:
    """Coverage, covered bins and argmax range of ``samples`` (see the module docstring).

    A bin is covered with ``min_coverage_s`` seconds within ±0.5 m/s, or, continuing from
    ``previous_m`` (n,), within ±``window_mps``. Raises :class:`DemoError` when no bin above
    standstill is covered: there is nothing to build a table from.
    """
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
    """The table's gaps (n,) and the bins the new evidence touched (n,) bool.

    Not continuing: ``gap_m`` and ``ev.covered`` unchanged. Continuing: weight
    ``w = c/(c + half_s)`` for the ``c`` seconds within the window, ``w·gap + (1 − w)·previous``
    clamped to ``bounds`` where ``c > 0``, the earlier gaps exactly elsewhere.
    """
    if ev.previous_m is None or ev.window_s is None:
        return gap_m, ev.covered
    weight = ev.window_s / (ev.window_s + half_s)
    mixed = np.where(weight > 0.0, weight * gap_m + (1.0 - weight) * ev.previous_m, ev.previous_m)
    return clamp_to_bounds(axis_mps, mixed, bounds), weight > 0.0


def covered_ranges(axis_mps: np.ndarray, mask: np.ndarray) -> list[list[float]]:
    """Contiguous True ranges of ``mask`` (n,) as ``[[v_from, v_to], ...]`` (m/s)."""
    out: list[list[float]] = []
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        out.append([float(axis_mps[a]), float(axis_mps[b - 1])])
    return out
