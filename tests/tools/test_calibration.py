"""The calibration tool: steady time gaps per speed band, ours against the real human pairs."""

from __future__ import annotations

import numpy as np
import pytest

from sim_bus.dataset import load_human_pairs
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.lead.profile import LeadProfile
from sim_bus.lead.scenarios import canonical_profiles, shorten
from sim_bus.manual import manual_trip
from sim_bus.population import draw_population
from tools import calibration
from tools.calibration import headway_by_band


def _headway_by_band(v: np.ndarray, gap: np.ndarray, v_lead: np.ndarray) -> list[float]:
    """The median steady time gaps of the bands with enough data (tools.calibration)."""
    return [x for x in headway_by_band(v, gap, v_lead) if x is not None]


def test_headway_by_band_hand_counted() -> None:
    v = np.concatenate([np.full(100, 12.0), np.full(99, 17.0), np.full(150, 22.0)])
    gap = np.concatenate([np.full(100, 24.0), np.full(99, 34.0), np.full(150, 44.0)])
    v_lead = v.copy()
    v_lead[200:] += 1.0  # not steady: |v_lead - v| >= 0.5
    v_lead[200:260] = v[200:260]  # 60 steady samples: fewer than MIN_SAMPLES
    assert headway_by_band(v, gap, v_lead) == [2.0, None, None, None]  # 99 < 100 samples too
    v_lead[200:300] = v[200:300]
    assert headway_by_band(v, gap, v_lead) == [2.0, None, 2.0, None]


@pytest.mark.slow
def test_calibration_against_real_human_pairs() -> None:
    """Our drivers, following the real leaders by hand, keep human-like headways.

    Real pairs: median time gaps 1.4-3.4 s per 5 m/s band. Every built-in driver's band
    medians must lie within the range the real followers span (widened by 0.2 s), and the
    drivers together must span most of it.
    """
    pairs = load_human_pairs()
    real: list[float] = []
    for p in pairs:
        real += _headway_by_band(p.v_follower_mps, p.gap_m, p.v_leader_mps)
    lo, hi = min(real), max(real)
    ours: list[float] = []
    for d in BUILTIN_DRIVERS.values():
        for p in pairs[:2] + pairs[4:5]:
            n = len(p.v_leader_mps)
            prof = LeadProfile(p.pair_id, np.arange(n) * 0.1, p.v_leader_mps)
            trip = manual_trip(d, shorten(prof, 600.0), seed=0)
            ours += _headway_by_band(trip.v_mps, trip.gap_m, trip.v_lead_mps)
    assert lo - 0.2 <= min(ours) and max(ours) <= hi + 0.2
    assert max(ours) - min(ours) > 0.6 * (hi - lo)


def test_main_refuses_a_negative_seed(capsys: pytest.CaptureFixture[str]) -> None:
    assert calibration.main(["--seed", "-3"]) == 2
    assert "--seed must be >= 0" in capsys.readouterr().out


def test_averages_and_held_out_kinds() -> None:
    rows = [
        {"controller": "irl", "poi_pct": 10.0, "nim_per_min": 4.0},
        {"controller": "irl", "poi_pct": 20.0, "nim_per_min": 6.0},
        {"controller": "irl+oa", "poi_pct": 5.0, "nim_per_min": 2.0},
    ]
    assert calibration.averages(rows).splitlines() == [
        "irl            PoI  15.0 %  NIM  5.00 /min",
        "irl+oa         PoI   5.0 %  NIM  2.00 /min",
    ]
    heads = {d.driver_id: d.headway_s for d in calibration.HELD_OUT_KINDS}
    assert list(heads) == ["nonmono", "slowpress", "brief"]
    assert heads["nonmono"][1] > heads["nonmono"][2] < heads["nonmono"][3]  # dips and rises


def test_a_manual_view_drives_by_hand_exactly_as_its_driver() -> None:
    """The IRL table learned from the manual view serves the driver at every takeover scale."""
    profile = shorten(canonical_profiles(3)["manual2"], 60.0)
    for d in draw_population(3, 3):
        view = calibration.manual_view(d)
        assert view != d and view.acc_offset_s == 0.0
        a, b = manual_trip(d, profile, 5), manual_trip(view, profile, 5)
        assert np.array_equal(a.gap_m, b.gap_m) and np.array_equal(a.v_mps, b.v_mps)


def test_presses_by_pedal_while_the_acc_is_on() -> None:
    pressed = np.array([0, 1, 1, 0, 1, 1, 1, 1, 0, 1], bool)
    on = np.array([1, 1, 1, 1, 1, 1, 0, 1, 1, 1], bool)  # off for one sample: two presses
    assert calibration.press_lengths(pressed, on, 0.05) == pytest.approx([0.1, 0.1, 0.05, 0.05])
    rows = [
        {"controller": "irl", "on_min": 1.5, "brake": [1.0, 2.0], "accel": [0.5]},
        {"controller": "irl", "on_min": 0.5, "brake": [3.0], "accel": []},
    ]
    assert (
        calibration.presses(rows)
        == "irl            brake  1.50 /min 2.00 s  accel  0.50 /min 0.50 s"
    )
