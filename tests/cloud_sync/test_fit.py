"""The IRL optimisation on a small MDP: start weights, convergence, the pull of the prior."""

from __future__ import annotations

import numpy as np
import pytest

from cloud_sync.irl.config import IrlConfig
from cloud_sync.irl.mce_irl import (
    DemoStats,
    feature_expectations,
    fit_alpha,
    objective,
    reward_table,
    soft_value_iteration,
    start_alpha,
    state_action_visitation,
)
from tests.cloud_sync.test_mce_irl import small_mdp

MDP = small_mdp()  # the small MDP of the MCE-IRL tests
GRID = MDP.grid
K = MDP.features.n_features


def own_stats(alpha: np.ndarray, horizon: int = 3) -> DemoStats:
    """Demonstrations that are the soft-optimal model's own expectation under ``alpha``."""
    p0 = np.zeros((horizon, GRID.n_states))
    p0[horizon - 1] = np.random.default_rng(1).dirichlet(np.ones(GRID.n_states))
    _, pi = soft_value_iteration(MDP.P, reward_table(MDP, alpha), horizon)
    mu = feature_expectations(MDP, state_action_visitation(MDP.PT, pi, p0))
    return DemoStats(mu=mu, p0=p0, n_segments=1)


def test_start_alpha_is_the_prior_plus_small_seeded_noise() -> None:
    prior = np.linspace(-1.0, 1.0, K)
    a = start_alpha(K, prior, 3)
    assert np.array_equal(a, start_alpha(K, prior, 3))
    assert not np.array_equal(a, start_alpha(K, prior, 4))
    assert 0.0 < np.max(np.abs(a - prior)) < 0.01
    assert np.array_equal(prior, np.linspace(-1.0, 1.0, K))  # the prior is not modified
    assert 0.0 < np.max(np.abs(start_alpha(K, None, 0))) < 0.01


def test_fit_stops_at_the_stationary_point_of_the_dual() -> None:
    """At the optimum the model's feature counts equal the demonstrated ones up to the L2 pull:
    ``μ_model − μ_D = −λ·α``."""
    stats = own_stats(np.random.default_rng(5).normal(0.0, 0.5, K))
    alpha0 = start_alpha(K, None, 0)
    fit = fit_alpha(
        MDP, stats, alpha0, None, IrlConfig(l2=0.01, max_iter=300, gtol=1e-6, ftol=1e-12)
    )
    assert fit.converged, fit.message
    _, grad = objective(fit.alpha, MDP, stats, l2=0.01)
    assert np.max(np.abs(grad)) <= 1e-6
    _, count_gap = objective(fit.alpha, MDP, stats, l2=0.0)  # μ_model − μ_D
    assert np.allclose(count_gap, -0.01 * fit.alpha, atol=1e-6)
    f0, _ = objective(alpha0, MDP, stats, l2=0.01)
    assert fit.objective == pytest.approx(objective(fit.alpha, MDP, stats, l2=0.01)[0])
    assert fit.objective < f0 and fit.n_iter >= 1


def test_strong_l2_pulls_the_fit_to_the_prior() -> None:
    stats = own_stats(np.random.default_rng(6).normal(0.0, 0.5, K))
    prior = np.full(K, 0.3)
    loose = fit_alpha(
        MDP, stats, prior.copy(), prior, IrlConfig(l2=1e-3, max_iter=200, gtol=1e-6, ftol=1e-12)
    )
    tight = fit_alpha(
        MDP, stats, prior.copy(), prior, IrlConfig(l2=1e3, max_iter=200, gtol=1e-6, ftol=1e-12)
    )
    assert np.max(np.abs(tight.alpha - prior)) < 1e-2
    assert np.max(np.abs(loose.alpha - prior)) > 10 * np.max(np.abs(tight.alpha - prior))
