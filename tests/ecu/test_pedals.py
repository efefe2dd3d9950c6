"""One pedal, one value: the 0..1 pedal fractions come from the DBC's full scale."""

from __future__ import annotations

import math

import pytest

from dbc.codec import load_codec
from dbc.vocab import FormatError
from dbc.vocab.pedals import PedalScale


def test_full_scale_is_the_dbc_maximum_of_each_pedal_field() -> None:
    scale = PedalScale.from_codec(load_codec())
    assert (scale.accel_full_pct, scale.brake_full_bar) == (100.0, 250.0)


def test_fractions_are_clipped_and_nan_passes() -> None:
    scale = PedalScale(accel_full_pct=100.0, brake_full_bar=250.0)
    assert scale.brake(125.0) == 0.5
    assert scale.brake(400.0) == 1.0 and scale.brake(-3.0) == 0.0
    assert scale.accel(25.0) == 0.25
    assert math.isnan(scale.brake(math.nan))


@pytest.mark.parametrize("bad", [0.0, -1.0, math.inf, math.nan])
def test_a_full_scale_must_be_positive_and_finite(bad: float) -> None:
    with pytest.raises(FormatError, match="brake_full_bar"):
        PedalScale(accel_full_pct=100.0, brake_full_bar=bad)
