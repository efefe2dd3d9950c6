"""Bootstrap intervals, paired tests and Holm's adjustment on hand-made data."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pacc.study.stats import bootstrap_ci, cell_means, driver_means, holm, paired_comparison
from sim_bus.errors import SimError


def test_bootstrap_interval_covers_the_mean_and_narrows() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(10.0, 2.0, 30)
    lo, hi = bootstrap_ci(x, np.random.default_rng(1))
    assert lo < x.mean() < hi
    # the standard error of the mean is 2/sqrt(30) = 0.37: a 95 % interval about 1.4 wide
    assert 0.9 < hi - lo < 2.0
    big = rng.normal(10.0, 2.0, 300)
    lo2, hi2 = bootstrap_ci(big, np.random.default_rng(1))
    assert hi2 - lo2 < (hi - lo) / 2.0
    assert all(math.isnan(v) for v in bootstrap_ci(np.array([1.0]), rng))


def test_paired_comparison_sees_a_shift_and_counts() -> None:
    rng = np.random.default_rng(2)
    a = rng.normal(20.0, 5.0, 40)
    b = a - 2.0 + rng.normal(0.0, 1.0, 40)  # b lower by 2 on the same drivers
    res = paired_comparison(a, b, np.random.default_rng(0))
    assert res.mean_diff == pytest.approx(float(np.mean(b - a)))
    assert res.ci[0] < res.mean_diff < res.ci[1] < 0.0
    assert res.p_value < 1e-4 and res.better > 30 and res.better + res.worse + res.ties == 40
    same = paired_comparison(a, a.copy(), np.random.default_rng(0))
    assert same.p_value == 1.0 and same.ties == 40
    with pytest.raises(SimError):
        paired_comparison(a, a[:3], np.random.default_rng(0))


def test_holm() -> None:
    # sorted 0.01, 0.02, 0.04 -> 3*0.01, max(0.03, 2*0.02), max(0.04, 1*0.04)
    assert holm([0.04, 0.01, 0.02]) == pytest.approx([0.04, 0.03, 0.04])
    assert holm([0.5, 0.9]) == pytest.approx([1.0, 1.0])


def test_a_drive_whose_acc_was_never_on_is_left_out() -> None:
    nan = math.nan
    rows = [
        {"driver": "a", "controller": "irl", "poi_pct": 4.0, "nim_per_min": 1.0},
        {"driver": "a", "controller": "irl", "poi_pct": nan, "nim_per_min": nan},
        {"driver": "b", "controller": "irl", "poi_pct": nan, "nim_per_min": nan},
    ]
    assert driver_means(rows, "poi_pct") == {"irl": {"a": 4.0}}
    assert cell_means([dict(r, scenario="B") for r in rows]) == {("a", "B", "irl"): (4.0, 1.0)}
