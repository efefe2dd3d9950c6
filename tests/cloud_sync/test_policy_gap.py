"""The gap the learned policy keeps: the zero crossing of its drift, on known drifts and rewards."""

from __future__ import annotations

import numpy as np
import pytest

from cloud_sync.irl.features import FeatureConfig, make_features
from cloud_sync.irl.mce_irl import CompiledMdp, steady_drift, steady_gaps
from cloud_sync.irl.mdp import GridConfig, build_transitions, make_grid

GRID_V = np.arange(0.0, 21.0, 1.0)
GRID_G = np.arange(0.0, 62.0, 2.0)
AXIS = np.arange(0.0, 20.01, 0.5)


def wide(lo: float = 0.0, hi: float = 60.0) -> tuple[np.ndarray, np.ndarray]:
    return np.full(AXIS.size, lo), np.full(AXIS.size, hi)


def test_linear_drift_gives_its_zero_exactly() -> None:
    want = 4.0 + 1.5 * GRID_V  # on and between the grid's speeds and gaps
    drift = 0.1 * (GRID_G[None, :] - want[:, None])
    value = np.zeros_like(drift)
    got = steady_gaps(drift, value, GRID_V, GRID_G, AXIS, wide())
    assert np.allclose(got, 4.0 + 1.5 * AXIS, atol=1e-9)


def test_of_several_stable_gaps_the_one_of_highest_value() -> None:
    # braking below 10 m and 40 m, accelerating above: two gaps the policy returns to
    drift = np.tile(np.sin(2.0 * np.pi * (GRID_G - 10.0) / 30.0), (GRID_V.size, 1))
    rising = np.tile(GRID_G, (GRID_V.size, 1))
    assert np.allclose(steady_gaps(drift, rising, GRID_V, GRID_G, AXIS, wide()), 40.0)
    assert np.allclose(steady_gaps(drift, -rising, GRID_V, GRID_G, AXIS, wide()), 10.0)
    # a gap outside the demonstrated range is not taken
    assert np.allclose(steady_gaps(drift, rising, GRID_V, GRID_G, AXIS, wide(0.0, 30.0)), 10.0)


def test_without_a_stable_gap_in_range_the_gap_goes_to_an_edge() -> None:
    ones = np.ones((GRID_V.size, GRID_G.size))
    lo_hi = wide(12.0, 30.0)
    # accelerating at every gap: the gap closes to the lower edge; braking: it opens
    assert np.allclose(steady_gaps(ones, ones, GRID_V, GRID_G, AXIS, lo_hi), 12.0)
    assert np.allclose(steady_gaps(-ones, ones, GRID_V, GRID_G, AXIS, lo_hi), 30.0)
    # no demonstration near a speed, or a speed above the grid: no gap (NaN)
    holes = (np.where(AXIS < 5.0, np.nan, 12.0), np.where(AXIS < 5.0, np.nan, 30.0))
    got = steady_gaps(ones, ones, GRID_V, GRID_G, AXIS, holes)
    assert np.isnan(got[AXIS < 5.0]).all() and np.allclose(got[AXIS >= 5.0], 12.0)
    above = steady_gaps(ones, ones, GRID_V[:11], GRID_G, AXIS, lo_hi)
    assert np.isnan(above[AXIS > 10.0]).all() and np.isfinite(above[AXIS <= 10.0]).all()


def test_policy_of_a_known_reward_keeps_its_preferred_gap() -> None:
    cfg = GridConfig(dv_max_mps=3.0)
    grid = make_grid(cfg, v_max_mps=12.0, gap_max_m=40.0)
    config = FeatureConfig(v_spacing_mps=2.0, gap_spacing_m=2.0, dv_width_mps=0.0)
    feats = make_features(grid, config)
    mdp = CompiledMdp.build(grid, feats, build_transitions(grid, cfg))
    # a (v, g) reward peaked at 20 m at every speed and relative speed (κ off), plus the
    # comfort terms
    rbf = -0.02 * (feats.gap_centres_m - 20.0) ** 2
    A = np.tile(rbf, (feats.v_centres_mps.size, 1))
    alpha = np.concatenate([A.ravel(), [1.0, 1.0]])
    drift, value = steady_drift(mdp, alpha, 5)
    assert drift.shape == value.shape == (grid.v_mps.size, grid.gap_m.size)
    near = np.abs(grid.gap_m - 20.0) <= 2.0
    inner = drift[grid.v_mps <= 12.0]  # away from the clipped top of the speed axis
    # below the preferred gap the policy brakes, above it it accelerates (away from the
    # clipped edges of the gap axis)
    assert (inner[:, (grid.gap_m >= 4.0) & (grid.gap_m <= 14.0)] < -0.5).all()
    assert (inner[:, (grid.gap_m >= 26.0) & (grid.gap_m <= 40.0)] > 0.5).all()
    assert np.all(np.abs(inner[:, near]) < 1.0)
    axis = np.arange(0.0, 12.01, 0.5)
    support = (np.full(axis.size, 0.0), np.full(axis.size, 50.0))
    got = steady_gaps(drift, value, grid.v_mps, grid.gap_m, axis, support)
    assert got == pytest.approx(np.full(axis.size, 20.0), abs=0.5)
