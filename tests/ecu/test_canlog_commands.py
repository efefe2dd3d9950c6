"""A recording through the commands: a killed one replays what it holds; plots carry units."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import pytest
from mcap.reader import make_reader

from ecu.buslog.reader import read_canlog
from pacc.commands import replay as replay_cmd
from pacc.commands.export import main as export_main
from pacc.commands.plot import main as plot_main
from pacc.commands.plot import signal_curves, unit_of
from pacc.study.drive import DriveConfig, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS

#: d2 with online adaptation: a takeover at 10.2 s
CFG = DriveConfig(scenario="B", driver_id="d2", controller="predefined+oa", seed=1, duration_s=20.0)


@lru_cache(maxsize=1)
def _recorded(tmp: str) -> Path:
    """A 20-s drive recorded to ``tmp/drive.mcap``."""
    path = Path(tmp) / "drive.mcap"
    driver = BUILTIN_DRIVERS["d2"]
    run_drive(CFG, driver, predefined_table(driver), can_log=path)
    return path


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _recorded(str(tmp_path_factory.mktemp("drive")))


def _killed_at(path: Path, t_s: float, out: Path) -> Path:
    """``path`` cut where the recorder was at ``t_s`` of the drive: the file up to the first
    chunk that starts after it (its frames to ~t_s, its cycles to the last 10-s rows)."""
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    start = chunks[0].message_start_time
    cut = next(c for c in chunks if c.message_start_time > start + t_s * 1e9)
    out.write_bytes(path.read_bytes()[: cut.chunk_start_offset])
    return out


def test_a_killed_recording_replays_what_it_holds(
    recorded: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Killed at 15 s: the frames reach 15 s, the cycles 10 s (the rows' interval); the ECU
    sends what was recorded up to its last recorded cycle, and says what it left out."""
    part = _killed_at(recorded, 15.0, tmp_path / "killed.mcap.part")
    assert replay_cmd.main([str(part), "--ecu"]) == 0
    out = capsys.readouterr().out
    assert "identical to the recording" in out
    assert "frames its node sent after its last recorded cycle are not compared" in out
    assert "max cycle time" not in out  # a lockstep replay's compute time means nothing
    repaired = tmp_path / "repaired.mcap"
    assert export_main([str(part), str(repaired)]) == 0
    assert replay_cmd.main([str(repaired), "--ecu"]) == 0
    assert "identical to the recording" in capsys.readouterr().out


def test_a_complete_recording_compares_every_frame(
    recorded: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert replay_cmd.main([str(recorded), "--ecu"]) == 0
    out = capsys.readouterr().out
    assert "identical to the recording" in out and "not compared" not in out
    assert "max cycle time" not in out


def test_signal_axes_carry_units(recorded: Path, tmp_path: Path) -> None:
    """The DBC's units on decoded signals, the field names' units on the internals."""
    log = read_canlog(recorded)
    assert unit_of(log, "ESC_Speed.VehicleSpeed") == "m/s"
    assert unit_of(log, "/ecu/outputs.desired_gap_m") == "m"
    assert unit_of(log, "/ecu/outputs.acc_state") == ""
    curves = signal_curves(
        log, ["ESC_Speed.VehicleSpeed", "desired_gap_m", "/ecu/outputs.acc_state"]
    )
    labels = [label for label, _, _ in curves]
    assert labels == [
        "ESC_Speed.VehicleSpeed, m/s",
        "/ecu/outputs.desired_gap_m, m",
        "/ecu/outputs.acc_state",
    ]
    out = tmp_path / "s.png"
    assert (
        plot_main([str(recorded), "ESC_Speed.VehicleSpeed", "desired_gap_m", "-o", str(out)]) == 0
    )
    assert out.stat().st_size > 0
