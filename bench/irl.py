"""Benchmark: IRL training time for one driver from 20 minutes of 10 Hz demonstrations.

Demonstrations: built-in synthetic driver d2 driving the four canonical manual profiles by hand
(4 × 300 s at 10 Hz, sim_bus.manual). Peer: the same algorithm with dense NumPy arrays (a
plain reference: dense transition matrix, the same soft value iteration, visitation and
L-BFGS), on a grid small enough for the dense matrix to fit; both run on that grid and the
ratio is printed. (imitation's MCE IRL needs torch and gym; it is not installed here.)

    .venv/bin/python bench/irl.py
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import scipy.sparse as sp
from scipy import optimize

from cloud_sync.irl import demos as dm
from cloud_sync.irl.config import IrlConfig
from cloud_sync.irl.features import FeatureConfig, make_features
from cloud_sync.irl.mce_irl import (
    CompiledMdp,
    DemoStats,
    feature_expectations,
    objective,
    reward_table,
)
from cloud_sync.irl.mdp import GridConfig, build_transitions, make_grid
from cloud_sync.irl.trainer import learn_dgpt
from dbc.vocab.triplog import Trip
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.lead.scenarios import canonical_profiles
from sim_bus.manual import manual_trip


def demonstrations() -> list[Trip]:
    profiles = canonical_profiles(0)
    d2 = BUILTIN_DRIVERS["d2"]
    return [manual_trip(d2, profiles[f"manual{i + 1}"], i) for i in range(4)]


def dense_objective(
    alpha: np.ndarray, mdp: CompiledMdp, P: np.ndarray, stats: DemoStats, l2: float
) -> tuple[float, np.ndarray]:
    """The same dual and gradient as ``cloud_sync.irl.mce_irl.objective``, dense arrays."""
    r = reward_table(mdp, alpha)
    n_s, n_a = r.shape
    H = stats.horizon
    V = np.zeros((H + 1, n_s))
    pi = np.empty((H, n_s, n_a))
    for h in range(1, H + 1):
        q = r + (P @ V[h - 1]).reshape(n_s, n_a)
        m = q.max(axis=1)
        V[h] = m + np.log(np.exp(q - m[:, None]).sum(axis=1))
        pi[h - 1] = np.exp(q - V[h][:, None])
    D = np.zeros(n_s)
    total = np.zeros((n_s, n_a))
    PT = P.T
    for h in range(H, 0, -1):
        D = D + stats.p0[h - 1]
        d_sa = D[:, None] * pi[h - 1]
        total += d_sa
        D = PT @ d_sa.ravel()
    mu_m = feature_expectations(mdp, total)
    value = -(float(alpha @ stats.mu) - float(np.sum(stats.p0 * V[1:]))) + 0.5 * l2 * alpha @ alpha
    return float(value), mu_m - stats.mu + l2 * alpha


def train(
    fun: Callable[[np.ndarray], tuple[float, np.ndarray]], n_features: int, cfg: IrlConfig
) -> tuple[np.ndarray, int, float]:
    t0 = time.perf_counter()
    res = optimize.minimize(
        fun,
        np.zeros(n_features),
        jac=True,
        method="L-BFGS-B",
        options={"maxiter": cfg.max_iter, "gtol": cfg.gtol, "ftol": cfg.ftol},
    )
    return np.asarray(res.x), int(res.nit), time.perf_counter() - t0


def main() -> int:
    trips = demonstrations()
    minutes = sum(t.duration_s for t in trips) / 60.0
    cfg = IrlConfig()

    # full problem, the trainer end to end (transitions, demo statistics, L-BFGS, table)
    t0 = time.perf_counter()
    result = learn_dgpt(trips, driver_id="d2", seed=0)
    total_s = time.perf_counter() - t0
    g = result.mdp.grid
    print(f"demonstrations: {len(trips)} trips, {minutes:.1f} min at 10 Hz (driver d2)")
    print(
        f"grid: {g.shape[0]} v x {g.shape[1]} gap x {g.shape[2]} dv = {g.n_states} states x "
        f"{g.n_actions} actions = {g.n_states * g.n_actions} state-actions; "
        f"P nnz {result.mdp.P.nnz} ({result.mdp.P.nnz / (g.n_states * g.n_actions):.1f}/row); "
        f"dense P would need {g.n_states**2 * g.n_actions * 8 / 1e9:.1f} GB"
    )
    print(
        f"full: {result.n_iter} L-BFGS iterations, optimisation {result.train_s:.2f} s, "
        f"end to end {total_s:.2f} s"
    )

    # peer comparison on a grid the dense reference can hold
    small_cfg = GridConfig(v_step_mps=2.0, gap_step_m=4.0, dv_step_mps=2.0, dv_max_mps=6.0)
    samples_v = np.concatenate([t.v_mps for t in trips])
    samples_g = np.concatenate([t.gap_m for t in trips])
    grid = make_grid(small_cfg, float(samples_v.max()), float(np.percentile(samples_g, 99.5)))
    feats = make_features(grid, FeatureConfig(v_spacing_mps=4.0, gap_spacing_m=6.0), 4.0, 1.7)
    P = build_transitions(grid, small_cfg)
    mdp = CompiledMdp.build(grid, feats, P)
    tr = dm.extract_transitions(
        trips,
        [1.0] * len(trips),
        dt_s=grid.dt_s,
        horizon=cfg.horizon_steps,
        max_gap_m=cfg.max_gap_m,
    )
    stats = dm.demo_stats(mdp, tr, cfg.horizon_steps)
    P_dense = P.toarray()
    assert isinstance(P, sp.csr_matrix)
    a_sparse, it_s, t_sparse = train(
        lambda a: objective(a, mdp, stats, l2=cfg.l2), feats.n_features, cfg
    )
    a_dense, it_d, t_dense = train(
        lambda a: dense_objective(a, mdp, P_dense, stats, cfg.l2), feats.n_features, cfg
    )
    print(
        f"small grid: {grid.n_states} states x {grid.n_actions} actions "
        f"(dense P {P_dense.nbytes / 1e6:.0f} MB)"
    )
    print(f"  sparse (cloud_sync):  {t_sparse:8.3f} s, {it_s} iterations")
    print(
        f"  dense reference:      {t_dense:8.3f} s, {it_d} iterations "
        f"(max |alpha difference| {np.max(np.abs(a_sparse - a_dense)):.1e})"
    )
    print(f"  ratio dense / sparse: {t_dense / t_sparse:.1f}x")
    print(f"train: {total_s:.1f} s per driver")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
