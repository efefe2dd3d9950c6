"""Maximum causal entropy IRL on a sparse finite-horizon MDP: pure functions.

Shapes: ``S`` states, ``A`` actions, ``K`` features, ``H`` the longest segment (steps); time is
counted in steps to go. :func:`soft_value_iteration` (log space), :func:`state_action_visitation`
and :func:`objective`, the convex dual ``f(α) = −(α·μ_D − Σ_h p0_h·V_h) + ½λ‖α − α_prior‖²``,
minimised by :func:`fit_alpha` (L-BFGS-B from :func:`start_alpha`: the prior α or zeros plus
N(0, 10⁻³) noise from the seed). The table is read from the soft-optimal policy, not the
reward's argmax (3–6 m off the OpenACC followers' steady gaps; docs/irl.md):
:func:`steady_drift` (``E_π[a | v, g, dv = 0]``, m/s², and the soft value on the grid's (v, g))
and :func:`steady_gaps` (per DGPT speed the gap, m, where that drift turns from braking to
accelerating, the highest-value one if several, else the demonstrated range's edge).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy import optimize
from tqdm import tqdm

from cloud_sync.errors import TrainingError
from cloud_sync.irl.config import IrlConfig
from cloud_sync.irl.features import Features
from cloud_sync.irl.mdp import Grid, interp_weights


@dataclass(frozen=True)
class CompiledMdp:
    """An MDP ready for IRL: grid, features, ``P`` (S·A, S) CSR and its transpose (S, S·A)."""

    grid: Grid
    features: Features
    P: sp.csr_matrix
    PT: sp.csr_matrix

    @classmethod
    def build(cls, grid: Grid, features: Features, P: sp.csr_matrix) -> CompiledMdp:
        """Compile with a CSR copy of ``Pᵀ`` for fast forward passes."""
        if P.shape != (grid.n_states * grid.n_actions, grid.n_states):
            raise TrainingError(
                f"P has shape {P.shape}, grid needs "
                f"({grid.n_states * grid.n_actions}, {grid.n_states})"
            )
        return cls(grid=grid, features=features, P=P.tocsr(), PT=P.T.tocsr())


@dataclass(frozen=True)
class DemoStats:
    """What IRL needs from the demonstrations (weights summing to one): ``mu`` (K,) feature
    counts per segment, ``p0`` (H, S) start distribution (row ``h−1``: segments of ``h``
    steps; sums to 1), ``n_segments``."""

    mu: np.ndarray
    p0: np.ndarray
    n_segments: int

    @property
    def horizon(self) -> int:
        """The longest segment, steps."""
        return int(self.p0.shape[0])


def reward_table(mdp: CompiledMdp, alpha: np.ndarray) -> np.ndarray:
    """``r(s, a)`` of weights ``alpha`` (K,): shape (S, A); the (v, g) part weighted by κ(dv)
    (:mod:`cloud_sync.irl.features`)."""
    feats = mdp.features
    A, a_dv, a_a = feats.split(alpha)
    r_vg = np.einsum("kj,klj->kl", feats.Bv @ A, feats.Bg)
    r_s = (r_vg[:, :, None] * feats.k_dv[None, None, :] + a_dv * feats.f_dv[None, None, :]).ravel()
    return np.asarray(r_s[:, None] + a_a * feats.f_a[None, :])


def _logsumexp_rows(q: np.ndarray) -> np.ndarray:
    m = q.max(axis=1)
    return np.asarray(m + np.log(np.exp(q - m[:, None]).sum(axis=1)))


def soft_value_iteration(
    P: sp.csr_matrix, reward: np.ndarray, horizon: int
) -> tuple[np.ndarray, np.ndarray]:
    """Soft value iteration in log space on ``P`` (S·A, S) and ``reward`` (S, A) over H ≥ 1
    steps: ``V`` (H+1, S), ``V[h]`` with ``h`` steps to go (``V[0] = 0``), and ``pi`` (H, S, A),
    ``pi[h−1]`` with ``h`` steps to go."""
    if horizon < 1:
        raise TrainingError(f"horizon must be >= 1, got {horizon}")
    n_s, n_a = reward.shape
    V = np.zeros((horizon + 1, n_s))
    pi = np.empty((horizon, n_s, n_a))
    for h in range(1, horizon + 1):
        q = reward + (P @ V[h - 1]).reshape(n_s, n_a)
        V[h] = _logsumexp_rows(q)
        pi[h - 1] = np.exp(q - V[h][:, None])
    return V, pi


def state_action_visitation(PT: sp.csr_matrix, pi: np.ndarray, p0: np.ndarray) -> np.ndarray:
    """Expected state-action counts summed over time (S, A), from ``PT`` (S, S·A), ``pi``
    (H, S, A) and ``p0`` (H, S) (row ``h−1`` enters with ``h`` steps to go); they total
    ``Σ_h h·p0[h−1].sum()``."""
    horizon, n_s, n_a = pi.shape
    if p0.shape != (horizon, n_s):
        raise TrainingError(f"p0 has shape {p0.shape}, expected {(horizon, n_s)}")
    D = np.zeros(n_s)
    total = np.zeros((n_s, n_a))
    for h in range(horizon, 0, -1):
        D = D + p0[h - 1]
        d_sa = D[:, None] * pi[h - 1]
        total += d_sa
        if h > 1:
            D = PT @ d_sa.ravel()
    return total


def feature_expectations(mdp: CompiledMdp, d_sa: np.ndarray) -> np.ndarray:
    """Feature counts (K,) of state-action counts ``d_sa`` (S, A); (v, g) counts weighted by
    κ(dv)."""
    feats = mdp.features
    d_s = d_sa.sum(axis=1).reshape(mdp.grid.shape)
    m_vg = d_s @ feats.k_dv
    rbf = feats.counts(m_vg)
    mu_dv = float(d_s.sum(axis=(0, 1)) @ feats.f_dv)
    mu_a = float(d_sa.sum(axis=0) @ feats.f_a)
    return np.concatenate([rbf, [mu_dv, mu_a]])


def objective(
    alpha: np.ndarray,
    mdp: CompiledMdp,
    demos: DemoStats,
    *,
    l2: float,
    prior: np.ndarray | None = None,
) -> tuple[float, np.ndarray]:
    """The convex MCE-IRL dual ``f(α)`` and its gradient (K,), see the module docstring."""
    reward = reward_table(mdp, alpha)
    V, pi = soft_value_iteration(mdp.P, reward, demos.horizon)
    log_z = float(np.sum(demos.p0 * V[1:]))
    mu_model = feature_expectations(mdp, state_action_visitation(mdp.PT, pi, demos.p0))
    diff = alpha - (prior if prior is not None else 0.0)
    value = -(float(alpha @ demos.mu) - log_z) + 0.5 * l2 * float(diff @ diff)
    grad = mu_model - demos.mu + l2 * diff
    if not (np.isfinite(value) and np.all(np.isfinite(grad))):
        raise TrainingError("IRL objective is not finite (reward weights diverged)")
    return value, grad


@dataclass(frozen=True)
class Fit:
    """The outcome of :func:`fit_alpha`: ``alpha`` (K,), iterations, whether the stopping
    rule was met and the optimiser's message, the final objective, wall time ``train_s`` (s)."""

    alpha: np.ndarray
    n_iter: int
    converged: bool
    message: str
    objective: float
    train_s: float


def start_alpha(n_features: int, prior: np.ndarray | None, seed: int) -> np.ndarray:
    """``prior`` (or zeros), shape (K,), plus N(0, 10⁻³) noise from ``default_rng(seed)``."""
    rng = np.random.default_rng(seed)
    alpha0 = prior.copy() if prior is not None else np.zeros(n_features)
    return np.asarray(alpha0 + rng.normal(0.0, 1e-3, n_features))


def fit_alpha(
    mdp: CompiledMdp,
    stats: DemoStats,
    alpha0: np.ndarray,
    prior: np.ndarray | None,
    cfg: IrlConfig,
    progress: bool = False,
) -> Fit:
    """Minimise the MCE-IRL dual by L-BFGS-B from ``alpha0`` (K,), L2 (``cfg.l2``) towards
    ``prior`` (stops at ``cfg.max_iter``, ``gtol``, ``ftol``); TrainingError if it diverges."""
    bar = tqdm(total=cfg.max_iter, desc="IRL", unit="it", leave=False) if progress else None

    def fun(alpha: np.ndarray) -> tuple[float, np.ndarray]:
        return objective(alpha, mdp, stats, l2=cfg.l2, prior=prior)

    def show(intermediate_result: optimize.OptimizeResult) -> None:
        if bar is not None:
            bar.update(1)
            bar.set_postfix(f=f"{intermediate_result.fun:.4f}")

    t0 = time.perf_counter()
    try:
        options = {"maxiter": cfg.max_iter, "gtol": cfg.gtol, "ftol": cfg.ftol}
        callback = show if bar is not None else None
        res = optimize.minimize(
            fun, alpha0, jac=True, method="L-BFGS-B", callback=callback, options=options
        )
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    return Fit(
        np.asarray(res.x), int(res.nit), bool(res.success), str(res.message), float(res.fun), wall
    )


def steady_drift(
    mdp: CompiledMdp, alpha: np.ndarray, horizon: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(drift, value)``, each (n_v, n_gap) on ``mdp.grid``: the soft-optimal policy's
    expected acceleration (m/s²) with ``horizon`` steps to go at relative speed 0 (linearly
    interpolated on the dv axis), and the soft value of those states."""
    grid = mdp.grid
    n_v, n_g, n_dv = grid.shape
    V, pi = soft_value_iteration(mdp.P, reward_table(mdp, alpha), horizon)
    ea = (pi[horizon - 1] @ grid.accels_mps2).reshape(n_v, n_g, n_dv)
    value = V[horizon].reshape(n_v, n_g, n_dv)
    i0, i1, w1 = interp_weights(grid.dv_mps, np.zeros(1))
    w = float(w1[0])
    drift = (1.0 - w) * ea[:, :, int(i0[0])] + w * ea[:, :, int(i1[0])]
    val = (1.0 - w) * value[:, :, int(i0[0])] + w * value[:, :, int(i1[0])]
    return np.asarray(drift), np.asarray(val)


def _along_speed(table: np.ndarray, grid_v: np.ndarray, v: float) -> np.ndarray:
    """Row of ``table`` (n_v, m) linearly interpolated at speed ``v``: (m,)."""
    i0, i1, w1 = interp_weights(grid_v, np.asarray([v]))
    w = float(w1[0])
    return np.asarray((1.0 - w) * table[int(i0[0])] + w * table[int(i1[0])])


def steady_gaps(
    drift: np.ndarray,
    value: np.ndarray,
    grid_v_mps: np.ndarray,
    grid_gap_m: np.ndarray,
    axis_mps: np.ndarray,
    support: tuple[np.ndarray, np.ndarray],
) -> np.ndarray:
    """The steady-following gap (n,) at each speed of ``axis_mps``: ``drift``, ``value``
    (n_v, n_gap) on the grid axes, ``support`` (lo, hi) (n,) each; NaN where the support is NaN
    or the speed lies above the grid."""
    out = np.full(axis_mps.size, np.nan)
    g = grid_gap_m
    for k, v in enumerate(axis_mps.tolist()):
        lo, hi = float(support[0][k]), float(support[1][k])
        if not (np.isfinite(lo) and np.isfinite(hi)) or v > grid_v_mps[-1] + 1e-9:
            continue
        d = _along_speed(drift, grid_v_mps, v)
        val = _along_speed(value, grid_v_mps, v)
        up = np.flatnonzero((d[:-1] < 0.0) & (d[1:] >= 0.0))
        x = g[up] + (g[up + 1] - g[up]) * (-d[up]) / (d[up + 1] - d[up])
        inside = (x >= lo) & (x <= hi)
        if inside.any():
            cand = x[inside]
            out[k] = float(cand[np.argmax(np.interp(cand, g, val))])
        else:
            # no gap to return to inside the range: the policy drives the gap to an edge
            # (accelerating everywhere: the lower one; braking everywhere: the upper one;
            # pushed away from an unstable gap: the edge of higher soft value)
            d_lo, d_hi = np.interp([lo, hi], g, d)
            if d_lo >= 0.0 and d_hi >= 0.0:
                out[k] = lo
            elif d_lo < 0.0 and d_hi < 0.0:
                out[k] = hi
            else:
                v_lo, v_hi = np.interp([lo, hi], g, val)
                out[k] = lo if v_lo >= v_hi else hi
    return out
