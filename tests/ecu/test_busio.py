"""The transmit mapping of the ECU's outputs: a non-finite request never goes out as the floor."""

from __future__ import annotations

import math

import pytest

from dbc.codec import load_codec
from ecu.busio import OutputLimits, command_values
from tests.ecu.test_safety import outputs

LIMITS = OutputLimits.from_codec(load_codec())


@pytest.mark.parametrize("bad", [math.nan, -math.inf, math.inf])
def test_a_non_finite_request_goes_out_as_zero_not_the_floor(bad: float) -> None:
    assert LIMITS.accel_lo_mps2 < -3.5  # the DBC's floor is harsher than the envelope
    assert command_values(outputs(bad), LIMITS)["accel_request_mps2"] == 0.0


def test_a_non_finite_request_outside_a_narrow_range_goes_out_at_its_nearest_edge() -> None:
    narrow = OutputLimits(accel_lo_mps2=0.5, accel_hi_mps2=1.0, gap_hi_m=100.0, set_speed_hi_mps=40)
    assert command_values(outputs(math.nan), narrow)["accel_request_mps2"] == 0.5


@pytest.mark.parametrize(("req", "sent"), [(-20.0, None), (1.25, 1.25), (50.0, None)])
def test_finite_requests_are_clipped_to_the_frame(req: float, sent: float | None) -> None:
    lo, hi = LIMITS.accel_lo_mps2, LIMITS.accel_hi_mps2
    want = sent if sent is not None else (lo if req < lo else hi)
    assert command_values(outputs(req), LIMITS)["accel_request_mps2"] == want
