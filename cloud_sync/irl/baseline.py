"""The empirical baseline: per speed bin the gap of the steady-state samples
(:func:`cloud_sync.irl.extract.steady_state_gaps`), continued and low-passed like a learned
table (meta ``method = empirical``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from cloud_sync.errors import DemoError
from cloud_sync.irl import demos as dm
from cloud_sync.irl.config import IrlConfig
from cloud_sync.irl.extract import finish_table, outside_coverage, steady_state_gaps
from dbc.vocab.dgpt import Dgpt, speed_axis
from dbc.vocab.triplog import Trip

__all__ = ["baseline_if_any", "empirical_baseline"]


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
