"""From per-bin gaps (of the learned policy, or of raw data) to a DGPT: low-pass, continuation,
bounds. Pure functions on the DGPT speed axis (shape (n,)).

:func:`gap_support`/:func:`search_range` (the demonstrated gap range per bin, m),
:func:`lowpass` (zero-phase Butterworth), :func:`continue_time_gap` (uncovered bins at the time
gap of covered ones of at least :data:`CONTINUE_MIN_SPEED_MPS`, else :data:`PRIOR_HEADWAY_S`),
:func:`finish_table` (raw gaps -> table), :func:`steady_state_gaps` and from it
:func:`empirical_baseline` (the comparison table, meta ``method = empirical``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import signal

from cloud_sync.errors import DemoError
from cloud_sync.irl import demos as dm
from cloud_sync.irl.config import IrlConfig
from dbc.vocab.dgpt import Dgpt, SafetyBounds, clamp_to_bounds, speed_axis
from dbc.vocab.triplog import Trip

#: covered bins slower than this do not set the time gap continued to other speeds, m/s:
#: below it the standstill distance dominates the gap and (g − d0)/v is mostly noise (issue
#: 11: a table learned from stop-and-go data below 5 m/s stated gaps at 30 m/s)
CONTINUE_MIN_SPEED_MPS = 8.0
#: the prior time gap of speeds no usable evidence reaches, s (openpilot's "standard"
#: personality is 1.45 s; the real OpenACC followers keep 1.4-3.4 s)
PRIOR_HEADWAY_S = 1.5


def gap_support(
    axis_mps: np.ndarray,
    v_mps: np.ndarray,
    gap_m: np.ndarray,
    *,
    half_window_mps: float = 1.0,
    quantile: float = 0.01,
    margin_m: float = 2.0,
) -> tuple[np.ndarray, np.ndarray]:
    """The demonstrated gap range (lo, hi) per bin, m, (n,) each: the ``quantile`` range of
    gaps within ±``half_window_mps`` widened by ``margin_m``; NaN where no sample."""
    order = np.argsort(v_mps)
    v, g = v_mps[order], gap_m[order]
    lo_i = np.searchsorted(v, axis_mps - half_window_mps, side="left")
    hi_i = np.searchsorted(v, axis_mps + half_window_mps, side="right")
    lo = np.full(axis_mps.size, np.nan)
    hi = np.full(axis_mps.size, np.nan)
    for i, (a, b) in enumerate(zip(lo_i.tolist(), hi_i.tolist(), strict=True)):
        if b > a:
            q = np.quantile(g[a:b], [quantile, 1.0 - quantile])
            lo[i], hi[i] = q[0] - margin_m, q[1] + margin_m
    return lo, hi


def lowpass(gap_m: np.ndarray, cutoff: float = 0.1, order: int = 2) -> np.ndarray:
    """Zero-phase Butterworth low-pass of ``gap_m`` (n,); ``cutoff`` normalised to Nyquist
    (0.1 keeps variations slower than about 20 bins)."""
    b, a = signal.butter(order, cutoff)
    x = np.arange(gap_m.size, dtype=np.float64)
    slope, icpt = np.polyfit(x, gap_m, 1)
    trend = icpt + slope * x  # filtered separately: a straight table passes unchanged
    resid = gap_m - trend
    padlen = min(3 * max(len(a), len(b)) * 4, gap_m.size - 1)
    return np.asarray(trend + signal.filtfilt(b, a, resid, padlen=padlen))


def continue_time_gap(
    axis_mps: np.ndarray,
    gap_m: np.ndarray,
    covered: np.ndarray,
    standstill_m: float,
    fallback_m: np.ndarray | None = None,
) -> np.ndarray:
    """Uncovered bins (n,) get ``d0 + T(v)·v`` (m), ``T`` the time gap (s) of covered bins of
    at least :data:`CONTINUE_MIN_SPEED_MPS` interpolated and held, else :data:`PRIOR_HEADWAY_S`;
    with ``fallback_m`` (n,) they keep the fallback's gaps."""
    out = np.array(gap_m, dtype=np.float64)
    if fallback_m is not None:
        if not covered.any():
            return out
        return np.where(covered, out, fallback_m)
    use = covered & (axis_mps >= CONTINUE_MIN_SPEED_MPS)
    if not use.any():
        return np.where(covered, out, standstill_m + PRIOR_HEADWAY_S * axis_mps)
    headway = (out[use] - standstill_m) / axis_mps[use]
    t_all = np.interp(axis_mps, axis_mps[use], headway)
    return np.where(covered, out, standstill_m + t_all * axis_mps)


def outside_coverage(axis_mps: np.ndarray, covered: np.ndarray) -> str:
    """The rule :func:`continue_time_gap` applied to the uncovered speeds (for a table's meta)."""
    if covered.all():
        return "none: every speed covered"
    if (covered & (axis_mps >= CONTINUE_MIN_SPEED_MPS)).any():
        return (
            f"time gap of the covered speeds >= {CONTINUE_MIN_SPEED_MPS:g} m/s, interpolated "
            "and held constant beyond them"
        )
    return (
        f"prior time gap {PRIOR_HEADWAY_S:g} s (no covered speed >= {CONTINUE_MIN_SPEED_MPS:g} m/s)"
    )


def steady_state_gaps(
    axis_mps: np.ndarray,
    v_mps: np.ndarray,
    gap_m: np.ndarray,
    dv_mps: np.ndarray,
    a_mps2: np.ndarray,
    *,
    max_abs_dv_mps: float = 0.5,
    max_abs_a_mps2: float = 0.3,
    half_window_mps: float = 0.5,
) -> tuple[np.ndarray, np.ndarray]:
    """``(gap_m, count)`` (n,): the median gap (m; NaN where none) and number of the samples
    (k,) with ``|dv| ≤ max_abs_dv`` and ``|a| ≤ max_abs_a`` within ±half_window of each bin."""
    steady = (np.abs(dv_mps) <= max_abs_dv_mps) & (np.abs(a_mps2) <= max_abs_a_mps2)
    v, g = v_mps[steady], gap_m[steady]
    order = np.argsort(v)
    v, g = v[order], g[order]
    lo = np.searchsorted(v, axis_mps - half_window_mps, side="left")
    hi = np.searchsorted(v, axis_mps + half_window_mps, side="right")
    out = np.full(axis_mps.size, np.nan)
    for i, (a, b) in enumerate(zip(lo.tolist(), hi.tolist(), strict=True)):
        if b > a:
            out[i] = float(np.median(g[a:b]))
    return out, (hi - lo).astype(np.int64)


def finish_table(
    axis_mps: np.ndarray,
    raw_gap_m: np.ndarray,
    covered: np.ndarray,
    bounds: SafetyBounds,
    *,
    cutoff: float = 0.1,
    fallback_m: np.ndarray | None = None,
) -> np.ndarray:
    """Raw per-bin gaps → the final table (n,): continuation (so the filter sees no holes),
    low-pass, continuation of the uncovered bins again (or ``fallback_m``), clamp to bounds."""
    raw = np.where(np.isfinite(raw_gap_m), raw_gap_m, 0.0)
    covered = covered & np.isfinite(raw_gap_m)
    filled = continue_time_gap(axis_mps, raw, covered, bounds.standstill_m, fallback_m)
    smooth = lowpass(clamp_to_bounds(axis_mps, filled, bounds), cutoff)
    final = continue_time_gap(axis_mps, smooth, covered, bounds.standstill_m, fallback_m)
    return np.asarray(clamp_to_bounds(axis_mps, final, bounds))


def search_range(
    axis_mps: np.ndarray,
    support: tuple[np.ndarray, np.ndarray],
    bounds: SafetyBounds,
    min_width_m: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The gaps a table may take at each speed: the demonstrated range ``support`` ((lo, hi),
    (n,) each, NaN: unlimited) inside the safety band, at least ``min_width_m`` wide; (n,) each."""
    lo = np.fmax(bounds.lower_m(axis_mps), np.nan_to_num(support[0], nan=-np.inf))
    hi = np.fmin(bounds.upper_m(axis_mps), np.nan_to_num(support[1], nan=np.inf))
    return np.asarray(lo), np.asarray(np.maximum(hi, lo + min_width_m))


def empirical_baseline(
    trips: Sequence[Trip],
    *,
    driver_id: str,
    condition: str = "default",
    config: IrlConfig | None = None,
) -> Dgpt:
    """The empirical steady-state table (same format; meta ``method = empirical``)."""
    cfg = config if config is not None else IrlConfig()
    dm.check_demos(trips, max_gap_m=cfg.max_gap_m, min_total_s=cfg.min_total_demo_s)
    s = dm.pooled_samples(trips, cfg.max_gap_m)
    axis = speed_axis(cfg.dgpt_step_mps)
    raw, count = steady_state_gaps(axis, s.v_mps, s.gap_m, s.dv_mps, s.a_mps2)
    dt = float(np.median(s.dt_s)) if s.dt_s.size else 0.1
    covered = (count * dt >= cfg.min_coverage_s / 4.0) & np.isfinite(raw)
    if not covered.any():
        raise DemoError("no speed bin has enough steady-state following for the baseline")
    gap = finish_table(axis, raw, covered, cfg.bounds, cutoff=cfg.lowpass_cutoff)
    return Dgpt(
        speed_mps=axis,
        gap_m=gap,
        version=0,
        driver_id=driver_id,
        condition=condition,
        source="irl",
        meta={
            "method": "empirical",
            "steady_samples": count.tolist(),
            "covered": covered.tolist(),
            "outside_coverage": outside_coverage(axis, covered),
            "training_digest": dm.digest(trips, [1.0] * len(trips)),
        },
    )


def baseline_if_any(
    trips: Sequence[Trip], driver_id: str, condition: str, cfg: IrlConfig
) -> Dgpt | None:
    """The empirical baseline, or None when the data hold no steady-state following (e.g.
    takeovers alone)."""
    try:
        return empirical_baseline(trips, driver_id=driver_id, condition=condition, config=cfg)
    except DemoError:
        return None
