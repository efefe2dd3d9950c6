"""Invariants of the MCE-IRL mathematics on hand-built and small MDPs."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st

from cloud_sync.errors import TrainingError
from cloud_sync.irl.demos import Transitions, demo_stats
from cloud_sync.irl.features import FeatureConfig, make_features
from cloud_sync.irl.mce_irl import (
    CompiledMdp,
    DemoStats,
    feature_expectations,
    objective,
    reward_table,
    soft_value_iteration,
    state_action_visitation,
)
from cloud_sync.irl.mdp import GridConfig, build_transitions, interp_weights, make_grid

SMALL = GridConfig(v_margin_mps=1.0, gap_margin_m=2.0, dv_max_mps=2.0)


def small_mdp() -> CompiledMdp:
    grid = make_grid(SMALL, v_max_mps=4.0, gap_max_m=10.0)
    feats = make_features(grid, FeatureConfig(v_spacing_mps=2.0, gap_spacing_m=4.0), 2.0, 1.0)
    return CompiledMdp.build(grid, feats, build_transitions(grid, SMALL))


MDP = small_mdp()


def toy() -> tuple[sp.csr_matrix, np.ndarray]:
    """3 states, 2 actions: action 0 stays, action 1 moves right (last state absorbs)."""
    P = np.zeros((6, 3))
    for s in range(3):
        P[s * 2 + 0, s] = 1.0
        P[s * 2 + 1, min(s + 1, 2)] = 1.0
    r = np.array([[0.0, -0.5], [0.2, -0.1], [1.0, 0.3]])
    return sp.csr_matrix(P), r


def test_toy_soft_values_match_hand_computation() -> None:
    P, r = toy()
    V, pi = soft_value_iteration(P, r, 2)
    v1 = np.log(np.exp(r).sum(axis=1))
    assert np.allclose(V[1], v1)
    q2 = r + np.array([[v1[0], v1[1]], [v1[1], v1[2]], [v1[2], v1[2]]])
    assert np.allclose(V[2], np.log(np.exp(q2).sum(axis=1)))
    assert np.allclose(pi[1], np.exp(q2 - V[2][:, None]))


def test_toy_visitation_sums_to_horizon_and_follows_policy() -> None:
    P, r = toy()
    H = 4
    _, pi = soft_value_iteration(P, r, H)
    p0 = np.zeros((H, 3))
    p0[H - 1, 0] = 1.0
    d = state_action_visitation(P.T.tocsr(), pi, p0)
    assert d.sum() == pytest.approx(H)
    # state 0 is only reached by staying in it: its time is the sum of survival products
    stay = [pi[h - 1, 0, 0] for h in range(H, 0, -1)]
    expected = sum(float(np.prod(stay[:k])) for k in range(H))
    assert d[0].sum() == pytest.approx(expected)
    assert d[0] / d[0].sum() != pytest.approx(np.array([0.5, 0.5]))


def test_transition_rows_are_distributions() -> None:
    P = MDP.P
    assert P.shape == (MDP.grid.n_states * MDP.grid.n_actions, MDP.grid.n_states)
    assert np.allclose(np.asarray(P.sum(axis=1)).ravel(), 1.0)
    assert P.data.min() > 0.0


def test_transition_mean_follows_eq_1_and_2() -> None:
    """From the grid's interior, E[v'] and E[g'] follow eq. 1-2 (the noise has zero mean)."""
    grid = MDP.grid
    n_v, n_g, n_dv = grid.shape
    iv, ig, idv = 2, 3, n_dv // 2 + 1  # v = 2, g = 6, dv = +1
    a_idx = int(np.flatnonzero(grid.accels_mps2 == 0.5)[0])
    row = ((iv * n_g + ig) * n_dv + idv) * grid.n_actions + a_idx
    p = MDP.P[row].toarray().ravel().reshape(grid.shape)
    ev = float((p.sum(axis=(1, 2)) * grid.v_mps).sum())
    eg = float((p.sum(axis=(0, 2)) * grid.gap_m).sum())
    dt = grid.dt_s
    assert ev == pytest.approx(2.0 + 0.5 * dt, abs=1e-9)
    assert eg == pytest.approx(6.0 + 1.0 * dt - 0.5 * 0.5 * dt**2, abs=1e-9)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 10_000), horizon=st.integers(1, 6))
def test_policy_rows_sum_to_one_and_visitation_sums_to_horizon(seed: int, horizon: int) -> None:
    rng = np.random.default_rng(seed)
    alpha = rng.normal(0, 2.0, MDP.features.n_features)
    _, pi = soft_value_iteration(MDP.P, reward_table(MDP, alpha), horizon)
    assert np.allclose(pi.sum(axis=2), 1.0)
    p0 = np.zeros((horizon, MDP.grid.n_states))
    p0[horizon - 1] = rng.dirichlet(np.ones(MDP.grid.n_states))
    d = state_action_visitation(MDP.PT, pi, p0)
    assert d.sum() == pytest.approx(horizon)
    assert d.min() >= 0.0


def test_mixed_segment_lengths_visitation_is_mean_length() -> None:
    alpha = np.zeros(MDP.features.n_features)
    _, pi = soft_value_iteration(MDP.P, reward_table(MDP, alpha), 5)
    p0 = np.zeros((5, MDP.grid.n_states))
    p0[4, 10] = 0.25  # a 5-step segment
    p0[1, 20] = 0.75  # 2-step segments
    d = state_action_visitation(MDP.PT, pi, p0)
    assert d.sum() == pytest.approx(0.25 * 5 + 0.75 * 2)


def _model_stats(alpha: np.ndarray, horizon: int, seed: int) -> DemoStats:
    rng = np.random.default_rng(seed)
    p0 = np.zeros((horizon, MDP.grid.n_states))
    p0[horizon - 1] = rng.dirichlet(np.ones(MDP.grid.n_states))
    _, pi = soft_value_iteration(MDP.P, reward_table(MDP, alpha), horizon)
    mu = feature_expectations(MDP, state_action_visitation(MDP.PT, pi, p0))
    return DemoStats(mu=mu, p0=p0, n_segments=1)


def test_gradient_zero_when_demos_are_the_models_own_expectation() -> None:
    rng = np.random.default_rng(3)
    alpha = rng.normal(0, 1.0, MDP.features.n_features)
    stats = _model_stats(alpha, 4, seed=1)
    _, grad = objective(alpha, MDP, stats, l2=0.0)
    assert np.max(np.abs(grad)) < 1e-9
    # and not zero elsewhere
    _, grad_other = objective(alpha + 0.5, MDP, stats, l2=0.0)
    assert np.max(np.abs(grad_other)) > 1e-3


def test_gradient_matches_finite_differences() -> None:
    rng = np.random.default_rng(5)
    alpha = rng.normal(0, 0.5, MDP.features.n_features)
    stats = _model_stats(rng.normal(0, 0.5, MDP.features.n_features), 3, seed=2)
    f0, grad = objective(alpha, MDP, stats, l2=0.1)
    for k in rng.choice(alpha.size, 6, replace=False):
        e = np.zeros_like(alpha)
        e[k] = 1e-6
        fp, _ = objective(alpha + e, MDP, stats, l2=0.1)
        fm, _ = objective(alpha - e, MDP, stats, l2=0.1)
        assert (fp - fm) / 2e-6 == pytest.approx(grad[k], rel=1e-4, abs=1e-7)
    assert np.isfinite(f0)


def test_interp_weights_reconstruct_points() -> None:
    axis = np.arange(0.0, 10.0, 2.0)
    x = np.array([0.0, 1.0, 3.3, 8.0, 9.5, -1.0])
    i0, i1, w1 = interp_weights(axis, x)
    recon = (1 - w1) * axis[i0] + w1 * axis[i1]
    assert np.allclose(recon, np.clip(x, 0.0, 8.0))


def test_bad_inputs_raise_training_error() -> None:
    with pytest.raises(TrainingError):
        soft_value_iteration(MDP.P, np.zeros((MDP.grid.n_states, MDP.grid.n_actions)), 0)
    with pytest.raises(TrainingError, match="alpha has shape"):
        reward_table(MDP, np.zeros(3))
    with pytest.raises(TrainingError):
        GridConfig(dt_s=0.0)


def test_gap_preference_counts_in_steady_following_only() -> None:
    """κ(dv): the (v, g) reward and its counts are weighted by exp(−½(dv/w)²), in the model
    (reward, expected counts) and in the demonstrations alike; w = 0 weights nothing."""
    grid = MDP.grid
    n_v, n_g, n_dv = grid.shape
    w = 0.5

    def mdp_of(width: float) -> CompiledMdp:
        config = FeatureConfig(v_spacing_mps=2.0, gap_spacing_m=4.0, dv_width_mps=width)
        return CompiledMdp.build(grid, make_features(grid, config), MDP.P)

    mdp, flat = mdp_of(w), mdp_of(0.0)
    feats = mdp.features
    kappa = np.exp(-0.5 * (grid.dv_mps / w) ** 2)
    assert np.allclose(feats.k_dv, kappa) and flat.features.k_dv.tolist() == [1.0] * n_dv
    alpha = np.random.default_rng(7).normal(0.0, 1.0, feats.n_features)
    alpha[-2:] = 0.0  # the (v, g) part alone
    r = reward_table(mdp, alpha)[:, 0].reshape(grid.shape)
    r_vg = feats.reward_vg(alpha, grid.v_mps, grid.gap_m)
    assert np.allclose(r, r_vg[:, :, None] * kappa[None, None, :])
    # one unit of visitation at (v, g) = grid point (2, 3) with dv = +1 m/s
    idv = int(np.flatnonzero(grid.dv_mps == 1.0)[0])
    d_sa = np.zeros((grid.n_states, grid.n_actions))
    d_sa[(2 * n_g + 3) * n_dv + idv, 0] = 1.0
    model = feature_expectations(mdp, d_sa)
    plain = feature_expectations(flat, d_sa)
    assert np.allclose(model[:-2], kappa[idv] * plain[:-2]) and kappa[idv] < 0.2
    # the same pair as a demonstration counts the same
    tr = Transitions(
        v_mps=grid.v_mps[2:3],
        gap_m=grid.gap_m[3:4],
        dv_mps=np.array([1.0]),
        a_mps2=grid.accels_mps2[:1],
        pos=np.array([1]),
        seg_len=np.array([1]),
        weight=np.array([1.0]),
    )
    assert np.allclose(demo_stats(mdp, tr, 1).mu, model)
