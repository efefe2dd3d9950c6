"""Maximum causal entropy IRL on a sparse finite-horizon MDP: pure functions.

Shapes: ``S`` states, ``A`` actions, ``K`` features, ``H`` the longest segment (steps); time is
counted in steps to go. :func:`soft_value_iteration` (log space), :func:`state_action_visitation`
and :func:`objective`, the convex dual ``f(α) = −(α·μ_D − Σ_h p0_h·V_h) + ½λ‖α − α_prior‖²``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from cloud_sync.errors import TrainingError
from cloud_sync.irl.features import Features
from cloud_sync.irl.mdp import Grid

__all__ = [
    "CompiledMdp",
    "DemoStats",
    "reward_table",
    "soft_value_iteration",
    "state_action_visitation",
    "feature_expectations",
    "objective",
]


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
