"""A real car's bus log as demonstrations: a Toyota-network drive, exported to BLF, becomes
manual trip logs (``pacc demos extract``), and the table the cloud learns from them matches
the one learned from the same drive's own trip log.

The drive runs on opendbc's Toyota network (tools/opendbc_toyota.py, pacc's Toyota binding)
with the ACC never engaged: the simulated driver follows the lead by hand. Its bus recording
goes to Vector BLF through python-can (``pacc export``); the extraction reads the BLF,
decodes it through the binding and cuts the manual car-following stretches.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cloud_sync.irl.bus_demos import extract_demos
from cloud_sync.irl.trainer import learn_dgpt
from dbc import DATA_DIR
from dbc.codec import load_codec
from pacc.commands.demos import main as demos_main
from pacc.commands.export import main as export_main
from pacc.vocab.triplog import Trip
from pacc.vocab.triplog_file import read_trip
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.study.drive import DriveConfig, log_to_trip, predefined_table, run_drive

pytest.importorskip("opendbc")
from tools.opendbc_toyota import assemble  # noqa: E402

BINDING = DATA_DIR / "bindings" / "toyota_nodsu.binding.toml"
#: the learned gaps may differ this much: the bus carries the DBC's quantized values, sampled
#: at 10 Hz from the frames' times, where the trip log holds the simulator's exact ones
GAP_TOLERANCE_M = 0.25


@pytest.mark.slow
def test_a_toyota_blf_becomes_demonstrations_that_learn_the_same_table(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    dbc = tmp_path / "toyota_nodsu_pt_generated.dbc"
    dbc.write_text(assemble())
    driver = BUILTIN_DRIVERS["d2"]
    cfg = DriveConfig(
        scenario="manual1",
        driver_id="d2",
        controller="predefined",
        seed=3,
        duration_s=90,
        engage_s=1e6,  # never: the driver drives
        dbc=str(dbc),
        binding=str(BINDING),
    )
    result = run_drive(cfg, driver, predefined_table(driver), can_log=tmp_path / "drive.mcap")
    blf = tmp_path / "drive.blf"
    assert export_main([str(tmp_path / "drive.mcap"), str(blf)]) == 0
    argv = ["extract", str(blf), "--dbc", str(dbc), "--binding", str(BINDING)]
    assert demos_main([*argv, "--driver", "d2", "-o", str(tmp_path / "trips")]) == 0
    out = capsys.readouterr().out
    assert "kept" in out and "demos: 1 trip logs written" in out
    demo = read_trip(tmp_path / "trips" / "drive_000.mcap")
    assert demo.meta["mode"] == "manual" and demo.meta["driver_id"] == "d2"
    assert demo.t_s[-1] > 80.0
    own = log_to_trip(result, driver)
    fields = ("t_s", "v_mps", "gap_m", "v_lead_mps", "a_mps2", "accel_pedal", "brake_pedal")
    manual = Trip(
        **{f: getattr(own, f) for f in fields},
        acc_state=own.acc_state,
        meta={**own.meta, "mode": "manual"},
    )
    from_trip = learn_dgpt([manual], driver_id="d2")
    from_bus = learn_dgpt([demo], driver_id="d2")
    a, b = from_trip.table.to_json_dict(), from_bus.table.to_json_dict()
    assert a["meta"]["covered_mps"] == b["meta"]["covered_mps"]
    diff = np.abs(np.asarray(a["gap_m"]) - np.asarray(b["gap_m"]))
    assert diff.max() < GAP_TOLERANCE_M, diff.max()


def test_what_is_not_manual_following_is_dropped_with_its_reason(tmp_path: Path) -> None:
    """A drive whose ACC engages after 1.5 s: only the first second is manual (too short), the
    rest is dropped as 'ACC engaged'."""
    driver = BUILTIN_DRIVERS["d1"]
    cfg = DriveConfig(scenario="B", driver_id="d1", controller="predefined", seed=1, duration_s=20)
    run_drive(cfg, driver, predefined_table(driver), can_log=tmp_path / "d.mcap")
    report = extract_demos(tmp_path / "d.mcap", load_codec(), driver_id="d1")
    assert report.trips == [] and report.kept_s == 0.0
    assert report.dropped_s["ACC engaged (the ECU drives, not the driver)"] > 15.0
    assert sum(report.dropped_s.values()) == pytest.approx(20.0, abs=0.3)
    assert demos_main(["extract", str(tmp_path / "d.mcap"), "-o", str(tmp_path / "t")]) == 1
