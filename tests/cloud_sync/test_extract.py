"""DGPT extraction: support, continuation, low-pass, baseline, bounds."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cloud_sync.irl.extract import (
    PRIOR_HEADWAY_S,
    continue_time_gap,
    finish_table,
    gap_support,
    lowpass,
    outside_coverage,
    steady_state_gaps,
)
from dbc.vocab.dgpt import SafetyBounds, speed_axis

AXIS = speed_axis(0.5)


def test_time_gap_continuation_holds_edge_headway() -> None:
    gap = 4.0 + 1.5 * AXIS
    covered = (AXIS >= 10) & (AXIS <= 20)
    out = continue_time_gap(AXIS, np.where(covered, gap, 0.0), covered, 4.0)
    assert np.allclose(out, gap)  # a constant time gap continues exactly
    fallback = np.full(AXIS.size, 33.0)
    out2 = continue_time_gap(AXIS, gap, covered, 4.0, fallback)
    assert np.all(out2[~covered] == 33.0) and np.allclose(out2[covered], gap[covered])


def test_slow_evidence_is_not_continued_to_motorway_speeds() -> None:
    """a table whose data lie below 5 m/s (stop-and-go) states the prior time gap
    above them, not the time gap of its slow data (here 3 s) continued to 30 m/s; a table
    with evidence from 8 m/s up continues its own time gap; the meta names the rule."""
    covered = AXIS <= 5.0
    gap = np.where(covered, 4.0 + 3.0 * AXIS, 0.0)
    out = continue_time_gap(AXIS, gap, covered, 4.0)
    assert np.allclose(out[covered], gap[covered])
    assert out[60] == pytest.approx(4.0 + PRIOR_HEADWAY_S * 30.0)
    assert "prior time gap" in outside_coverage(AXIS, covered)
    wide = AXIS <= 12.0
    out = continue_time_gap(AXIS, np.where(wide, 4.0 + 2.2 * AXIS, 0.0), wide, 4.0)
    assert out[60] == pytest.approx(4.0 + 2.2 * 30.0)
    assert "held constant" in outside_coverage(AXIS, wide)
    assert outside_coverage(AXIS, np.ones(AXIS.size, dtype=bool)).startswith("none")


def test_lowpass_keeps_lines_and_damps_noise() -> None:
    line = 3.0 + 1.2 * AXIS
    assert np.allclose(lowpass(line), line, atol=1e-6)
    noisy = line + np.random.default_rng(0).normal(0, 2.0, AXIS.size)
    assert np.std(lowpass(noisy) - line) < 0.6 * np.std(noisy - line)


@settings(max_examples=25, deadline=None)
@given(
    gaps=st.lists(st.floats(-50, 500, allow_nan=False), min_size=AXIS.size, max_size=AXIS.size),
    lo=st.integers(0, 70),
)
def test_finish_table_always_within_bounds(gaps: list[float], lo: int) -> None:
    b = SafetyBounds()
    covered = np.zeros(AXIS.size, dtype=bool)
    covered[lo : lo + 10] = True
    out = finish_table(AXIS, np.array(gaps), covered, b)
    assert np.all(out >= b.lower_m(AXIS) - 1e-9) and np.all(out <= b.upper_m(AXIS) + 1e-9)
    assert np.all(np.isfinite(out))


def test_steady_state_baseline_uses_only_steady_samples() -> None:
    v = np.array([15.0, 15.1, 15.2, 15.0])
    g = np.array([30.0, 31.0, 32.0, 80.0])
    dv = np.array([0.0, 0.1, -0.2, 3.0])  # the last one is closing in: not steady
    gap, count = steady_state_gaps(AXIS, v, g, dv, np.zeros(4))
    assert gap[30] == pytest.approx(31.0) and count[30] == 3
    assert np.isnan(gap[0]) and count[0] == 0


def test_support() -> None:
    v = np.linspace(5, 25, 400)
    g = 3.0 + 1.4 * v
    lo, hi = gap_support(AXIS, v, g, margin_m=0.0)
    assert np.isnan(lo[0]) and lo[30] == pytest.approx(3.0 + 1.4 * 14.0, abs=0.1)
    assert hi[30] == pytest.approx(3.0 + 1.4 * 16.0, abs=0.1)
