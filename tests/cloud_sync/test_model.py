"""The reward model: a fresh one from the data, or the one an earlier table carries."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from cloud_sync.errors import TrainingError
from cloud_sync.irl.demos import Samples
from cloud_sync.irl.features import FeatureConfig, gap_basis
from cloud_sync.irl.mdp import GridConfig
from cloud_sync.irl.trainer import (
    METHOD,
    RewardModel,
    compile_model,
    fresh_model,
    model_of_table,
    reference_line,
)
from dbc.vocab.dgpt import Dgpt, predefined


def line_samples(n: int = 400) -> Samples:
    """Steady following on the line g = 3 m + 1.4 s·v between 5 and 25 m/s."""
    v = np.linspace(5.0, 25.0, n)
    return Samples(
        v_mps=v,
        gap_m=3.0 + 1.4 * v,
        dv_mps=np.zeros(n),
        a_mps2=np.zeros(n),
        dt_s=np.full(n, 0.1),
    )


def carrying(model: RewardModel, alpha: np.ndarray) -> Dgpt:
    """A table whose metadata carry ``model`` and ``alpha`` as a learned table's do."""
    meta = {
        "method": METHOD,
        "grid": model.grid.spec(),
        "features": model.features.spec(),
        "alpha": [float(a) for a in alpha],
    }
    return replace(predefined(1.5, driver_id="d"), source="irl", meta=meta)


def test_reference_line_through_steady_samples() -> None:
    s = line_samples()
    c0, c1 = reference_line(s.v_mps, s.gap_m, s.dv_mps, s.a_mps2)
    assert c0 == pytest.approx(3.0) and c1 == pytest.approx(1.4)
    # the closing-in samples are left out while 20 steady ones remain
    dv = np.where(np.arange(s.v_mps.size) % 2 == 0, 0.0, 3.0)
    off = np.where(dv == 0.0, s.gap_m, 0.0)
    assert reference_line(s.v_mps, off, dv, s.a_mps2) == pytest.approx((3.0, 1.4))
    assert reference_line(np.full(5, 10.0), np.full(5, 20.0), np.zeros(5), np.zeros(5)) == (
        20.0,
        0.0,
    )


def test_fresh_model_spans_the_data_and_has_no_prior() -> None:
    model = fresh_model(line_samples(), GridConfig(), FeatureConfig())
    assert model.prior_alpha is None
    assert model.grid.v_mps[-1] >= 25.0 and model.grid.gap_m[-1] >= 3.0 + 1.4 * 25.0
    # the default basis is fitted to nothing: time-gap centres fixed at 0 ... 6 s
    feats = model.features
    assert feats.ref_c0_m == 0.0 and feats.ref_c1_s == 0.0
    assert feats.time_gap_floor_mps == 5.0
    assert feats.gap_centres_m[0] == 0.0 and feats.gap_centres_m[-1] == pytest.approx(6.0)
    other = fresh_model(line_samples(), GridConfig(), FeatureConfig())
    shifted = replace(line_samples(), gap_m=line_samples().gap_m + 10.0)
    assert np.array_equal(fresh_model(shifted, GridConfig(), FeatureConfig()).features.Bv, feats.Bv)
    assert np.array_equal(other.features.gap_centres_m, feats.gap_centres_m)


def test_offset_basis_is_sheared_along_the_fitted_line() -> None:
    model = fresh_model(line_samples(), GridConfig(), FeatureConfig(gap_basis="offset"))
    assert model.features.ref_c0_m == pytest.approx(3.0)
    assert model.features.ref_c1_s == pytest.approx(1.4)
    assert model.features.time_gap_floor_mps == 0.0


def test_time_gap_basis_peaks_on_its_time_gap() -> None:
    feats = fresh_model(line_samples(), GridConfig(), FeatureConfig()).features
    centres = feats.gap_centres_m
    # at 20 m/s a 30 m gap is 1.5 s: the basis function centred on 1.5 s is the largest
    bg = gap_basis(np.array([20.0, 2.0]), np.array([30.0, 7.5]), centres, 0.25, 0.0, 0.0, 5.0)
    assert centres[int(np.argmax(bg[0, 0]))] == pytest.approx(1.5)
    # below the 5 m/s floor the gap is scaled by the floor: 7.5 m at 2 m/s reads as 1.5 s
    assert centres[int(np.argmax(bg[1, 1]))] == pytest.approx(1.5)


def test_bad_feature_config_refused() -> None:
    with pytest.raises(TrainingError, match="gap_basis"):
        FeatureConfig(gap_basis="sheared")
    with pytest.raises(TrainingError, match="time_gap_floor_mps"):
        FeatureConfig(time_gap_floor_mps=0.0)


def test_model_of_a_table_round_trips() -> None:
    model = fresh_model(line_samples(), GridConfig(), FeatureConfig())
    alpha = np.linspace(-1.0, 1.0, model.features.n_features)
    back = model_of_table(carrying(model, alpha))
    assert back is not None and back.prior_alpha is not None
    assert np.array_equal(back.prior_alpha, alpha)
    assert np.array_equal(back.grid.v_mps, model.grid.v_mps)
    assert np.array_equal(back.grid.gap_m, model.grid.gap_m)
    assert np.allclose(back.features.Bg, model.features.Bg)
    mdp = compile_model(back, GridConfig())
    assert mdp.P.shape == (back.grid.n_states * back.grid.n_actions, back.grid.n_states)


def test_tables_of_other_kinds_carry_no_model() -> None:
    assert model_of_table(None) is None
    assert model_of_table(predefined(1.5)) is None
    empirical = replace(predefined(1.5), meta={"method": "empirical"})
    assert model_of_table(empirical) is None


def test_unusable_model_metadata_is_refused() -> None:
    model = fresh_model(line_samples(), GridConfig(), FeatureConfig())
    table = carrying(model, np.zeros(model.features.n_features))
    with pytest.raises(TrainingError, match="alpha does not match"):
        model_of_table(replace(table, meta={**table.meta, "alpha": [0.0, 1.0]}))
    with pytest.raises(TrainingError, match="alpha does not match"):
        model_of_table(
            replace(table, meta={**table.meta, "alpha": [np.nan] * len(table.meta["alpha"])})
        )
    no_grid = {k: v for k, v in table.meta.items() if k != "grid"}
    with pytest.raises(TrainingError, match="unusable IRL metadata"):
        model_of_table(replace(table, meta=no_grid))
