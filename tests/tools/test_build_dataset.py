"""Building the shipped data file from pair CSVs, and its refusal of bad sources."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sim_bus.dataset import DATA_PATH, load_human_pairs
from sim_bus.errors import SimError
from tools.build_dataset import DEFAULT_OUT, BuildError, build, main

HEADER = "t,x_follower,v_follower,a_follower,x_leader,v_leader,a_leader,leader_length,spacing,dv"


def _pair_csv(path: Path, n: int, v0: float) -> np.ndarray:
    t = np.arange(n) * 0.1
    v_f = v0 + 0.01 * np.arange(n)
    v_l = v_f + 0.5
    gap = 20.0 + 0.05 * np.arange(n)
    rows = [HEADER] + [
        f"{t[i]:.1f},0,{v_f[i]:.4f},0,0,{v_l[i]:.4f},0,4.5,{gap[i]:.4f},0.5" for i in range(n)
    ]
    path.write_text("\n".join(rows) + "\n")
    return np.stack([v_l, v_f, gap])


def test_build_round_trips_through_the_reader(tmp_path: Path) -> None:
    a = _pair_csv(tmp_path / "oa_pair_a.csv", 30, 10.0)
    b = _pair_csv(tmp_path / "oa_pair_b.csv", 50, 20.0)
    out = tmp_path / "out" / "data.npz"
    sizes = build(tmp_path, out)
    assert sizes["pairs"] == 2 and sizes["samples"] == 80 and sizes["bytes"] > 0
    pairs = load_human_pairs(out)
    assert [p.pair_id for p in pairs] == ["a", "b"]
    for p, want in zip(pairs, (a, b), strict=True):
        got = np.stack([p.v_leader_mps, p.v_follower_mps, p.gap_m])
        assert np.allclose(got, want, atol=1e-4)  # float32 on disk
        assert p.dt_s == pytest.approx(0.1)


@pytest.mark.parametrize(
    "text,match",
    [
        (b"", "missing columns"),
        (b"t,v_follower,v_leader\n0,1,2\n", "missing columns"),
        (b"t,v_follower,v_leader,spacing\n", "fewer than two samples"),
        (b"t,v_follower,v_leader,spacing\n0,1,2,3\n0.3,1,2,3\n", "not sampled at"),
        (b"t,v_follower,v_leader,spacing\n0,1,2,3\n0.1,1,nan,3\n", "non-finite"),
        (b"t,v_follower,v_leader,spacing\n0,1,2,3\n0.1,1,x,3\n", "oa_pair_bad.csv"),
        (b"t,v_follower,v_leader,spacing\n0,1,2,3\n0.1,1,2\n", "oa_pair_bad.csv"),
        (b"\xff\xfe\x00\x01garbage", "oa_pair_bad.csv"),
    ],
)
def test_bad_source_is_a_build_error(tmp_path: Path, text: bytes, match: str) -> None:
    (tmp_path / "oa_pair_bad.csv").write_bytes(text)
    out = tmp_path / "data.npz"
    with pytest.raises(BuildError, match=match):
        build(tmp_path, out)
    assert not out.exists()
    assert issubclass(BuildError, SimError)  # one exception root for the package


def test_main_reports_a_bad_source(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--source", str(tmp_path), "--out", str(tmp_path / "x.npz")]) == 1
    assert "no oa_pair_*.csv" in capsys.readouterr().out


def test_default_output_is_the_file_the_simulator_reads() -> None:
    assert DEFAULT_OUT == DATA_PATH
