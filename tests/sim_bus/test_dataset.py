"""The shipped real-data file: read, and refused when damaged."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sim_bus.dataset import DATA_PATH, load_human_pairs
from sim_bus.errors import DataError


def test_shipped_pairs_are_human_followers_at_10_hz() -> None:
    pairs = load_human_pairs()
    assert len(pairs) == 8
    for p in pairs:
        n = len(p.v_leader_mps)
        assert n > 100 and len(p.v_follower_mps) == n == len(p.gap_m)
        assert p.dt_s == pytest.approx(0.1)
        assert np.all(p.v_leader_mps >= 0.0) and np.all(p.gap_m > 0.0)


def test_damaged_data_file_is_a_data_error(tmp_path: Path) -> None:
    truncated = tmp_path / "truncated.npz"
    truncated.write_bytes(DATA_PATH.read_bytes()[:5000])
    junk = tmp_path / "junk.npz"
    junk.write_bytes(b"not numpy at all")
    for path in (truncated, junk, tmp_path / "missing.npz"):
        with pytest.raises(DataError, match=path.name):
            load_human_pairs(path)
