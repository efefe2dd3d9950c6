"""``pacc ecu --manual DIR``: the driver's manual car-following is spooled as demonstrations
(batches of kind ``manual`` for ``pacc cloud sync --spool DIR``), beside the takeovers;
``pacc drive --manual-trips DIR`` writes what the ECU recorded of it in a simulated drive (and
says when it could not; a folder that cannot be one is refused before the drive)."""

from __future__ import annotations

import itertools
import threading
import time
from pathlib import Path
from typing import Any

import can
import numpy as np
import pytest

from cloud_sync.vehicle.spool import Spool
from dbc.vocab.triplog_file import read_trip
from pacc import cli
from pacc.commands.drive import main as drive_main
from pacc.commands.ecu import main
from pacc.study.drive import run_drive
from tests.peers import PeerNodes

_ids = itertools.count()


class ManualDriver(threading.Thread):
    """Plays ESC/PEDAL/RADAR/HMI in real time: the driver follows a lead at 40 m with the
    ACC off (main switch off), pressing the accelerator a little, until ``seconds`` after
    the ECU's first frame; the radar goes silent for 0.6 s at 1.5 s."""

    def __init__(self, channel: str, seconds: float) -> None:
        super().__init__(daemon=True)
        self.channel, self.seconds = channel, seconds

    def run(self) -> None:
        with can.Bus(interface="virtual", channel=self.channel) as bus:
            peers = PeerNodes(bus)
            peers.set("radar", gap_m=40.0, lead_valid=1)
            peers.set("hmi", main_switch=0)
            peers.set("pedals", accel_pedal_pct=12.0, accel_pressed=1)
            deadline = time.monotonic() + 30.0
            while bus.recv(0.05) is None and time.monotonic() < deadline:
                pass
            t0 = time.monotonic()
            while (t := time.monotonic() - t0) < self.seconds:
                peers.mute("radar", 1.5 <= t < 2.1)
                peers.send_due(t)
                while bus.recv(0) is not None:
                    pass
                time.sleep(0.002)


@pytest.mark.slow
def test_ecu_spools_the_manual_driving(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    channel = f"ecu-manual-{next(_ids)}"
    player = ManualDriver(channel, 3.6)
    player.start()
    spool = tmp_path / "spool"
    args = ["-i", "virtual", "-c", channel, "--duration", "3.5", "--driver", "d2"]
    args += ["--takeovers", str(spool), "--manual", str(spool), "--manual-min", "0.8"]
    rc = main(args)
    player.join()
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "manual trips: 2 of 2 written to" in out, out
    batches = Spool(spool).pending()
    assert [b.kind for b in batches] == ["manual", "manual"]  # one spool, no takeover
    first, second = (read_trip(b.path) for b in batches)
    for trip in (first, second):
        assert trip.meta["mode"] == "manual" and trip.meta["driver_id"] == "d2"
        assert trip.meta["start_utc"].endswith("Z")
        assert set(trip.acc_state.tolist()) == {0}  # OFF
        assert trip.accel_pedal.min() > 0.0 and (trip.gap_m == 40.0).all()
        assert abs(float(np.median(np.diff(trip.t_s))) - 0.1) < 0.005  # every 5th cycle
    # the radar times out 0.5 s (10 of its periods) after it went silent
    assert 1.0 <= len(first) * 0.1 <= 2.3 and 0.8 <= len(second) * 0.1 <= 2.0


def test_manual_flags_are_checked_before_the_bus_opens(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["--manual", "--duration", "0"]) == 2
    assert "--manual needs a DIR" in capsys.readouterr().err
    (tmp_path / "t").write_text("tok\n")
    cloud = ["--cloud", str(tmp_path / "c"), "--vehicle", "v", "--token-file", str(tmp_path / "t")]
    assert main([*cloud, "--manual", str(tmp_path / "m"), "--duration", "0"]) == 2
    assert "--manual without DIR" in capsys.readouterr().err
    with pytest.raises(SystemExit) as refused:
        main(["--manual-min", "0", "--duration", "0"])
    assert refused.value.code == 2


def test_drive_writes_what_the_ecu_recorded_of_manual_driving(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``pacc drive --manual-trips DIR``: in cancel mode the driver drives between a brake
    takeover and the resume; the ECU's manual trips land in DIR, and the drive's figures are
    those of the same drive without the option."""
    argv = ["--scenario", "cutin", "--driver", "d3", "--seed", "0", "--brake-mode", "cancel"]
    argv += ["--duration", "120"]
    assert drive_main(argv) == 0
    plain = capsys.readouterr().out
    assert drive_main([*argv, "--manual-trips", str(tmp_path / "m")]) == 0
    out = capsys.readouterr().out
    same = plain.splitlines()[1:]  # the first line has the wall-clock time
    assert out.splitlines()[1 : len(same) + 1] == same, out  # the same drive; one line more
    assert f"manual trips   2 (50.6 s) in {tmp_path / 'm'}" in out
    trips = [read_trip(p) for p in sorted((tmp_path / "m").glob("manual_*.mcap"))]
    assert [len(t) for t in trips] == [221, 285]
    for trip in trips:
        assert trip.meta["mode"] == "manual" and trip.meta["driver_id"] == "d3"
        assert set(trip.acc_state.tolist()) <= {0, 1} and np.isfinite(trip.gap_m).all()
    assert (
        drive_main(
            ["--manual", "--log", str(tmp_path / "x.mcap"), *argv[:2], "--manual-trips", "m"]
        )
        == 2
    )
    assert "drop --manual-trips" in capsys.readouterr().err


def test_drive_says_when_manual_trips_were_not_written(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The folder of ``--manual-trips`` passes the check, then goes away during the drive (a
    file takes its place: every write fails): the drive's figures and --log still come out,
    the trips not written are said, exit 2."""
    out_dir = tmp_path / "m"

    def run_drive_losing_the_folder(*args: Any, **kwargs: Any) -> Any:
        out_dir.rmdir()
        out_dir.write_text("not a folder any more\n")
        return run_drive(*args, **kwargs)

    monkeypatch.setattr("pacc.study.drive.run_drive", run_drive_losing_the_folder)
    argv = ["--scenario", "cutin", "--driver", "d3", "--seed", "0", "--brake-mode", "cancel"]
    argv += ["--duration", "120", "--log", str(tmp_path / "trip.mcap")]
    assert drive_main([*argv, "--manual-trips", str(out_dir)]) == 2
    out, err = capsys.readouterr()
    assert f"manual trips   0 (0.0 s) in {out_dir}" in out and "collisions     0" in out
    assert "pacc drive: error: 2 manual trip(s) not written: " in err, err
    assert read_trip(tmp_path / "trip.mcap").meta["scenario"] == "cutin"


@pytest.mark.parametrize(
    ("outputs", "why"),
    [
        (["--log", "same", "--manual-trips", "same"], "name the same file"),
        (["--can-log", "same", "--manual-trips", "same"], "name the same file"),
        (["--manual-trips", "file"], "is not a folder"),
        (["--manual-trips", "file/sub"], "is not a writable folder"),
    ],
)
def test_drive_refuses_manual_trips_that_cannot_be_written_before_it_runs(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
    outputs: list[str],
    why: str,
) -> None:
    """Checked with the other outputs before anything runs (not even the IRL table is
    learned), and nothing is left behind."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "file").write_text("x\n")
    argv = ["drive", "--controller", "irl", "--cache", str(tmp_path / "cache"), "--duration", "3"]
    assert cli.main([*argv, *outputs]) == 2
    err = capsys.readouterr().err
    assert why in err and "learning" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_manual_min_is_bounded_and_needs_manual(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--manual-min: 0.1 to 600 s (the longest trip), and only with --manual; refused before
    any spool is created."""
    with pytest.raises(SystemExit) as refused:
        main(["--manual-min", "601", "--manual", str(tmp_path / "m"), "--duration", "0"])
    assert refused.value.code == 2 and "<= 600" in capsys.readouterr().err
    assert main(["--manual-min", "5", "--takeovers", str(tmp_path / "t"), "--duration", "0"]) == 2
    assert "--manual-min is for --manual" in capsys.readouterr().err
    (tmp_path / "tok").write_text("tok\n")
    cloud = [
        "--cloud",
        str(tmp_path / "c"),
        "--vehicle",
        "v",
        "--token-file",
        str(tmp_path / "tok"),
    ]
    assert main([*cloud, "--spool", str(tmp_path / "s"), "--manual-min", "5"]) == 2
    assert "--manual-min is for --manual" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tok"]


def test_manual_alone_warns_of_a_guest_driver_and_takes_the_longest_minimum(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--manual without --driver: the warning names the manual trips (not takeovers, which
    are not recorded); --manual-min 600 is accepted."""
    args = ["-i", "virtual", "-c", f"ecu-manual-{next(_ids)}", "--duration", "0.1"]
    assert main([*args, "--manual", str(tmp_path / "m"), "--manual-min", "600"]) == 0
    out, err = capsys.readouterr()
    assert "warning: manual trips are tagged driver 'guest'" in err, err
    assert "takeover" not in err
    assert "shorter than 600 s" in out, out
