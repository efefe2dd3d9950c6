"""The IRL trainer: trips in, a driver's DGPT out (a thin composition of the pure phases).

:func:`learn_dgpt` learns from demonstrations (manual drives, plus weighted ACC takeovers);
:func:`fine_tune` continues an earlier IRL table; :func:`empirical_baseline` is the comparison.
Phases: :mod:`~cloud_sync.irl.demos`, :mod:`~cloud_sync.irl.blend`, :mod:`~cloud_sync.irl.model`,
:mod:`~cloud_sync.irl.mce_irl`, :mod:`~cloud_sync.irl.policy_gap`, :mod:`~cloud_sync.irl.extract`.
Every result is a pure function of (configuration, seed, data).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from cloud_sync.errors import DemoError, TrainingError
from cloud_sync.irl import demos as dm
from cloud_sync.irl.blend import Evidence, blend, covered_ranges, evidence
from cloud_sync.irl.config import IrlConfig
from cloud_sync.irl.extract import (
    baseline_if_any,
    empirical_baseline,
    finish_table,
    outside_coverage,
    search_range,
)
from cloud_sync.irl.mce_irl import CompiledMdp, fit_alpha, start_alpha
from cloud_sync.irl.model import METHOD, compile_model, fresh_model, model_of_table
from cloud_sync.irl.policy_gap import steady_drift, steady_gaps
from dbc.vocab.dgpt import Dgpt, speed_axis
from dbc.vocab.triplog import Trip

__all__ = ["IrlConfig", "LearnResult", "learn_dgpt", "fine_tune", "empirical_baseline", "METHOD"]


@dataclass(frozen=True)
class LearnResult:
    """A learned table (its meta: data digest, coverage, model), the empirical baseline (None
    without steady following), ``alpha`` (K,), the compiled MDP, ``covered`` (n,) bool bins
    set by the data, and the optimiser's outcome (``train_s`` in s)."""

    table: Dgpt
    baseline: Dgpt | None
    alpha: np.ndarray
    mdp: CompiledMdp
    covered: np.ndarray
    n_iter: int
    converged: bool
    message: str
    train_s: float

    def reward_vg(self, v_mps: np.ndarray, gap_m: np.ndarray) -> np.ndarray:
        """The recovered (v, g) reward on the outer product of (n,) and (m,): (n, m)."""
        return self.mdp.features.reward_vg(self.alpha, v_mps, gap_m)


def learn_dgpt(
    trips: list[Trip],
    *,
    driver_id: str,
    condition: str = "default",
    init: Dgpt | None = None,
    seed: int = 0,
    progress: bool = False,
    config: IrlConfig | None = None,
    weights: Sequence[float] | None = None,
) -> LearnResult:
    """Learn a driver's DGPT by MCE IRL from ``trips`` (manual weight 1, ACC takeovers
    ``config.takeover_weight``, or ``weights``); with ``init`` its model and α are the start and
    prior, uncovered speeds keep its gaps, version + 1. DemoError, TrainingError."""
    cfg = config if config is not None else IrlConfig()
    if not seed >= 0:  # numpy's generators take no negative seed
        raise TrainingError(f"a seed is an integer >= 0, got {seed}")
    if init is not None and init.driver_id != driver_id:
        raise TrainingError(
            f"the initial table belongs to driver {init.driver_id!r}, not {driver_id!r}"
        )
    w = list(weights) if weights is not None else dm.takeover_weighted(trips, cfg.takeover_weight)
    if len(w) != len(trips):
        raise DemoError(f"{len(w)} weights for {len(trips)} trips")
    usable_s = dm.check_demos(
        trips, max_gap_m=cfg.max_gap_m, min_total_s=cfg.min_total_demo_s, dt_s=cfg.grid.dt_s
    )
    samples = dm.pooled_samples(trips, cfg.max_gap_m)
    axis = speed_axis(cfg.dgpt_step_mps)
    previous = None if init is None else np.interp(axis, init.speed_mps, init.gap_m)
    ev = evidence(
        axis, samples, cfg.min_coverage_s, previous, cfg.blend_window_mps, cfg.init_support_ratio
    )
    model = model_of_table(init) or fresh_model(samples, cfg.grid, cfg.features)
    mdp = compile_model(model, cfg.grid)
    tr = dm.extract_transitions(
        trips, w, dt_s=model.grid.dt_s, horizon=cfg.horizon_steps, max_gap_m=cfg.max_gap_m
    )
    stats = dm.demo_stats(mdp, tr, cfg.horizon_steps)
    alpha0 = start_alpha(model.features.n_features, model.prior_alpha, seed)
    fit = fit_alpha(mdp, stats, alpha0, model.prior_alpha, cfg, progress)
    learned = _extract(cfg, fit.alpha, mdp, axis, ev)
    gap, covered = blend(axis, learned, ev, half_s=cfg.blend_half_s, bounds=cfg.bounds)
    meta: dict[str, Any] = {
        "method": METHOD,
        "training_digest": dm.digest(trips, w),
        "seed": int(seed),
        "n_trips": len(trips),
        "usable_demo_s": round(usable_s, 3),
        "n_segments": stats.n_segments,
        "coverage_s": [round(float(c), 2) for c in ev.coverage_s],
        "min_coverage_s": cfg.min_coverage_s,
        "covered_mps": covered_ranges(axis, covered),
        "outside_coverage": outside_coverage(axis, covered),
        "alpha": [float(a) for a in fit.alpha],
        "grid": model.grid.spec(),
        "features": model.features.spec(),
        "horizon_steps": cfg.horizon_steps,
        "l2": cfg.l2,
        "iterations": fit.n_iter,
        "converged": fit.converged,
        "objective": fit.objective,
    }
    if init is not None:
        meta["parent_version"] = init.version
    table = Dgpt(
        speed_mps=axis,
        gap_m=gap,
        version=init.version + 1 if init is not None else 1,
        driver_id=driver_id,
        condition=condition,
        source="irl",
        meta=meta,
    )
    baseline = baseline_if_any(trips, driver_id, condition, cfg)
    return LearnResult(
        table,
        baseline,
        fit.alpha,
        mdp,
        covered,
        fit.n_iter,
        fit.converged,
        fit.message,
        fit.train_s,
    )


def fine_tune(
    takeover_trips: list[Trip],
    init: Dgpt,
    *,
    demos: Sequence[Trip] = (),
    seed: int = 0,
    progress: bool = False,
    config: IrlConfig | None = None,
) -> LearnResult:
    """The next version of ``init`` (an IRL table of this method) from the takeovers of ACC
    trips (weight ``config.takeover_weight``; earlier ``demos`` weight 1)."""
    cfg = config if config is not None else IrlConfig()
    if model_of_table(init) is None:
        raise TrainingError(
            "fine-tuning needs an IRL table of this method as init (its alpha and grid); "
            f"got source={init.source!r}, method={init.meta.get('method')!r}"
        )
    trips = [*takeover_trips, *demos]
    weights = [cfg.takeover_weight] * len(takeover_trips) + [1.0] * len(demos)
    # takeovers are short: accept any amount, the prior keeps the rest of the table
    cfg_ft = replace(
        cfg,
        min_total_demo_s=min(cfg.min_total_demo_s, 5.0),
        min_coverage_s=min(cfg.min_coverage_s, 3.0),
    )
    return learn_dgpt(
        trips,
        driver_id=init.driver_id,
        condition=init.condition,
        init=init,
        seed=seed,
        progress=progress,
        config=cfg_ft,
        weights=weights,
    )


def _extract(
    cfg: IrlConfig, alpha: np.ndarray, mdp: CompiledMdp, axis: np.ndarray, ev: Evidence
) -> np.ndarray:
    """The table (n,) of the fitted weights ``alpha``: the gap the policy keeps, finished."""
    drift, value = steady_drift(mdp, alpha, cfg.horizon_steps)
    support = search_range(axis, ev.support, cfg.bounds, cfg.gap_resolution_m)
    raw = steady_gaps(drift, value, mdp.grid.v_mps, mdp.grid.gap_m, axis, support)
    return finish_table(axis, raw, ev.covered, cfg.bounds, cutoff=cfg.lowpass_cutoff)
