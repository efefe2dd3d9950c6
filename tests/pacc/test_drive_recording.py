"""A drive's bus recording: replay reproduces the ECU's commands exactly; export, plot, CLIs."""

from __future__ import annotations

import re
import subprocess
import sys
from dataclasses import replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import can
import cantools
import numpy as np
import pytest
from mcap.reader import make_reader

from dbc import DBC_PATH
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import write_trip
from ecu.buslog.reader import CanLog, read_canlog
from ecu.buslog.replay import play, replay_through_ecu
from pacc import cli
from pacc.cli import main as pacc_main
from pacc.commands import replay as replay_cmd
from pacc.commands.drive import main as drive_main
from pacc.commands.export import main as export_main
from pacc.commands.plot import main as plot_main
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from pacc.study.pipeline import Drive, plan, run_one
from pacc.study.spec import StudySpec, table1_method
from sim_bus.drivers import BUILTIN_DRIVERS

#: d2 with online adaptation: a takeover at 10.2 s, the adaptation at its release (13.2 s)
CFG = DriveConfig(scenario="B", driver_id="d2", controller="predefined+oa", seed=1, duration_s=20.0)
UTC0_NS = 1_790_000_000_000_000_000


@lru_cache(maxsize=1)
def _recorded(tmp: str) -> tuple[Path, list[tuple[float, int, bytes]]]:
    """A 20-s drive recorded to ``tmp/drive.mcap``, and every frame the ECU sent in it as a
    listener on the drive's channel saw it."""
    path = Path(tmp) / "drive.mcap"
    driver = BUILTIN_DRIVERS["d2"]
    channel = "test-drive-recording"
    listener = can.Bus(interface="lockstep", channel=channel)
    try:
        result = run_drive(
            CFG,
            driver,
            predefined_table(driver),
            record_channel=channel,
            can_log=path,
            utc_start_ns=UTC0_NS,
        )
        seen = []
        while (msg := listener.recv(0)) is not None:
            if msg.arbitration_id in (0x2E0, 0x3E0):
                seen.append((msg.timestamp, msg.arbitration_id, bytes(msg.data)))
    finally:
        listener.shutdown()
    assert result.adaptations >= 1  # the drive exercises the adaptation
    return path, seen


@pytest.fixture(scope="module")
def recorded(
    tmp_path_factory: pytest.TempPathFactory,
) -> tuple[Path, list[tuple[float, int, bytes]]]:
    return _recorded(str(tmp_path_factory.mktemp("rec")))


def test_replaying_a_drive_reproduces_its_ecu_commands_exactly(
    recorded: tuple[Path, list[tuple[float, int, bytes]]],
) -> None:
    path, on_the_bus = recorded
    log = read_canlog(path)
    result = replay_through_ecu(log)
    assert len(result.sent) == 1000 + 200  # 20 s of ACC_Command (50 Hz) and ACC_Status
    assert result.sent == on_the_bus  # what the drive's ECU put on the bus, bit for bit
    assert result.identical and result.first_difference() is None
    assert result.summary.adaptations >= 1 and result.summary.takeovers >= 1
    assert [s for _, s in result.states][:3] == ["STANDBY", "ACTIVE", "OVERRIDE"]


def test_a_changed_input_frame_changes_the_replay(
    recorded: tuple[Path, list[tuple[float, int, bytes]]],
) -> None:
    log = read_canlog(recorded[0])
    f = log.frames
    # the radar's frames from 5 s on report the lead 20 m closer: the ECU must act differently
    radar = [i for i in range(len(f)) if f.id[i] == 0x120 and f.t_s[i] >= 5.0]
    codec_db: Any = cantools.database.load_file(str(DBC_PATH), database_format="dbc")
    from dbc.codec import load_codec  # noqa: PLC0415

    codec = load_codec()
    mc = codec.by_role["radar"]
    for i in radar:
        d = mc.decode(f.data[i])
        values = dict(d.values)
        values["gap_m"] = max(0.0, float(values["gap_m"]) - 20.0)
        f.data[i] = mc.encode(values, d.counter or 0)
    assert codec_db.get_message_by_frame_id(0x120).name == "RADAR_Lead"
    result = replay_through_ecu(log)
    assert not result.identical
    first = result.first_difference()
    assert first is not None and result.sent[first][0] >= 5.0


def test_pacc_replay_cli(
    recorded: tuple[Path, list[tuple[float, int, bytes]]], capsys: pytest.CaptureFixture[str]
) -> None:
    assert pacc_main(["replay", str(recorded[0]), "--ecu"]) == 0
    out = capsys.readouterr().out
    assert "identical to the recording (1200 of 1200)" in out
    assert re.search(r"ACTIVE, \d+\.\d\d s OVERRIDE", out) and "adaptations:" in out
    assert replay_cmd.main([str(recorded[0]), "--ecu", "-i", "virtual"]) == 2
    assert replay_cmd.main([str(recorded[0].with_name("none.mcap")), "--ecu"]) == 2
    assert "no such recording" in capsys.readouterr().err


def test_the_drive_recording_holds_decoded_frames_internals_and_utc(
    recorded: tuple[Path, list[tuple[float, int, bytes]]],
) -> None:
    log = read_canlog(recorded[0])
    assert log.node == "drive" and log.metadata["drive"]["driver_id"] == "d2"
    assert "None" not in log.metadata["drive"].values()  # unset settings are absent
    assert {"ESC_Speed", "ACC_Command", "ACC_Status", "RADAR_Lead"} <= set(log.decoded)
    assert len(log.frames) == 20 * (100 + 100 + 20 + 10 + 50 + 10)
    out = log.series["/ecu/outputs"]
    assert len(out["t_s"]) == 1000 and set(np.unique(out["acc_state"])) >= {1.0, 2.0, 3.0}
    assert len(log.series["/sim/world"]["t_s"]) == 400  # the driver's 20 Hz
    assert any("takeover 1" in text for _, text in log.events)
    speed = log.decoded["ESC_Speed"]["VehicleSpeed"]
    world = log.series["/sim/world"]
    assert abs(float(np.median(speed)) - float(np.median(world["v_mps"]))) < 0.5
    with recorded[0].open("rb") as fh:
        first = min(m.log_time for _, _, m in make_reader(fh).iter_messages())
    assert first == UTC0_NS


@pytest.mark.parametrize("suffix", [".log", ".asc", ".blf", ".trc", ".csv"])
def test_export_round_trip_frames_in_equal_frames_out(
    suffix: str, recorded: tuple[Path, list[tuple[float, int, bytes]]], tmp_path: Path
) -> None:
    src = read_canlog(recorded[0])
    other = tmp_path / f"bus{suffix}"
    back = tmp_path / "back.mcap"
    assert export_main([str(recorded[0]), str(other)]) == 0
    assert export_main([str(other), str(back)]) == 0
    log = read_canlog(back)
    assert len(log.frames) == len(src.frames)
    assert log.frames.id.tolist() == src.frames.id.tolist()
    assert log.frames.data == src.frames.data
    assert log.frames.dlc.tolist() == src.frames.dlc.tolist()
    if suffix != ".csv":  # python-can's CSV has no direction
        assert log.frames.rx.tolist() == src.frames.rx.tolist()
    tolerance_s = 1e-3 if suffix == ".asc" else 1e-5  # ASC: the start time in ms
    want = np.array([src.time_base.utc_ns(t) / 1e9 for t in src.frames.t_s.tolist()])
    assert np.max(np.abs(log.frames.t_s - want)) < tolerance_s
    db: Any = cantools.database.load_file(str(DBC_PATH), database_format="dbc", strict=True)
    _decoded_equal_cantools(log, db)


def _decoded_equal_cantools(log: CanLog, db: Any) -> None:
    for message in db.messages:
        rows = [d for i, d in enumerate(log.frames.data) if log.frames.id[i] == message.frame_id]
        cols = log.decoded[message.name]
        assert len(cols["t_s"]) == len(rows)
        for i in range(0, len(rows), 37):
            want = message.decode(rows[i], decode_choices=False)
            assert {k: cols[k][i].item() for k in want} == want


def test_python_can_reads_and_writes_pacc_recordings(
    recorded: tuple[Path, list[tuple[float, int, bytes]]], tmp_path: Path
) -> None:
    msgs = list(can.LogReader(recorded[0]))  # the .mcap plugin of pacc's entry points
    assert len(msgs) == 5800 and msgs[0].timestamp == pytest.approx(UTC0_NS / 1e9)
    with can.Logger(tmp_path / "copy.mcap") as writer:
        for m in msgs:
            writer.on_message_received(m)
    assert read_canlog(tmp_path / "copy.mcap").frames.data == read_canlog(recorded[0]).frames.data


def test_export_errors_leave_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert export_main([str(tmp_path / "none.blf"), str(tmp_path / "x.mcap")]) == 2
    (tmp_path / "bad.mcap").write_bytes(b"not mcap at all")
    assert export_main([str(tmp_path / "bad.mcap"), str(tmp_path / "x.asc")]) == 2
    assert not (tmp_path / "x.asc").exists() and not (tmp_path / "x.mcap").exists()
    err = capsys.readouterr().err
    assert "none.blf: no such file" in err and "bad.mcap: corrupt or not MCAP" in err
    assert export_main([str(tmp_path / "bad.mcap"), str(tmp_path / "x.asc"), "--dbc", "a"]) == 2


def test_plot_of_a_drive(
    recorded: tuple[Path, list[tuple[float, int, bytes]]],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    png = tmp_path / "fig.png"
    assert plot_main([str(recorded[0]), "-o", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    raw_only = tmp_path / "raw.mcap"
    assert export_main([str(recorded[0]), str(tmp_path / "x.blf")]) == 0
    assert export_main([str(tmp_path / "x.blf"), str(raw_only)]) == 0
    assert plot_main([str(raw_only), "-o", str(tmp_path / "no.png")]) == 2
    assert "nothing to plot" in capsys.readouterr().err


def test_drive_cli_can_log_and_utc_trip_log(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    can_log, trip = tmp_path / "bus.mcap", tmp_path / "trip.mcap"
    argv = ["--duration", "3", "--can-log", str(can_log), "--log", str(trip)]
    assert drive_main(argv) == 0
    assert "bus recording  " in capsys.readouterr().out
    assert len(read_canlog(can_log).frames) == 3 * 290
    with trip.open("rb") as fh:
        stamps = [m.log_time for _, _, m in make_reader(fh).iter_messages()]
    assert min(stamps) > 1_600_000_000 * 10**9  # real UTC, not 1970
    # through the error boundary, as the shell runs it
    assert cli.main(["drive", "--duration", "3", "--can-log", str(tmp_path)]) == 2


def test_study_drive_records_its_bus(tmp_path: Path) -> None:
    driver = BUILTIN_DRIVERS["d4"]
    cfg = DriveConfig(scenario="B", driver_id="d4", seed=0, duration_s=2.0)
    method = table1_method("predefined")
    drive = Drive(cfg, driver, predefined_table(driver), method, 0, 0,
                  can_log=str(tmp_path / "d4.mcap"))  # fmt: skip
    run_one(drive)
    assert read_canlog(tmp_path / "d4.mcap").metadata["drive"]["driver_id"] == "d4"
    assert StudySpec().can_logs is False


@pytest.mark.slow
def test_play_sends_the_recorded_inputs(
    recorded: tuple[Path, list[tuple[float, int, bytes]]],
) -> None:
    log = read_canlog(recorded[0])
    keep = log.frames.t_s < 0.3  # 0.3 s of recording, sent in real time
    f = log.frames
    short = CanLog(
        log.path,
        type(f)(
            f.t_s[keep],
            f.id[keep],
            f.flags[keep],
            f.dlc[keep],
            [d for d, k in zip(f.data, keep, strict=False) if k],
        ),
        {},
        {},
        [],
        log.metadata,
        log.attachments,
        log.time_base,
    )
    sender = can.Bus(interface="virtual", channel="test-play")
    listener = can.Bus(interface="virtual", channel="test-play")
    try:
        result = play(short, sender, which="rx")
        got = []
        while (msg := listener.recv(0)) is not None:
            got.append(bytes(msg.data))
    finally:
        sender.shutdown()
        listener.shutdown()
    want = [d for d, r, k in zip(f.data, f.rx.tolist(), keep.tolist(), strict=False) if r and k]
    assert result.frames_sent == len(want) and got == want


def test_a_recording_is_a_pure_function_of_the_drive_and_its_start(tmp_path: Path) -> None:
    driver = BUILTIN_DRIVERS["d1"]
    cfg = DriveConfig(scenario="B", driver_id="d1", seed=4, duration_s=3.0)
    paths = [tmp_path / "one.mcap", tmp_path / "two.mcap"]
    for path in paths:
        run_drive(cfg, driver, predefined_table(driver), can_log=path, utc_start_ns=UTC0_NS)
    assert paths[0].read_bytes() == paths[1].read_bytes()


def test_study_plan_puts_bus_recordings_under_can(tmp_path: Path) -> None:
    driver = BUILTIN_DRIVERS["d1"]
    method = table1_method("predefined")
    cfg = StudySpec(drivers=("d1",), scenarios=("B",), methods=(method,), trials=2)
    tables = {("d1", method.table_key): predefined_table(driver)}
    drives = plan(replace(cfg, can_logs=True), {"d1": driver}, tables, tmp_path)
    assert [d.can_log for d in drives] == [
        str(tmp_path / "can" / f"d1_B_predefined_t{t}.mcap") for t in (0, 1)
    ]
    assert all(d.can_log is None for d in plan(cfg, {"d1": driver}, tables, tmp_path))


_FULL_DISK = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, resource.RLIM_INFINITY))
from pacc.commands.drive import main
sys.exit(main(["--duration", "60", "--can-log", sys.argv[1]]))
"""


@pytest.mark.slow
def test_a_failing_recording_costs_neither_the_drive_nor_its_results(tmp_path: Path) -> None:
    path = tmp_path / "bus.mcap"
    proc = subprocess.run(
        [sys.executable, "-c", _FULL_DISK, str(path)],
        check=False,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2, proc.stderr
    assert "PoI" in proc.stdout and "collisions     0" in proc.stdout  # the drive ran through
    assert "bus recording failed" in proc.stderr and "recording stopped at t = " in proc.stderr
    assert "File too large" in proc.stderr
    assert not path.exists() and (tmp_path / "bus.mcap.part").exists()


def test_plot_signals_trip_logs_foreign_logs_and_killed_recordings(
    recorded: tuple[Path, list[tuple[float, int, bytes]]],
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    src = recorded[0]
    out = tmp_path / "sig"
    args = [str(src), "ESC_Speed.VehicleSpeed", "/ecu/outputs.desired_gap_m", "-o", str(out)]
    assert plot_main(args) == 0
    assert capsys.readouterr().out.strip() == f"plot: {out}.png"
    assert (tmp_path / "sig.png").read_bytes()[:4] == b"\x89PNG"
    assert plot_main([str(src), "no_such_signal", "-o", str(out)]) == 2
    assert "signal 'no_such_signal' is in none" in capsys.readouterr().err
    # a foreign log (BLF) decoded with the DBC: its signals plot
    blf = tmp_path / "x.blf"
    assert export_main([str(src), str(blf)]) == 0
    assert plot_main([str(blf), "VehicleSpeed", "-o", str(tmp_path / "b.png")]) == 0
    # ... and its fixed panels, decoded through the binding (pacc's own here)
    binding = str(DBC_PATH.with_name("pacc.binding.toml"))
    assert plot_main([str(blf), "--binding", binding, "-o", str(tmp_path / "f.png")]) == 0
    assert (tmp_path / "f.png").stat().st_size > 10_000
    # a trip log: the fixed panels
    trip = tmp_path / "trip.mcap"
    t = np.arange(50.0)
    write_trip(trip, Trip.manual(t, np.ones(50), np.full(50, 20.0), np.ones(50), np.zeros(50)))
    assert plot_main([str(trip), "-o", str(tmp_path / "t.png")]) == 0
    # a recording cut mid-chunk (a killed recorder): plotted and exported with a warning
    part = tmp_path / "cut.mcap.part"
    part.write_bytes(src.read_bytes()[: src.stat().st_size * 2 // 3])
    capsys.readouterr()
    assert plot_main([str(part), "-o", str(tmp_path / "p.png")]) == 0
    assert "warning: " in capsys.readouterr().err
    assert export_main([str(part), str(tmp_path / "fixed.mcap")]) == 0
    assert "unfinished recording" in capsys.readouterr().err
    fixed = read_canlog(tmp_path / "fixed.mcap")
    assert fixed.complete and 0 < len(fixed.frames) < len(read_canlog(src).frames)
    assert fixed.attachments.keys() == read_canlog(src).attachments.keys()
