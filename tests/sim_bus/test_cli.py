"""``pacc drive`` and ``pacc sim`` entry points."""

from __future__ import annotations

import threading
from pathlib import Path

import can
import numpy as np
import pytest

from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import predefined
from dbc.vocab.dgpt_file import save_dgpt
from dbc.vocab.triplog_file import read_trip
from ecu.buslog.reader import read_canlog
from ecu.config import EcuConfig
from ecu.node import EcuNode
from ecu.runtime import EcuRuntime
from pacc.commands import drive
from pacc.commands import sim as cli
from pacc.commands.drive import report as drive_report
from pacc.commands.plot import main as plot_main
from pacc.study.drive import with_condition
from pacc.study.irl_table import cache_key, code_digest, irl_table
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.errors import SimError
from sim_bus.lead import profile_csv, scenarios
from sim_bus.lead.__main__ import main as lead_main
from sim_bus.manual import manual_trip
from sim_bus.world import World
from tests.cli_util import exit_code


def test_drive_prints_the_figures_and_logs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "run.mcap"
    rc = drive.main(
        [
            "--scenario",
            "A",
            "--driver",
            "d3",
            "--controller",
            "predefined+oa",
            "--seed",
            "1",
            "--duration",
            "20",
            "--log",
            str(log),
        ]
    )
    out = capsys.readouterr().out
    assert rc == 0
    for word in (
        "PoI",
        "NIM",
        "min gap",
        "min TTC",
        "RMS jerk",
        "takeovers",
        "adaptations",
        "collisions     0",
    ):
        assert word in out
    trip = read_trip(log)
    assert trip.meta["mode"] == "acc" and trip.meta["controller"] == "predefined+oa"
    assert trip.meta["condition"] == "default" and trip.meta["condition_factor"] == 1.0
    assert len(trip.t_s) == 200 and (trip.acc_state == AccState.ACTIVE).any()


def test_drive_irl_with_profile(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "t.json"
    save_dgpt(predefined(1.8, driver_id="d2"), path)
    rc = drive.main(
        [
            "--controller",
            "irl",
            "--driver",
            "d2",
            "--profile",
            str(path),
            "--duration",
            "10",
            "--scenario",
            "manual2",
        ]
    )
    assert rc == 0 and "controller irl" in capsys.readouterr().out


@pytest.mark.parametrize(
    "argv,match",
    [
        (["--driver", "d9"], "unknown driver"),
        (["--faults", "radar:drop=7"], "0..1"),
        (["--scenario", "Z"], "unknown scenario"),
        (["--scenario", "missing.csv"], "missing.csv"),
        (["--controller", "irl", "--profile", "nope.json"], "nope.json"),
        (["--duration", "-1"], "duration"),
        (["--duration", "0.05"], "at least one profile step"),
        (["--seed", "-1"], "seed"),
    ],
)
def test_drive_bad_options(argv: list[str], match: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert exit_code(drive.main, argv) == 2
    err = capsys.readouterr().err
    assert "error" in err and match in err


def test_irl_table_cache_hit_skips_learning(tmp_path: Path) -> None:
    driver = BUILTIN_DRIVERS["d4"]
    src = code_digest()
    cached = predefined(2.2, driver_id="d4")
    save_dgpt(cached, tmp_path / f"irl-d4-{cache_key(driver, 5, src)}.json")
    table = irl_table(driver, 5, tmp_path)  # learning would take seconds; the hit is instant
    assert table.source == "predefined" and (table.gap_m == cached.gap_m).all()
    assert cache_key(driver, 5, src) != cache_key(driver, 6, src)
    assert cache_key(driver, 5, src) != cache_key(BUILTIN_DRIVERS["d3"], 5, src)
    assert cache_key(driver, 5, src) != cache_key(driver, 5, "another code version")


def test_sim_real_time_against_an_ecu_runtime_records_the_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``pacc sim --can-log`` in real time against an ECU runtime on the same bus: the ECU's
    commands counted, the run recorded (the simulator's frames out, the commands in, the
    world, the wall clock) and plotted."""
    channel = "test-pacc-sim-rt"
    ecu_bus = can.Bus(interface="virtual", channel=channel)
    rt = EcuRuntime(ecu_bus, EcuNode(EcuConfig(set_speed_mps=40.0), predefined(1.8)))
    thread = threading.Thread(target=rt.run_realtime, args=(4.0,), daemon=True)
    thread.start()
    path = tmp_path / "sim.mcap"
    try:
        argv = ["-i", "virtual", "-c", channel, "--scenario", "manual2", "--driver", "d2"]
        rc = cli.main([*argv, "--duration", "3", "--quiet", "--can-log", str(path)])
    finally:
        rt.stop()
        thread.join(5.0)
        ecu_bus.shutdown()
    out = capsys.readouterr().out
    assert rc == 0 and "bus recording:" in out
    n_cmd = int(out.split(" ACC commands received")[0].rsplit(";", 1)[1])
    assert 100 <= n_cmd <= 160  # 50 Hz for ~3 s
    assert rt.summary().frames_in > 500
    log = read_canlog(path)
    assert log.node == "sim" and "/sim/world" in log.series
    rx = log.frames.rx
    assert rx.sum() > 50 and (~rx).sum() > 400  # ACC commands in, the simulator's frames out
    assert log.time_base.utc_origin_ns > 1_600_000_000 * 10**9  # the wall clock
    assert plot_main([str(path), "-o", str(tmp_path / "sim.png")]) == 0


def test_sim_bad_bus(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["-i", "no-such-interface", "-c", "x", "--duration", "1"]) == 2
    assert "cannot open the CAN bus" in capsys.readouterr().err


def test_negative_seed_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    argv = ["-i", "virtual", "-c", "neg-seed", "--seed", "-1", "--duration", "1"]
    assert exit_code(cli.main, argv) == 2
    err = capsys.readouterr().err
    assert "--seed" in err and ">= 0" in err
    assert lead_main(["list", "--seed", "-2"]) == 2
    assert capsys.readouterr().out.count(">= 0") == 1
    profile = scenarios.canonical_profiles(0)["B"]
    with pytest.raises(SimError, match="seed"):
        World(BUILTIN_DRIVERS["d1"], profile, -1)
    with pytest.raises(SimError, match="seed"):
        manual_trip(BUILTIN_DRIVERS["d1"], profile, -1)


def test_sim_writes_its_run_as_a_trip_log(tmp_path: Path) -> None:
    log = tmp_path / "sim.mcap"
    rc = cli.main(
        [
            "-i",
            "virtual",
            "-c",
            "test-pacc-sim-trip",
            "--driver",
            "d3",
            "--seed",
            "4",
            "--duration",
            "1",
            "--quiet",
            "--condition-factor",
            "1.2",
            "--log",
            str(log),
        ]
    )
    assert rc == 0
    trip = read_trip(log)
    assert trip.meta["driver_id"] == "d3" and trip.meta["seed"] == 4
    assert trip.meta["mode"] == "acc" and trip.meta["condition_factor"] == 1.2
    assert trip.meta["condition"] == "factor-1.2"  # not filed as a dry trip
    assert len(trip) == 10 and np.allclose(np.diff(trip.t_s), 0.1)  # 1 s at 10 Hz
    assert np.all(trip.acc_state == AccState.OFF)  # no ECU on this channel: the ACC never engaged


@pytest.mark.parametrize("where", ["no-such-dir/run.mcap", "."])
def test_sim_refuses_an_unwritable_log_before_running(
    where: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    listener = can.Bus(interface="virtual", channel="test-pacc-sim-log")
    try:
        rc = cli.main(
            [
                "-i",
                "virtual",
                "-c",
                "test-pacc-sim-log",
                "--duration",
                "0.5",
                "--quiet",
                "--log",
                str(tmp_path / where),
            ]
        )
        sent = listener.recv(0.0)
    finally:
        listener.shutdown()
    assert rc == 2 and "--log" in capsys.readouterr().err
    assert sent is None  # refused at start: no frame was ever sent


def test_scenarios_export_and_drive_the_csv(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "b.csv"
    assert lead_main(["export", "B", str(path), "--seed", "2"]) == 0
    assert profile_csv.load_profile_csv(path).duration_s == pytest.approx(300.0)
    assert lead_main(["export", "Q", str(path)]) == 2
    assert lead_main(["list"]) == 0
    listed = capsys.readouterr().out
    assert all(
        name in listed for name in ("manual4", "cutin", "cutout", "leadloss", "stopgo", "C ")
    )
    assert drive.main(["--scenario", str(path), "--duration", "5", "--driver", "d4"]) == 0
    assert f"scenario {path}" in capsys.readouterr().out


def test_condition_factor_lengthens_the_preference(tmp_path: Path) -> None:
    d = with_condition(BUILTIN_DRIVERS["d2"], 1.25)
    assert d.preferred_gap_m(20.0) - 4.0 == pytest.approx(
        1.25 * (BUILTIN_DRIVERS["d2"].preferred_gap_m(20.0) - 4.0)
    )
    assert with_condition(BUILTIN_DRIVERS["d2"], 1.0) is BUILTIN_DRIVERS["d2"]
    assert exit_code(drive.main, ["--condition-factor", "0", "--duration", "5"]) == 2
    log = tmp_path / "rain.mcap"
    assert drive.main(["--condition-factor", "1.2", "--duration", "5", "--log", str(log)]) == 0
    trip = read_trip(log)
    assert trip.meta["condition"] == "factor-1.2" and trip.meta["condition_factor"] == 1.2


def test_sim_on_vcan0_if_present() -> None:
    try:
        bus = can.Bus(interface="socketcan", channel="vcan0")
    except (OSError, can.CanError, ImportError, ValueError) as exc:
        pytest.skip(f"no SocketCAN vcan0 here: {exc}")
    bus.shutdown()
    rc = cli.main(["-i", "socketcan", "-c", "vcan0", "--duration", "1", "--quiet"])
    assert rc == 0  # no ECU on vcan0: the driver drives by hand, nothing collides


def test_collision_is_reported_not_hidden(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # a lead that stops dead (a recorded crash, say) while the radar frames freeze
    csv = tmp_path / "wall.csv"
    csv.write_text("t_s,v_lead_mps\n0,20\n10,20\n10.1,0\n30,0\n")
    log = tmp_path / "crash.mcap"
    rc = drive.main(
        [
            "--scenario",
            str(csv),
            "--driver",
            "d1",
            "--faults",
            "radar:freeze=9-30",
            "--log",
            str(log),
        ]
    )
    out = capsys.readouterr().out
    assert rc == 1
    assert "collisions     1 at t = " in out
    trip = read_trip(log)
    assert trip.meta["collision"] is True and trip.t_s[-1] < 25.0


@pytest.mark.slow
def test_irl_table_is_learned_from_manual_trips_and_cached(tmp_path: Path) -> None:
    driver = BUILTIN_DRIVERS["d1"]
    table = irl_table(driver, 0, tmp_path)
    files = list(tmp_path.glob("irl-d1-*.json"))
    assert len(files) == 1 and table.source == "irl" and table.driver_id == "d1"
    v = np.array([10.0, 15.0, 20.0, 25.0])  # speeds the manual profiles cover well
    rel = table.lookup(v) / driver.preferred_gap_m(v) - 1.0
    assert np.all(np.abs(rel) < 0.25), rel
    again = irl_table(driver, 0, tmp_path)
    assert np.array_equal(again.gap_m, table.gap_m)
    # an unusable cache folder (here a file) costs a re-learn, not the drive
    blocked = tmp_path / "not-a-dir"
    blocked.write_text("x")
    relearned = irl_table(driver, 0, blocked)
    assert np.array_equal(relearned.gap_m, table.gap_m)  # learning is a pure function
    assert blocked.read_text() == "x"


def test_sim_takes_the_bus_from_python_can_config(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # no -i/-c/-b: python-can's own configuration (here CAN_INTERFACE/CAN_CHANNEL) applies
    monkeypatch.setenv("CAN_INTERFACE", "virtual")
    monkeypatch.setenv("CAN_CHANNEL", "test-pacc-sim-env")
    listener = can.Bus(interface="virtual", channel="test-pacc-sim-env")
    try:
        assert cli.main(["--duration", "0.3", "--quiet", "--driver", "d2"]) == 0
        n = 0
        while listener.recv(0.0) is not None:
            n += 1
    finally:
        listener.shutdown()
    assert n >= 60  # ESC and PEDAL every 10 ms, RADAR, HMI


def test_fault_time_counts_the_seconds_in_fault() -> None:
    t = np.arange(0.0, 10.0, 0.1)
    state = np.full(t.shape, int(AccState.ACTIVE))
    state[20:40] = int(AccState.FAULT)  # 2 s
    state[60:65] = int(AccState.FAULT)  # 0.5 s
    fault_s, entries = drive_report.fault_time(t, state)
    assert fault_s == pytest.approx(2.5) and entries == 2
    assert drive_report.fault_time(t, np.zeros_like(state)) == (0.0, 0)
