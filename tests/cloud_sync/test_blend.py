"""Evidence per speed bin and the blend of new evidence into an earlier table."""

from __future__ import annotations

import numpy as np
import pytest

from cloud_sync.errors import DemoError
from cloud_sync.irl.blend import blend, coverage_s, covered_ranges, evidence
from cloud_sync.irl.demos import Samples
from dbc.vocab.dgpt import SafetyBounds, speed_axis

AXIS = speed_axis(0.5)


def samples_at(v_mps: float, seconds: float, gap_m: float = 30.0) -> Samples:
    """``seconds`` of 10 Hz samples at one speed and gap."""
    n = round(seconds * 10)
    return Samples(
        v_mps=np.full(n, v_mps),
        gap_m=np.full(n, gap_m),
        dv_mps=np.zeros(n),
        a_mps2=np.zeros(n),
        dt_s=np.full(n, 0.1),
    )


def test_coverage_counts_seconds_in_window() -> None:
    v = np.array([10.0, 10.2, 10.4, 20.0])
    cov = coverage_s(AXIS, v, np.full(4, 0.1))
    assert cov[20] == pytest.approx(0.3)  # 10 m/s: all three
    assert cov[21] == pytest.approx(0.3)  # 10.5 m/s: 10.0..11.0
    assert cov[40] == pytest.approx(0.1)
    assert cov[0] == 0.0
    assert coverage_s(AXIS, v, np.full(4, 0.1), 2.0)[24] == pytest.approx(0.3)  # 12 m/s


def test_fresh_evidence_covers_the_demonstrated_speeds_only() -> None:
    ev = evidence(
        AXIS,
        samples_at(10.0, 20.0),
        min_coverage_s=10.0,
        previous_m=None,
        window_mps=2.0,
        support_ratio=0.3,
    )
    assert list(AXIS[ev.covered]) == [9.5, 10.0, 10.5]
    assert ev.coverage_s[20] == pytest.approx(20.0)
    assert ev.previous_m is None and ev.window_s is None
    lo, hi = ev.support
    assert lo[20] == pytest.approx(28.0) and hi[20] == pytest.approx(32.0)  # ±2 m margin
    assert np.isnan(lo[0]) and np.isnan(hi[80])


def test_continuing_widens_coverage_and_support_around_the_earlier_table() -> None:
    previous = 4.0 + 1.5 * AXIS
    ev = evidence(
        AXIS,
        samples_at(10.0, 20.0),
        min_coverage_s=10.0,
        previous_m=previous,
        window_mps=2.0,
        support_ratio=0.3,
    )
    assert list(AXIS[ev.covered]) == [8.0 + 0.5 * k for k in range(9)]  # 8..12 m/s
    assert ev.coverage_s[20] == pytest.approx(20.0)  # still the ±0.5 m/s coverage
    lo, hi = ev.support
    assert lo[0] == pytest.approx(4.0 * 0.7) and hi[80] == pytest.approx(previous[80] * 1.3)
    assert lo[20] == pytest.approx(min(28.0, previous[20] * 0.7))


def test_no_evidence_above_standstill_is_refused() -> None:
    with pytest.raises(DemoError, match="no speed bin above standstill"):
        evidence(
            AXIS,
            samples_at(0.0, 100.0),
            min_coverage_s=10.0,
            previous_m=None,
            window_mps=2.0,
            support_ratio=0.3,
        )


def test_blend_weights_new_evidence_and_keeps_untouched_bins_exactly() -> None:
    previous = 4.0 + 1.5 * AXIS
    ev = evidence(
        AXIS,
        samples_at(10.0, 10.0),
        min_coverage_s=1.0,
        previous_m=previous,
        window_mps=2.0,
        support_ratio=0.3,
    )
    new = 4.0 + 1.0 * AXIS
    gap, touched = blend(AXIS, new, ev, half_s=10.0, bounds=SafetyBounds())
    assert list(AXIS[touched]) == [8.0 + 0.5 * k for k in range(9)]
    assert np.array_equal(gap[~touched], previous[~touched])
    # 10 s of new evidence against a half-weight of 10 s: half way
    assert gap[20] == pytest.approx(0.5 * new[20] + 0.5 * previous[20])


def test_blend_without_an_earlier_table_changes_nothing() -> None:
    ev = evidence(
        AXIS,
        samples_at(10.0, 20.0),
        min_coverage_s=10.0,
        previous_m=None,
        window_mps=2.0,
        support_ratio=0.3,
    )
    gap = 4.0 + 1.0 * AXIS
    out, covered = blend(AXIS, gap, ev, half_s=10.0, bounds=SafetyBounds())
    assert out is gap and covered is ev.covered


def test_blend_result_is_clamped_to_the_bounds() -> None:
    b = SafetyBounds()
    previous = b.upper_m(AXIS)
    ev = evidence(
        AXIS,
        samples_at(10.0, 100.0),
        min_coverage_s=1.0,
        previous_m=previous,
        window_mps=2.0,
        support_ratio=0.3,
    )
    gap, _ = blend(AXIS, previous + 50.0, ev, half_s=1.0, bounds=b)
    assert np.all(gap <= b.upper_m(AXIS) + 1e-9)


def test_covered_ranges() -> None:
    mask = np.zeros(AXIS.size, dtype=bool)
    mask[2:5] = True
    mask[80] = True
    assert covered_ranges(AXIS, mask) == [[1.0, 2.0], [40.0, 40.0]]
    assert covered_ranges(AXIS, np.zeros(AXIS.size, dtype=bool)) == []
