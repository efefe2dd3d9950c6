"""``pacc validate``: car following per real pair, Table I beside the paper's people."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from pacc.commands.validate import main
from sim_bus.errors import SimError


def test_following_prints_every_model_per_pair(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    png = tmp_path / "f.png"
    assert main(["following", "--pairs", "2", "--maxiter", "1", "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert "driver spacing | idm spacing | ctg spacing | gipps spacing" in out
    assert "040719_platoon10_f2" in out and "**mean**" in out
    prior = out.split("prior, median (sd of log): ")[1]
    assert all(name in prior for name in ("accel_max_mps2", "decel_comfort_mps2", "reaction_s"))
    assert png.read_bytes()[:4] == b"\x89PNG"


def test_people_puts_table_one_beside_the_paper(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    path = tmp_path / "drives.csv"
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["driver", "controller", "poi_pct", "nim_per_min"])
        for i in range(6):
            for c, poi in (("predefined", 20), ("predefined+oa", 8), ("irl", 14), ("irl+oa", 7)):
                w.writerow([f"p{i}", c, poi + i, 5])
    assert main(["people", str(path)]) == 0
    out = capsys.readouterr().out
    assert "| IRL | 16.5 [" in out and "| 14.5 |" in out
    assert "IRL + OA vs IRL: PoI -7.00 points, lower for 6 of 6 drivers" in out
    assert "mean press s (PoI × 0.6 / NIM): Predefined 2.70 (1.14)" in out  # 22.5 % at 5/min
    assert "IRL 1.98 (1.36)" in out


def test_people_refuses_a_file_without_drives(tmp_path: Path) -> None:
    bad = tmp_path / "x.csv"
    bad.write_text("a,b\n1,2\n")
    with pytest.raises(SimError, match="not a study's drives.csv"):
        main(["people", str(bad)])
