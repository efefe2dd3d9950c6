"""The reward model a table is learned in: the MDP's grid, the reward basis and, from an earlier
table, its weights α (the fit's start and prior).

:func:`reference_line` (``g ≈ c0 + c1·v``, the offset basis's line), :func:`fresh_model` (a grid
spanning the demonstrations), :func:`model_of_table` (an earlier :data:`METHOD` table's model,
else None) and :func:`compile_model` (with sparse transitions, ready for IRL).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from cloud_sync.errors import TrainingError
from cloud_sync.irl.demos import Samples
from cloud_sync.irl.features import (
    FeatureConfig,
    Features,
    features_from_spec,
    make_features,
    make_time_gap_features,
)
from cloud_sync.irl.mce_irl import CompiledMdp
from cloud_sync.irl.mdp import Grid, GridConfig, build_transitions, grid_from_spec, make_grid
from dbc.vocab.dgpt import Dgpt

__all__ = [
    "METHOD",
    "RewardModel",
    "reference_line",
    "fresh_model",
    "model_of_table",
    "compile_model",
]

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
    samples: Samples, grid_config: GridConfig, feature_config: FeatureConfig
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
    """The model's MDP with transitions under ``grid_config``'s noise (lead, speed)."""
    return CompiledMdp.build(model.grid, model.features, build_transitions(model.grid, grid_config))
