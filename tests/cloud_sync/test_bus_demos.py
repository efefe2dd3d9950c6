"""A real car's bus log as demonstrations: a Toyota-network drive, exported to BLF, becomes
manual trip logs (``pacc demos extract``), and the table the cloud learns from them equals the
one learned from the ECU's own recording of the same manual driving.

The drive runs on opendbc's Toyota network (tools/opendbc_toyota.py, pacc's Toyota binding)
with the ACC never engaged: the simulated driver follows the lead by hand, and the ECU records
the manual car-following (:class:`ecu.manual.ManualRecorder`). Its bus recording goes to
Vector BLF through python-can (``pacc export``); the extraction reads the BLF, decodes it
through the binding and cuts the manual car-following stretches, sampling as the ECU did.

Two checks of the learned table:

- against the ECU's recording: **equal within 1e-9 m** (:data:`FLOAT_NOISE_M`). Both sample
  the same decoded frames at the same cycles with the same input checks, so every value is
  bit-identical; only the sample times differ, by float round-off (the ECU's clock reads
  ``k × 0.02`` from 0, the extraction's is the BLF's time relative to its first frame rounded
  to 1 µs, and the trip starts at 0): ~1e-14 s, which moves the learned gaps by far less than
  1e-9 m (measured: 0.0);
- against the simulator's exact trip log (``log_to_trip``, 10 Hz from the world at its own
  step): within 0.25 m (:data:`GAP_TOLERANCE_M`), since the bus carries the DBC's quantized
  values, sampled at the ECU's cycles, where the trip log holds the simulator's exact ones.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cloud_sync.irl.sources import bus_demos
from cloud_sync.irl.sources.bus_demos import extract_demos, read_frames
from cloud_sync.irl.trainer import learn_dgpt
from dbc import DATA_DIR
from dbc.codec import load_codec
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import read_trip
from ecu.config import EcuConfig
from pacc.commands.demos import main as demos_main
from pacc.commands.export import main as export_main
from pacc.study.drive import DriveConfig, log_to_trip, predefined_table, run_drive
from sim_bus.drivers import BUILTIN_DRIVERS

pytest.importorskip("opendbc")
from tools.opendbc_toyota import assemble  # noqa: E402

BINDING = DATA_DIR / "bindings" / "toyota_nodsu.binding.toml"
#: the tables learned from the ECU's recording and from the BLF may differ this much, m
#: (float noise of the sample times: module docstring)
FLOAT_NOISE_M = 1e-9
#: the tables learned from the simulator's exact trip log and from the BLF may differ this
#: much, m: the bus carries the DBC's quantized values, where the trip log holds exact ones
GAP_TOLERANCE_M = 0.25
FIELDS = ("v_mps", "gap_m", "v_lead_mps", "a_mps2", "accel_pedal", "brake_pedal", "acc_state")


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
    recorded: list[Trip] = []  # the ECU's own recording of the manual driving
    result = run_drive(
        cfg,
        driver,
        predefined_table(driver),
        can_log=tmp_path / "drive.mcap",
        manual_sink=recorded.append,
    )
    blf = tmp_path / "drive.blf"
    assert export_main([str(tmp_path / "drive.mcap"), str(blf)]) == 0
    argv = ["extract", str(blf), "--dbc", str(dbc), "--binding", str(BINDING)]
    assert demos_main([*argv, "--driver", "d2", "-o", str(tmp_path / "trips")]) == 0
    out = capsys.readouterr().out
    assert "kept 90.0 s" in out and "demos: 1 trip logs written" in out
    demo = read_trip(tmp_path / "trips" / "drive_000.mcap")
    assert demo.meta["mode"] == "manual" and demo.meta["driver_id"] == "d2"
    assert demo.t_s[-1] > 80.0

    # 1. the ECU's recording: the same samples, the same table within float noise
    assert len(recorded) == 1 and recorded[0].meta["mode"] == "manual"
    ecu_trip = recorded[0]
    for name in FIELDS:
        assert np.array_equal(getattr(ecu_trip, name), getattr(demo, name)), name
    assert np.abs((ecu_trip.t_s - ecu_trip.t_s[0]) - demo.t_s).max() < 1e-9
    from_ecu = learn_dgpt(recorded, driver_id="d2").table.to_json_dict()
    from_bus = learn_dgpt([demo], driver_id="d2").table.to_json_dict()
    assert from_ecu["meta"]["covered_mps"] == from_bus["meta"]["covered_mps"]
    noise = np.abs(np.asarray(from_ecu["gap_m"]) - np.asarray(from_bus["gap_m"]))
    assert noise.max() <= FLOAT_NOISE_M, noise.max()

    # 2. the simulator's exact trip log: the same table within the bus's quantization
    own = log_to_trip(result, driver)
    fields = ("t_s", "v_mps", "gap_m", "v_lead_mps", "a_mps2", "accel_pedal", "brake_pedal")
    manual = Trip(
        **{f: getattr(own, f) for f in fields},
        acc_state=own.acc_state,
        meta={**own.meta, "mode": "manual"},
    )
    from_trip = learn_dgpt([manual], driver_id="d2").table.to_json_dict()
    assert from_trip["meta"]["covered_mps"] == from_bus["meta"]["covered_mps"]
    diff = np.abs(np.asarray(from_trip["gap_m"]) - np.asarray(from_bus["gap_m"]))
    assert diff.max() < GAP_TOLERANCE_M, diff.max()


def test_the_ecu_and_the_extraction_cut_the_same_stretches(tmp_path: Path) -> None:
    """A drive with engagements, takeovers (brake: cancel), cut-ins and a pedal frame
    dropout: the ECU's manual trips and those extracted from its bus log are the same,
    sample for sample (pacc's network)."""
    driver = BUILTIN_DRIVERS["d3"]
    cfg = DriveConfig(
        scenario="cutin",
        driver_id="d3",
        seed=0,
        duration_s=120,
        faults="pedals:dropout=50-51",
        brake_mode="cancel",
    )
    recorded: list[Trip] = []
    run_drive(
        cfg,
        driver,
        predefined_table(driver),
        can_log=tmp_path / "d.mcap",
        manual_sink=recorded.append,
    )
    report = extract_demos(tmp_path / "d.mcap", load_codec(), driver_id="d3")
    assert report.dropped_s["ACC engaged (the ECU drives, not the driver)"] > 20.0
    assert len(recorded) == len(report.trips) >= 2
    for ecu_trip, demo in zip(recorded, report.trips, strict=True):
        assert ecu_trip.t_s[0] == pytest.approx(demo.meta["log_t0_s"], abs=1e-9)
        for name in FIELDS:
            assert np.array_equal(getattr(ecu_trip, name), getattr(demo, name)), name


def test_the_extraction_samples_at_the_ecu_recorders_period() -> None:
    """cloud_sync does not import ecu: the trips' period is checked here (the keep rule and
    the stretches' limits both import from dbc.vocab.sampling)."""
    assert EcuConfig().record_period_s == bus_demos.DT_S


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


def test_a_log_without_acc_frames_is_sampled_on_a_grid(tmp_path: Path) -> None:
    """Another car's log (no command frames here: the ECU's are removed) is sampled on a
    0.1-s grid from its first frame, each grid point seeing the frames up to it: in a drive
    whose ECU ran on the same grid, the values equal the ECU's recording; the ACC state is
    OFF (no ACC frames)."""
    driver = BUILTIN_DRIVERS["d2"]
    cfg = DriveConfig(scenario="manual1", driver_id="d2", seed=3, duration_s=30, engage_s=1e6)
    recorded: list[Trip] = []
    run_drive(
        cfg,
        driver,
        predefined_table(driver),
        can_log=tmp_path / "d.mcap",
        manual_sink=recorded.append,
    )
    codec = load_codec()
    acc = {p.frame_id for p in codec.roles["command"].parts}
    frames = [m for m in read_frames(tmp_path / "d.mcap") if m.arbitration_id not in acc]
    report = extract_demos(tmp_path / "d.mcap", codec, driver_id="d2", frames=frames)
    (demo,) = report.trips
    (ecu_trip,) = recorded
    assert len(demo) == len(ecu_trip) == 300
    assert np.abs(np.diff(demo.t_s) - 0.1).max() < 1e-12
    for name in FIELDS[:-1]:
        assert np.array_equal(getattr(ecu_trip, name), getattr(demo, name)), name
    assert set(demo.acc_state.tolist()) == {0}
