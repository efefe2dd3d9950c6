"""``pacc cloud learn`` end to end on MCAP and CSV demonstration files."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cloud_sync.irl.trainer import LearnResult
from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt_file import load_dgpt, save_dgpt
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import write_trip
from pacc.cli import main as pacc_main
from pacc.commands.cloud import main
from tests.cli_util import exit_code


def _write_csv(trip: Trip, path: Path) -> None:
    cols = np.column_stack([trip.t_s, trip.v_mps, trip.a_mps2, trip.gap_m, trip.v_lead_mps])
    np.savetxt(
        path, cols, delimiter=",", header="t,v_follower,a_follower,spacing,v_leader", comments=""
    )


@pytest.mark.slow
def test_learn_from_mcap_and_csv_then_continue(
    syn_trips: list[Trip], tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    files = []
    for i, trip in enumerate(syn_trips[:2]):
        p = tmp_path / f"manual{i}.mcap"
        write_trip(p, trip)
        files.append(str(p))
    csv = tmp_path / "manual2.csv"
    _write_csv(syn_trips[2], csv)
    files.append(str(csv))
    out, png = tmp_path / "d1.json", tmp_path / "d1.png"
    rc = main(
        [
            "learn",
            "--demos",
            *files,
            "--driver",
            "d1",
            "--condition",
            "dry",
            "-o",
            str(out),
            "--plot",
            str(png),
            "-q",
        ]
    )
    assert rc == 0
    table = load_dgpt(out)
    assert table.source == "irl" and table.driver_id == "d1" and table.condition == "dry"
    assert table.meta["n_trips"] == 3
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = capsys.readouterr().out
    assert "DGPT v1" in text and "covered speeds" in text
    # continuing from it gives the next version through the pacc launcher
    out2 = tmp_path / "d1v2.json"
    rc = pacc_main(
        [
            "cloud",
            "learn",
            "--demos",
            files[0],
            "--driver",
            "d1",
            "--init",
            str(out),
            "-o",
            str(out2),
            "-q",
        ]
    )
    assert rc == 0
    t2 = load_dgpt(out2)
    assert t2.version == 2 and t2.meta["parent_version"] == 1


def test_learn_refuses_bad_demos_with_message(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 40)
    out = tmp_path / "x.json"
    rc = main(["learn", "--demos", str(bad), "--driver", "d", "-o", str(out), "-q"])
    assert rc == 2 and not out.exists()  # bad input: 2, as every refusal of pacc
    assert "bad.mcap" in capsys.readouterr().err
    nan = tmp_path / "nan.csv"
    nan.write_text(
        "t,v_follower,spacing,v_leader\n" + "".join(f"{i / 10},nan,nan,nan\n" for i in range(100))
    )
    rc = main(["learn", "--demos", str(nan), "--driver", "d", "-o", str(out), "-q"])
    assert rc == 2
    rc = main(["learn", "--demos", str(nan), "--driver", "d", "-o", str(out), "--learner", "gp"])
    assert rc == 2  # every learner refuses bad input alike
    assert "NaN-filled" in capsys.readouterr().err


@pytest.mark.parametrize(
    "extra,match",
    [
        (["-o", "no-such-dir/x.json"], "-o"),
        (["-o", "."], "-o"),
        (["-o", "x.json", "--plot", "no-such-dir/p.png"], "--plot"),
        (["-o", "x.json", "--plot", "p.xyz"], "unknown image format 'xyz'"),
        (["-o", "x.json", "--takeover-weight", "nan"], "--takeover-weight"),
        (["-o", "x.json", "--seed", "-1"], "--seed"),
    ],
)
def test_learn_refuses_bad_outputs_and_options_before_training(
    extra: list[str],
    match: str,
    syn_trips: list[Trip],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)
    demo = tmp_path / "m.mcap"
    write_trip(demo, syn_trips[0])
    rc = exit_code(main, ["learn", "--demos", str(demo), "--driver", "d", "-q", *extra])
    captured = capsys.readouterr()
    assert rc == 2 and match in captured.err  # usage or bad input: 2, as argparse
    assert "IRL:" not in captured.out  # refused before any training
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.mcap"]  # nothing written


def test_help_and_no_command(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["learn", "--help"])
    assert exc.value.code == 0
    assert "--demos" in capsys.readouterr().out
    assert main([]) == 2


@pytest.mark.slow
def test_init_with_acc_trip_fine_tunes(
    syn_learned_one: LearnResult, follower: Callable[..., Trip], tmp_path: Path
) -> None:
    base = tmp_path / "v1.json"  # learned from a manual drive (as pacc cloud learn does above)
    save_dgpt(syn_learned_one.table, base)
    t = follower(31, headway_s=1.0, minutes=2.0, v_lo=15.0, v_hi=20.0)
    state = np.full(len(t), AccState.ACTIVE)
    for start in range(0, len(t), 300):
        state[start + 20 : start + 170] = AccState.OVERRIDE
    acc = tmp_path / "acc.mcap"
    write_trip(acc, replace(t, acc_state=state, meta={**t.meta, "mode": "acc"}))
    out = tmp_path / "v2.json"
    argv = ["learn", "--demos", str(acc), "--driver", "syn", "--init", str(base), "-o", str(out)]
    rc = main([*argv, "-q"])
    assert rc == 0
    v1, v2 = load_dgpt(base), load_dgpt(out)
    assert v2.version == 2 and v2.meta["n_trips"] == 1
    band = (v2.speed_mps >= 16) & (v2.speed_mps <= 19)
    assert np.mean(v2.gap_m[band]) < np.mean(v1.gap_m[band]) - 1.0  # towards 4 m + 1.0 s·v
    assert np.array_equal(v2.gap_m[v2.speed_mps <= 10], v1.gap_m[v1.speed_mps <= 10])
