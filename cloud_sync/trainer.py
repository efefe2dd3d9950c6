"""The IRL trainer: trips in, a driver's DGPT out (a thin layer over the pure modules).

:func:`learn_dgpt` learns from demonstrations (manual drives, plus the takeovers of ACC trips,
weighted); :func:`fine_tune` continues from an earlier IRL table with new takeovers;
:func:`empirical_baseline` is the comparison table. Every result is a pure function of
(configuration, seed, data): the optimiser is deterministic and the seed only draws the
starting weights, which the convex objective forgets.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy import optimize

from cloud_sync import demos as dm
from cloud_sync.errors import DemoError, TrainingError
from cloud_sync.extract import (
    argmax_gap,
    coverage_s,
    finish_table,
    gap_support,
    reference_line,
    steady_state_gaps,
)
from cloud_sync.features import FeatureConfig, Features, features_from_spec, make_features
from cloud_sync.mce_irl import CompiledMdp, DemoStats, objective
from cloud_sync.mdp import Grid, GridConfig, build_transitions, grid_from_spec, make_grid
from ecu.dgpt import Dgpt, SafetyBounds, clamp_to_bounds, speed_axis
from ecu.triplog import Trip

__all__ = ["IrlConfig", "LearnResult", "learn_dgpt", "fine_tune", "empirical_baseline", "METHOD"]

METHOD = "mce_irl/1"


@dataclass(frozen=True)
class IrlConfig:
    """Everything that decides a learned table (units in names).

    ``horizon_steps``: the longest demonstration segment (decisions). ``l2``: weight of the
    quadratic penalty on α (towards the previous α when fine-tuning). ``max_iter``/``gtol``/
    ``ftol``: the L-BFGS stopping rule (iterations; max |gradient component| per segment;
    relative objective decrease). ``min_total_demo_s``: refuse less usable demonstration.
    ``min_coverage_s``: seconds within ±0.5 m/s for a speed bin to count as evidence.
    ``takeover_weight``: weight of an ACC trip's takeover samples against manual samples.
    ``blend_window_mps``: when continuing from an earlier table, new evidence moves the table
    within this distance of its speeds, blended by its amount (weight c/(c + blend_half_s)
    for c seconds of new evidence); elsewhere the table is kept;
    the argmax may range ±``init_support_ratio`` around the earlier gaps.
    """

    grid: GridConfig = field(default_factory=GridConfig)
    features: FeatureConfig = field(default_factory=FeatureConfig)
    bounds: SafetyBounds = field(default_factory=SafetyBounds)
    horizon_steps: int = 5
    l2: float = 0.01
    max_iter: int = 150
    gtol: float = 1e-3
    ftol: float = 1e-7
    max_gap_m: float = 120.0
    min_total_demo_s: float = 60.0
    min_coverage_s: float = 10.0
    lowpass_cutoff: float = 0.1
    gap_resolution_m: float = 0.25
    takeover_weight: float = 5.0
    dgpt_step_mps: float = 0.5
    blend_window_mps: float = 2.0
    blend_half_s: float = 10.0
    init_support_ratio: float = 0.3

    def __post_init__(self) -> None:
        if self.horizon_steps < 1:
            raise TrainingError("horizon_steps must be >= 1")
        if not (self.l2 >= 0 and self.max_iter >= 1 and self.gtol > 0 and self.ftol > 0):
            raise TrainingError("l2 must be >= 0, max_iter >= 1, gtol and ftol > 0")
        if not 0 < self.lowpass_cutoff < 1:
            raise TrainingError("lowpass_cutoff must be in (0, 1)")
        positive = (
            "max_gap_m",
            "min_coverage_s",
            "gap_resolution_m",
            "takeover_weight",
            "dgpt_step_mps",
            "blend_half_s",
        )
        for name in positive:  # finite and > 0 (NaN fails the comparison too)
            value = getattr(self, name)
            if not 0 < value < math.inf:
                raise TrainingError(f"{name} must be a finite number > 0, got {value}")
        for name in ("min_total_demo_s", "blend_window_mps", "init_support_ratio"):
            value = getattr(self, name)
            if not 0 <= value < math.inf:
                raise TrainingError(f"{name} must be a finite number >= 0, got {value}")


@dataclass(frozen=True)
class LearnResult:
    """A learned table and how it was obtained.

    Attributes:
        table: the DGPT (source ``irl``). baseline: the empirical steady-state table (None
            when the data hold no steady-state following, e.g. takeovers alone).
        alpha: (K,) reward weights. mdp: the compiled MDP (grid, features, transitions).
        coverage_s: (n,) seconds of demonstration per DGPT speed bin. covered: (n,) bool.
        history: objective value per L-BFGS iteration. n_iter, converged, message: the
        optimiser's outcome. train_s: wall time of the optimisation, s. digest: SHA-256 of data.
    """

    table: Dgpt
    baseline: Dgpt | None
    alpha: np.ndarray
    mdp: CompiledMdp
    coverage_s: np.ndarray
    covered: np.ndarray
    history: list[float]
    n_iter: int
    converged: bool
    message: str
    train_s: float
    digest: str

    def reward_vg(self, v_mps: np.ndarray, gap_m: np.ndarray) -> np.ndarray:
        """The recovered (v, g) reward on the outer product of (n,) and (m,): (n, m)."""
        return self.mdp.features.reward_vg(self.alpha, v_mps, gap_m)


def _samples(trips: Sequence[Trip], max_gap_m: float) -> dict[str, np.ndarray]:
    """Usable samples of all trips, concatenated: v, gap, dv, a, dt (each (k,))."""
    out: dict[str, list[np.ndarray]] = {"v": [], "g": [], "dv": [], "a": [], "dt": []}
    for trip in trips:
        if len(trip) < 2:
            continue
        m = dm.usable_mask(trip, max_gap_m)
        dt = np.diff(trip.t_s, append=trip.t_s[-1] + np.median(np.diff(trip.t_s)))
        out["v"].append(trip.v_mps[m])
        out["g"].append(trip.gap_m[m])
        out["dv"].append((trip.v_lead_mps - trip.v_mps)[m])
        a = np.where(np.isfinite(trip.a_mps2), trip.a_mps2, np.inf)
        out["a"].append(a[m])
        out["dt"].append(dt[m])
    return {k: np.concatenate(v) if v else np.zeros(0) for k, v in out.items()}


def _prior_from(init: Dgpt | None) -> tuple[Grid, Features, np.ndarray] | None:
    """The grid, features and α stored in an earlier IRL table, if it has them."""
    if init is None or init.meta.get("method") != METHOD:
        return None
    try:
        grid = grid_from_spec(init.meta["grid"])
        feats = features_from_spec(grid, init.meta["features"])
        alpha = np.asarray(init.meta["alpha"], dtype=np.float64)
    except (KeyError, TypeError, ValueError, TrainingError) as exc:
        raise TrainingError(f"initial DGPT has unusable IRL metadata: {exc}") from exc
    if alpha.shape != (feats.n_features,) or not np.all(np.isfinite(alpha)):
        raise TrainingError("initial DGPT: alpha does not match its feature spec")
    return grid, feats, alpha


def _optimise(
    mdp: CompiledMdp,
    stats: DemoStats,
    alpha0: np.ndarray,
    prior: np.ndarray | None,
    config: IrlConfig,
    progress: bool,
) -> tuple[np.ndarray, list[float], optimize.OptimizeResult]:
    history: list[float] = []
    bar: Any = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=config.max_iter, desc="IRL", unit="it", leave=False)

    def fun(alpha: np.ndarray) -> tuple[float, np.ndarray]:
        return objective(alpha, mdp, stats, l2=config.l2, prior=prior)

    def callback(intermediate_result: optimize.OptimizeResult) -> None:
        history.append(float(intermediate_result.fun))
        if bar is not None:
            bar.update(1)
            bar.set_postfix(f=f"{intermediate_result.fun:.4f}")

    try:
        res = optimize.minimize(
            fun,
            alpha0,
            jac=True,
            method="L-BFGS-B",
            callback=callback,
            options={"maxiter": config.max_iter, "gtol": config.gtol, "ftol": config.ftol},
        )
    finally:
        if bar is not None:
            bar.close()
    return np.asarray(res.x), history, res


def _extract(
    result_alpha: np.ndarray,
    feats: Features,
    axis: np.ndarray,
    covered: np.ndarray,
    config: IrlConfig,
    support: tuple[np.ndarray, np.ndarray],
) -> np.ndarray:
    b = config.bounds
    gaps = np.arange(b.lower_m(0.0), float(b.upper_m(axis[-1])) + 1e-9, config.gap_resolution_m)
    reward = feats.reward_vg(result_alpha, axis, gaps)
    # the argmax is taken inside the safe band and the demonstrated gap range at each speed
    lo = np.fmax(b.lower_m(axis), np.nan_to_num(support[0], nan=-np.inf))[:, None]
    hi = np.fmin(b.upper_m(axis), np.nan_to_num(support[1], nan=np.inf))[:, None]
    hi = np.maximum(hi, lo + config.gap_resolution_m)
    reward = np.where((gaps[None, :] >= lo) & (gaps[None, :] <= hi), reward, -np.inf)
    raw = argmax_gap(reward, gaps)
    return finish_table(axis, raw, covered, b, cutoff=config.lowpass_cutoff)


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
    s = _samples(trips, cfg.max_gap_m)
    axis = speed_axis(cfg.dgpt_step_mps)
    raw, count = steady_state_gaps(axis, s["v"], s["g"], s["dv"], s["a"])
    dt = float(np.median(s["dt"])) if s["dt"].size else 0.1
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
            "training_digest": dm.digest(trips, [1.0] * len(trips)),
        },
    )


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
    """Learn a driver's DGPT by maximum causal entropy IRL from ``trips``.

    Manual drives count with weight 1 and the takeovers of ACC trips with
    ``config.takeover_weight`` (or explicit per-trip ``weights``). With ``init`` (an earlier
    table of this method) the grid, the features and α are taken from it, α starts from and is
    pulled towards the earlier α, speeds without new evidence keep the earlier gaps, and the
    result is ``init.version + 1``. Raises :class:`DemoError` for empty, NaN-filled or too
    short demonstrations, :class:`TrainingError` for a negative seed or if the optimisation
    fails.
    """
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
    samples = _samples(trips, cfg.max_gap_m)
    prior = _prior_from(init)
    if prior is not None:
        grid, feats, alpha_prev = prior
    else:
        grid = make_grid(
            cfg.grid,
            float(np.percentile(samples["v"], 99.9)),
            float(np.percentile(samples["g"], 99.5)),
        )
        c0, c1 = reference_line(samples["v"], samples["g"], samples["dv"], samples["a"])
        feats = make_features(grid, cfg.features, c0, c1)
        alpha_prev = None
    mdp = CompiledMdp.build(grid, feats, build_transitions(grid, cfg.grid))
    tr = dm.extract_transitions(
        trips, w, dt_s=grid.dt_s, horizon=cfg.horizon_steps, max_gap_m=cfg.max_gap_m
    )
    stats = dm.demo_stats(mdp, tr, cfg.horizon_steps)
    rng = np.random.default_rng(seed)
    alpha0 = alpha_prev.copy() if alpha_prev is not None else np.zeros(feats.n_features)
    alpha0 = alpha0 + rng.normal(0.0, 1e-3, feats.n_features)
    t0 = time.perf_counter()
    alpha, history, res = _optimise(mdp, stats, alpha0, alpha_prev, cfg, progress)
    train_s = time.perf_counter() - t0

    axis = speed_axis(cfg.dgpt_step_mps)
    cov = coverage_s(axis, samples["v"], samples["dt"])
    covered = cov >= cfg.min_coverage_s
    if init is not None:
        # continuing: new evidence counts within ±blend_window of its speeds
        cov_wide = coverage_s(axis, samples["v"], samples["dt"], cfg.blend_window_mps)
        covered = cov_wide >= cfg.min_coverage_s
    if not (covered & (axis > 0.5)).any():
        raise DemoError(
            f"no speed bin above standstill has {cfg.min_coverage_s:g} s of demonstration; "
            "cannot build a table"
        )
    support = gap_support(axis, samples["v"], samples["g"])
    if init is not None:
        # the earlier table's neighbourhood is known ground too (its data are not at hand)
        before = np.interp(axis, init.speed_mps, init.gap_m)
        support = (
            np.fmin(support[0], before * (1.0 - cfg.init_support_ratio)),
            np.fmax(support[1], before * (1.0 + cfg.init_support_ratio)),
        )
    gap = _extract(alpha, feats, axis, covered, cfg, support)
    if init is not None:
        # blend into the earlier table by the amount of new evidence; untouched speeds
        # (no new sample within ±blend_window) keep the earlier gaps exactly
        previous = np.interp(axis, init.speed_mps, init.gap_m)
        blend = cov_wide / (cov_wide + cfg.blend_half_s)
        gap = np.where(blend > 0.0, blend * gap + (1.0 - blend) * previous, previous)
        gap = clamp_to_bounds(axis, gap, cfg.bounds)
        covered = blend > 0.0
    data_digest = dm.digest(trips, w)
    meta: dict[str, Any] = {
        "method": METHOD,
        "training_digest": data_digest,
        "seed": int(seed),
        "n_trips": len(trips),
        "usable_demo_s": round(usable_s, 3),
        "n_segments": stats.n_segments,
        "coverage_s": [round(float(c), 2) for c in cov],
        "min_coverage_s": cfg.min_coverage_s,
        "covered_mps": _ranges(axis, covered),
        "alpha": [float(a) for a in alpha],
        "grid": grid.spec(),
        "features": feats.spec(),
        "horizon_steps": cfg.horizon_steps,
        "l2": cfg.l2,
        "iterations": int(res.nit),
        "converged": bool(res.success),
        "objective": float(res.fun),
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
    try:
        baseline: Dgpt | None = empirical_baseline(
            trips, driver_id=driver_id, condition=condition, config=cfg
        )
    except DemoError:
        baseline = None  # e.g. takeovers alone hold no steady-state following
    return LearnResult(
        table=table,
        baseline=baseline,
        alpha=alpha,
        mdp=mdp,
        coverage_s=cov,
        covered=covered,
        history=history,
        n_iter=int(res.nit),
        converged=bool(res.success),
        message=str(res.message),
        train_s=train_s,
        digest=data_digest,
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
    """The next version of ``init`` from the takeover segments of ACC trips.

    Only the samples where the driver was in control count (``acc_state`` ≠ Active), with
    weight ``config.takeover_weight``; optional earlier ``demos`` count with weight 1. α starts
    from ``init``'s α and is pulled towards it, and speeds the takeovers do not cover keep
    ``init``'s gaps. ``init`` must be an IRL table of this method (it carries α and the grid).
    """
    cfg = config if config is not None else IrlConfig()
    if _prior_from(init) is None:
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


def _ranges(axis: np.ndarray, mask: np.ndarray) -> list[list[float]]:
    """Contiguous True ranges of ``mask`` as [[v_from, v_to], ...] (m/s)."""
    out: list[list[float]] = []
    padded = np.concatenate([[False], mask, [False]]).astype(np.int8)
    edges = np.flatnonzero(np.diff(padded))
    for a, b in zip(edges[::2], edges[1::2], strict=True):
        out.append([float(axis[a]), float(axis[b - 1])])
    return out
