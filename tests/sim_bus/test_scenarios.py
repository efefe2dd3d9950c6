"""The stochastic scenario generator over the shipped real data, and profile CSV files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim_bus.dataset import load_human_pairs
from sim_bus.errors import ScenarioError
from sim_bus.lead.profile import DT_S, LeadProfile
from sim_bus.lead.profile_csv import load_profile_csv, save_profile_csv
from sim_bus.lead.scenarios import (
    GeneratorConfig,
    canonical_profiles,
    random_speed_sequence,
    shorten,
    synthesize,
)


@pytest.fixture(scope="module")
def profiles() -> dict[str, LeadProfile]:
    return canonical_profiles(0)


def test_canonical_set_shape(profiles: dict[str, LeadProfile]) -> None:
    assert set(profiles) == {"manual1", "manual2", "manual3", "manual4", "A", "B"}
    for p in profiles.values():
        assert len(p.t_s) == 3001 and p.duration_s == pytest.approx(300.0)
        assert np.allclose(np.diff(p.t_s), DT_S)
        assert np.all(np.isfinite(p.v_lead_mps)) and np.all(p.v_lead_mps >= 0)


def test_acceleration_within_bounds(profiles: dict[str, LeadProfile]) -> None:
    cfg = GeneratorConfig()
    for p in profiles.values():
        a = np.diff(p.v_lead_mps) / DT_S
        assert a.max() <= cfg.accel_max_mps2 + 1e-9
        assert a.min() >= -cfg.decel_max_mps2 - 1e-9


def test_manual_profiles_cover_5_to_30(profiles: dict[str, LeadProfile]) -> None:
    v = np.concatenate([profiles[f"manual{k}"].v_lead_mps for k in range(1, 5)])
    hist, _ = np.histogram(v, bins=np.arange(5.0, 31.0, 5.0))
    assert np.all(hist > 100), hist  # every 5 m/s band visited for > 10 s
    assert v.min() < 7.0 and v.max() > 28.0


def test_requested_average_speeds_are_met() -> None:
    speeds = np.array(
        [
            8.0,
            14.0,
            20.0,
            26.0,
            20.0,
            14.0,
            8.0,
            12.0,
            18.0,
            24.0,
            28.0,
            22.0,
            16.0,
            10.0,
            15.0,
            25.0,
        ]
    )
    prof = synthesize(speeds, seed=5, name="t")
    n = int(GeneratorConfig().segment_s / DT_S)
    raw = prof.raw_v_mps
    assert raw is not None
    means = [raw[i * n : (i + 1) * n].mean() for i in range(len(raw) // n)]
    assert np.allclose(means, speeds[: len(means)], atol=GeneratorConfig().tolerance_mps + 1e-6)


def test_scenario_a_slows_from_30_to_5(profiles: dict[str, LeadProfile]) -> None:
    v = profiles["A"].v_lead_mps
    assert v[:300].mean() > 25.0
    assert v[-300:].mean() < 10.0
    means = v[:3000].reshape(10, 300).mean(axis=1)
    assert np.sum(np.diff(means) < 0) >= 7  # mostly decreasing


def test_scenario_a_is_drawn_from_the_manual_profiles(profiles: dict[str, LeadProfile]) -> None:
    a = profiles["A"]
    assert {s.source for s in a.segments} <= {"manual1", "manual2", "manual3", "manual4"}
    assert a.raw_v_mps is not None  # a profile built from segments keeps them unfiltered
    pos = 0
    for seg in a.segments:
        src = profiles[seg.source].v_lead_mps[seg.start : seg.start + seg.length]
        piece = a.raw_v_mps[pos : pos + seg.length]
        assert np.allclose(piece, seg.scale * src[: len(piece)])
        pos += seg.length
        if pos >= len(a.raw_v_mps):
            break


def test_segments_really_come_from_the_data(profiles: dict[str, LeadProfile]) -> None:
    pairs = {p.pair_id: p for p in load_human_pairs()}
    for name in ("manual2", "B"):
        prof = profiles[name]
        assert prof.raw_v_mps is not None
        pos = 0
        for seg in prof.segments:
            src = pairs[seg.source].v_leader_mps[seg.start : seg.start + seg.length]
            piece = prof.raw_v_mps[pos : pos + seg.length]
            assert np.allclose(piece, seg.scale * src[: len(piece)])
            pos += seg.length
            if pos >= len(prof.raw_v_mps):
                break
        # the filtered profile stays close to the real pieces
        assert np.mean(np.abs(prof.v_lead_mps - prof.raw_v_mps)) < 1.0
    unscaled = [s for s in profiles["manual3"].segments if s.scale == 1.0]
    assert len(unscaled) >= 10  # in the data's speed range, segments are used as recorded


def test_reproducible_by_seed() -> None:
    a, b, c = canonical_profiles(7), canonical_profiles(7), canonical_profiles(8)
    for k in a:
        assert np.array_equal(a[k].v_lead_mps, b[k].v_lead_mps)
    assert not np.array_equal(a["B"].v_lead_mps, c["B"].v_lead_mps)


def test_random_sequence_covers_its_range() -> None:
    seq = random_speed_sequence(5.0, 30.0, 16, np.random.default_rng(1))
    assert seq.min() == pytest.approx(5.0) and seq.max() == pytest.approx(30.0)
    with pytest.raises(ScenarioError):
        random_speed_sequence(10.0, 5.0, 16, np.random.default_rng(1))


def test_bad_speed_sequence_rejected() -> None:
    with pytest.raises(ScenarioError):
        synthesize(np.array([10.0, np.nan]), 0, "x")
    with pytest.raises(ScenarioError):
        synthesize(np.array([10.0]), 0, "x")  # 20 s of segments < 300 s


def test_csv_round_trip(tmp_path: Path, profiles: dict[str, LeadProfile]) -> None:
    path = tmp_path / "b.csv"
    save_profile_csv(profiles["B"], path)
    back = load_profile_csv(path)
    assert np.allclose(back.v_lead_mps, profiles["B"].v_lead_mps, atol=1e-5)
    assert np.allclose(back.t_s, profiles["B"].t_s)


def test_shorten_keeps_whole_steps_and_refuses_less_than_one(
    profiles: dict[str, LeadProfile],
) -> None:
    b = profiles["B"]
    assert len(shorten(b, 0.1).t_s) == 2 and len(shorten(b, 20.0).t_s) == 201
    for long in (300.0, 1e300, float("inf")):  # to or beyond the end: all of it
        assert np.array_equal(shorten(b, long).v_lead_mps, b.v_lead_mps)
    for bad in (0.05, 0.0, -1.0, float("nan")):
        with pytest.raises(ScenarioError, match="at least one profile step"):
            shorten(b, bad)


def test_csv_import_resamples_to_10_hz(tmp_path: Path) -> None:
    path = tmp_path / "rec.csv"
    path.write_text("t_s,v_lead_mps\n0,10\n0.25,11\n0.5,12\n1.0,12\n2.0,14\n")
    prof = load_profile_csv(path)
    assert len(prof.t_s) == 21
    assert prof.v_lead_mps[1] == pytest.approx(10.4)


@pytest.mark.parametrize(
    "text,match",
    [
        ("time,speed\n0,1\n1,2\n", "columns"),
        ("t_s,v_lead_mps\n0,1\n0,2\n", "increasing"),
        ("t_s,v_lead_mps\n0,1\n2,-2\n", "negative"),
        ("t_s,v_lead_mps\n0,1\n2,abc\n", "non-numeric"),
        ("t_s,v_lead_mps\n0,1\n2\n", "non-numeric"),  # a short row
        ("t_s,v_lead_mps\n0,1\n2,nan\n", "non-finite"),
        ("t_s,v_lead_mps\n0,1\n0.5,2\n", "shorter"),
    ],
)
def test_bad_csv_gets_a_clear_error(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=match):
        load_profile_csv(path)
    assert path.read_text() == text  # the input is left as it was


@pytest.mark.parametrize("data", [b"\xff\xfe\xfa\x00t_s\n", b"t_s,v_lead_mps\n0,1\n1,2\x00\n"])
def test_binary_csv_gets_a_clear_error(tmp_path: Path, data: bytes) -> None:
    path = tmp_path / "bin.csv"
    path.write_bytes(data)
    with pytest.raises(ScenarioError, match="bin.csv"):
        load_profile_csv(path)


@settings(max_examples=20)
@given(
    seed=st.integers(0, 2**31 - 1), speeds=st.lists(st.floats(3.0, 35.0), min_size=16, max_size=20)
)
def test_any_synthesis_respects_the_bounds(seed: int, speeds: list[float]) -> None:
    cfg = GeneratorConfig()
    prof = synthesize(np.array(speeds), seed, "h", cfg)
    a = np.diff(prof.v_lead_mps) / DT_S
    assert a.max() <= cfg.accel_max_mps2 + 1e-9 and a.min() >= -cfg.decel_max_mps2 - 1e-9
    assert np.all(prof.v_lead_mps >= 0) and len(prof.t_s) == 3001
    assert np.array_equal(prof.v_lead_mps, synthesize(np.array(speeds), seed, "h").v_lead_mps)
