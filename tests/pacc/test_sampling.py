"""The manual recorder's keep rule (dbc.vocab.sampling), shared by the ECU's recorder and
``pacc demos extract``: a cycle is kept ``period_s`` less half a cycle after the last kept."""

from __future__ import annotations

import math

import pytest

from dbc.vocab.sampling import PERIOD_EPS_S, keep_interval_s, keep_sample


@pytest.mark.parametrize(
    ("dt", "cycle", "kept"),
    [
        (0.0899, 0.02, False),
        (0.0901, 0.02, True),  # half a 20-ms cycle early
        (0.0999, 0.02, True),
        (0.12, 0.02, True),
        (0.0999, 0.0, False),  # no cycle: 1 µs of round-off only
        (0.1 - PERIOD_EPS_S, 0.0, True),
        (0.1, 0.0, True),
    ],
)
def test_a_cycle_is_kept_a_period_less_half_a_cycle_after_the_last(
    dt: float, cycle: float, kept: bool
) -> None:
    assert keep_sample(12.5 + dt, 12.5, 0.1, cycle) is kept


def test_the_first_cycle_is_always_kept_and_the_interval_is_the_rules() -> None:
    assert keep_sample(0.0, -math.inf, 0.1, 0.02)
    assert keep_interval_s(0.1, 0.02) == pytest.approx(0.09)
    assert keep_interval_s(0.1, 0.0) == 0.1 - PERIOD_EPS_S
