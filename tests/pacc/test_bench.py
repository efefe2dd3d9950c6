"""``pacc bench``: fresh seeds stored, leaderboard files, resumption, held-out error."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from dbc.vocab.dgpt import predefined
from dbc.vocab.triplog import Trip
from pacc.commands.bench import main as bench_main
from pacc.study.bench.heldout import held_out_error
from pacc.study.bench.suite import fresh_seeds

METHODS = """
[[methods]]
name = "paper"
table = "empirical"
adaptation = "paper"

[[methods]]
table = "gp"
adaptation = "bayes"
"""


def test_fresh_seeds_are_distinct_and_new_each_time() -> None:
    a, b = fresh_seeds(5), fresh_seeds(5)
    assert len(set(a)) == 5 and all(0 <= s < 10**6 for s in a)
    assert a != b  # 1 in 10^30 to fail by chance


def test_held_out_error_counts_near_steady_samples_at_covered_speeds() -> None:
    table = predefined(2.0)  # 4 m + 2 s * v
    t = np.arange(6) * 0.1
    v = np.array([20.0, 20.0, 20.0, 20.0, 30.0, 20.0])
    gap = np.array([44.0, 46.0, 40.0, 44.0, 64.0, 99.0])
    v_lead = v + np.array([0, 0, 0, 0, 0, 3.0])  # the last sample is not steady
    trip = Trip.manual(t, v, gap, v_lead, np.zeros(6), {})
    covered = table.speed_mps <= 25.0  # 30 m/s not covered
    assert held_out_error(table, trip, covered) == pytest.approx((0 + 2 + 4 + 0) / 4)
    assert math.isnan(held_out_error(table, trip, np.zeros_like(covered)))


@pytest.mark.slow
def test_a_small_bench_stores_its_seeds_writes_the_board_and_resumes(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    methods = tmp_path / "methods.toml"
    methods.write_text(METHODS, encoding="utf-8")
    out = tmp_path / "bench"
    argv = ["--seeds", "1", "--drivers-per-seed", "2", "--no-builtin", "--duration", "10",
            "--methods", str(methods), "--out", str(out), "--workers", "1", "-q"]  # fmt: skip
    assert bench_main(argv) == 0
    printed = capsys.readouterr().out
    stored = json.loads((out / "bench.json").read_text(encoding="utf-8"))
    (seed,) = stored["seeds"]
    assert f"population seeds (drawn fresh): {seed}" in printed
    board = (out / "leaderboard.md").read_text(encoding="utf-8")
    assert "| paper | 2 |" in board and "| gp+bayes | 2 |" in board
    assert "(the baseline)" in board and "(8/8)" not in board  # no wins against itself
    assert (out / "leaderboard.png").stat().st_size > 1000
    csv_lines = (out / "leaderboard.csv").read_text(encoding="utf-8").splitlines()
    assert len(csv_lines) == 3 and csv_lines[0].startswith("method,table")
    heldout = (out / "heldout" / "rows.jsonl").read_text(encoding="utf-8").splitlines()
    assert len(heldout) == 1 + 8 + 2  # fingerprint, the 8 OpenACC pairs, 2 drawn drivers
    # a second run resumes: the stored seed, nothing run again
    assert bench_main(argv) == 0
    assert "resuming the bench" in capsys.readouterr().err
    assert (out / "heldout" / "rows.jsonl").read_text(encoding="utf-8").splitlines() == heldout
