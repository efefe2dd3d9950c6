"""The IRL trainer: trips in, a driver's DGPT out (a thin composition of the pure phases).

:func:`learn_dgpt` learns from demonstrations (manual drives, plus weighted ACC takeovers);
:func:`fine_tune` continues an earlier IRL table; :func:`empirical_baseline` is the comparison.
Phases: :mod:`~cloud_sync.irl.demos`, :mod:`~cloud_sync.irl.blend`, the reward model
(:class:`RewardModel`: a fresh grid and basis, or an earlier table's, with its α as the fit's
start and prior), :mod:`~cloud_sync.irl.mce_irl` (also the gap the policy keeps),
:mod:`~cloud_sync.irl.extract`. Every result is a pure function of (configuration, seed, data).
"""

from __future__ import annotations

import functools
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
    finish_table,
    outside_coverage,
    search_range,
)
from cloud_sync.irl.features import (
    FeatureConfig,
    Features,
    features_from_spec,
    make_features,
    make_time_gap_features,
)
from cloud_sync.irl.mce_irl import CompiledMdp, fit_alpha, start_alpha, steady_drift, steady_gaps
from cloud_sync.irl.mdp import Grid, GridConfig, build_transitions, grid_from_spec, make_grid
from dbc.vocab.dgpt import Dgpt, speed_axis
from dbc.vocab.triplog import Trip

#: ``meta["method"]`` of a learned table: the tables whose metadata carry a model
METHOD = "mce_irl/1"


@dataclass(frozen=True)
class RewardModel:
    """A grid, the reward basis on it and, continuing an earlier table, its α (K,)."""

    grid: Grid
    features: Features
    prior_alpha: np.ndarray | None = None


def reference_line(
    v_mps: np.ndarray, gap_m: np.ndarray, dv_mps: np.ndarray, a_mps2: np.ndarray
) -> tuple[float, float]:
    """Least-squares line ``g ≈ c0 + c1·v`` through near-steady samples (all samples if fewer
    than 20 are steady); ``c1`` clipped to 0…5 s. Inputs (k,). Returns ``(c0_m, c1_s)``."""
    steady = (np.abs(dv_mps) <= 1.0) & (np.abs(a_mps2) <= 0.5)
    if steady.sum() < 20:
        steady = np.ones(v_mps.size, dtype=bool)
    v, g = v_mps[steady], gap_m[steady]
    if v.size < 2 or float(np.ptp(v)) < 1e-6:
        return float(np.median(g)) if g.size else 0.0, 0.0
    c1, c0 = np.polyfit(v, g, 1)
    c1 = float(np.clip(c1, 0.0, 5.0))
    return float(np.median(g - c1 * v)), c1


def fresh_model(
    samples: dm.Samples, grid_config: GridConfig, feature_config: FeatureConfig
) -> RewardModel:
    """A grid up to the samples' 99.9 % speed and 99.5 % gap quantiles, and the basis of
    ``feature_config`` on it: time-gap RBFs (fitted to nothing), or, with the ``offset`` basis,
    RBFs around the samples' :func:`reference_line`; no prior α."""
    grid = make_grid(
        grid_config,
        float(np.percentile(samples.v_mps, 99.9)),
        float(np.percentile(samples.gap_m, 99.5)),
    )
    if feature_config.gap_basis == "time_gap":
        return RewardModel(grid=grid, features=make_time_gap_features(grid, feature_config))
    c0, c1 = reference_line(samples.v_mps, samples.gap_m, samples.dv_mps, samples.a_mps2)
    return RewardModel(grid=grid, features=make_features(grid, feature_config, c0, c1))


def model_of_table(table: Dgpt | None) -> RewardModel | None:
    """The grid, features and α of an earlier :data:`METHOD` table (None: no table or another
    method); TrainingError when its metadata are unusable."""
    if table is None or table.meta.get("method") != METHOD:
        return None
    try:
        grid = grid_from_spec(table.meta["grid"])
        feats = features_from_spec(grid, table.meta["features"])
        alpha = np.asarray(table.meta["alpha"], dtype=np.float64)
    except (KeyError, TypeError, ValueError, TrainingError) as exc:
        raise TrainingError(f"initial DGPT has unusable IRL metadata: {exc}") from exc
    if alpha.shape != (feats.n_features,) or not np.all(np.isfinite(alpha)):
        raise TrainingError("initial DGPT: alpha does not match its feature spec")
    return RewardModel(grid=grid, features=feats, prior_alpha=alpha)


def compile_model(model: RewardModel, grid_config: GridConfig) -> CompiledMdp:
    """The model's MDP with transitions under ``grid_config``'s noise (lead, speed); those of
    the last two grids are kept: a fine-tune on its parent's grid skips their build."""
    g = model.grid
    axes = tuple(a.tobytes() for a in (g.v_mps, g.gap_m, g.dv_mps, g.accels_mps2))
    return CompiledMdp.build(g, model.features, _transitions(axes, g.dt_s, grid_config))


@functools.lru_cache(maxsize=2)
def _transitions(axes: tuple[bytes, ...], dt_s: float, config: GridConfig) -> Any:
    """``P`` (read-only CSR) on the grid of ``axes``, the float64 bytes of v, gap, dv, accels."""
    v, gap, dv, accels = (np.frombuffer(a) for a in axes)
    P = build_transitions(Grid(v, gap, dv, accels, dt_s), config)
    for array in (P.data, P.indices, P.indptr):
        array.flags.writeable = False
    return P


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
