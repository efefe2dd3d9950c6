"""Closed loop on the virtual bus: the real ECU node and runtime against the simulator."""

from __future__ import annotations

import math
from functools import lru_cache

import can
import numpy as np
import pytest

from dbc.vocab.acc_state import AccState
from dbc.vocab.dgpt import Dgpt, SafetyBounds, clamp_to_bounds, speed_axis
from ecu.adaptation import AdaptationParams, Reason
from pacc.commands.drive import main
from pacc.study.drive import (
    CONTROLLERS,
    DriveConfig,
    DriveResult,
    adaptation_params,
    predefined_table,
    run_drive,
)
from sim_bus.drivers import BUILTIN_DRIVERS, DriverParams
from sim_bus.errors import DriveError
from sim_bus.lead.profile import LeadProfile
from sim_bus.lead.scenarios import canonical_profiles, shorten

SAFETY_MIN_GAP_M = 2.0  # SafetyBounds.standstill_min_m: the smallest gap the DGPT allows
JERK_LIMIT_MPS3 = 2.5


@lru_cache(maxsize=1)
def _profiles() -> dict[str, LeadProfile]:
    return canonical_profiles(0)


def _table_from(driver: DriverParams, factor: float, source: str = "irl") -> Dgpt:
    """A DGPT of ``factor`` × the driver's ACC preference, clamped to the safety bounds.

    Stands in for a table passed with ``--profile`` (the irl controllers in the matrix):
    learning five IRL tables would not fit the test budget; the trainer has its own tests.
    """
    v = speed_axis()
    gap = clamp_to_bounds(v, factor * driver.acc_preferred_gap_m(v), SafetyBounds())
    return Dgpt(
        speed_mps=v,
        gap_m=gap,
        version=1,
        driver_id=driver.driver_id,
        condition="dry",
        source=source,  # type: ignore[arg-type]
        created_utc="2000-01-01T00:00:00Z",
        meta={},
    )


@pytest.mark.slow
@pytest.mark.parametrize("driver_id", sorted(BUILTIN_DRIVERS))
def test_every_driver_with_every_controller_is_safe(driver_id: str) -> None:
    driver = BUILTIN_DRIVERS[driver_id]
    for controller in CONTROLLERS:
        table = (
            _table_from(driver, 1.08) if controller.startswith("irl") else predefined_table(driver)
        )
        cfg = DriveConfig(
            scenario="B",
            driver_id=driver_id,
            controller=controller,  # type: ignore[arg-type]
            seed=1,
            duration_s=40.0,
        )
        r = run_drive(cfg, driver, table, shorten(_profiles()["B"], 40.0))
        log = r.log
        assert not r.collision, (controller, r.collision_t_s)
        assert r.metrics.min_gap_m > SAFETY_MIN_GAP_M, controller
        assert np.all(np.isfinite(log.a_request_mps2)) and np.all(np.isfinite(log.gap_m))
        req = log.a_request_mps2[log.request_active]
        assert req.size > 100, controller  # the ACC really drove
        assert req.min() >= -3.5 - 1e-6 and req.max() <= 2.0 + 1e-6
        assert r.metrics.acc_on_s > 30.0 and math.isfinite(r.metrics.poi_pct)
        assert r.summary.e2e_errors == {}
        if not controller.endswith("+oa"):
            assert r.adaptations == 0


def _intervention(driver: DriverParams, factor: float) -> tuple[int, int, float]:
    table = _table_from(driver, factor, source="predefined")
    prof = shorten(_profiles()["manual3"], 90.0)
    r = run_drive(
        DriveConfig(scenario="manual3", driver_id=driver.driver_id, seed=2, duration_s=90.0),
        driver,
        table,
        prof,
    )
    log = r.log
    on = np.asarray(log.acc_state) >= AccState.ACTIVE
    acc = int((np.diff(log.accel_pressed.astype(int)) == 1)[on[1:]].sum())
    brk = int((np.diff(log.brake_pressed.astype(int)) == 1)[on[1:]].sum())
    assert not r.collision
    return acc, brk, r.metrics.poi_pct


@pytest.mark.slow
@pytest.mark.parametrize("driver_id", ["d1", "d3"])  # the extremes; d2 lies between them
def test_driver_sanity_against_the_table(driver_id: str) -> None:
    driver = BUILTIN_DRIVERS[driver_id]
    acc, brk, poi = _intervention(driver, 1.0)
    assert poi < 3.0 and acc + brk <= 1  # its own preference: near zero interventions
    acc, brk, poi = _intervention(driver, 0.5)
    assert brk >= 3 and brk > 3 * acc  # far shorter: it brakes
    acc, brk, poi = _intervention(driver, 2.0)
    assert acc >= 3 and acc > 3 * brk  # far longer: it accelerates


def _frames(seed: int, channel: str) -> list[tuple[float, int, bytes]]:
    driver = BUILTIN_DRIVERS["d5"]  # noisiest driver: random taps, drift, noise
    listener = can.Bus(interface="lockstep", channel=channel)
    try:
        run_drive(
            DriveConfig(
                scenario="B",
                driver_id="d5",
                controller="predefined+oa",
                seed=seed,
                duration_s=15.0,
                faults="ego:drop=0.05",
            ),
            driver,
            predefined_table(driver),
            record_channel=channel,
        )
        out = []
        while (m := listener.recv(0.0)) is not None:
            out.append((m.timestamp, m.arbitration_id, bytes(m.data)))
        return out
    finally:
        listener.shutdown()


def test_same_seed_same_frames() -> None:
    a = _frames(11, "det-a")
    b = _frames(11, "det-b")
    c = _frames(12, "det-c")
    assert len(a) > 3000
    assert a == b
    assert a != c


@pytest.mark.slow
def test_radar_dropout_faults_ramps_out_and_driver_takes_over() -> None:
    driver = BUILTIN_DRIVERS["d2"]
    prof = shorten(_profiles()["manual4"], 45.0)
    r = run_drive(
        DriveConfig(
            scenario="manual4",
            driver_id="d2",
            seed=3,
            duration_s=45.0,
            faults="radar:dropout=20-26",
        ),
        driver,
        _table_from(driver, 1.0, "predefined"),
        prof,
    )
    log = r.log
    assert not r.collision and r.metrics.min_gap_m > SAFETY_MIN_GAP_M
    t = log.t_s
    fault = log.acc_state == AccState.FAULT
    assert fault.any()
    t_fault = t[np.argmax(fault)]
    assert 20.0 < t_fault < 21.0  # radar times out after 10 periods (0.5 s)
    # the request ramps to zero within the jerk limit and then goes inactive
    ramp = (t >= t_fault - 0.1) & (t <= t_fault + 5.0)
    req = np.where(log.request_active, log.a_request_mps2, 0.0)[ramp]
    # log samples are 50 ms apart and commands 20 ms: two samples span at most 3 commands
    assert np.all(np.abs(np.diff(req)) <= JERK_LIMIT_MPS3 * 0.06 + 0.011)
    assert abs(req[-1]) < 0.011
    assert not log.request_active[(t > t_fault + 3.0) & (t < 26.0)].any()
    # the driver takes over by hand while the ACC is faulted
    during = (t > t_fault + 1.5) & (t < t_fault + 4.5)  # it tries RESUME after 5 s of fault
    assert (log.accel_pressed | log.brake_pressed)[during].all()
    # after the radar is back, the driver resumes and the ACC is active again
    assert (log.acc_state[t > 33.0] == AccState.ACTIVE).any()


@pytest.mark.slow
def test_corrupt_crcs_are_counted_and_never_acted_on() -> None:
    driver = BUILTIN_DRIVERS["d1"]
    prof = shorten(_profiles()["B"], 40.0)

    def run(faults: str) -> DriveResult:
        return run_drive(
            DriveConfig(scenario="B", driver_id="d1", seed=4, duration_s=40.0, faults=faults),
            driver,
            predefined_table(driver),
            prof,
        )

    bad = run("radar:crc=0.2")
    dropped = run("radar:drop=0.2")  # the same frames (one draw per frame), never sent
    assert bad.summary.e2e_errors.get("wrong_crc") == bad.frames_faulted > 100
    assert "wrong_crc" not in dropped.summary.e2e_errors
    # acting on nothing from a corrupted frame is the same as never receiving it
    assert np.array_equal(bad.log.a_request_mps2, dropped.log.a_request_mps2)
    assert np.array_equal(bad.log.gap_m, dropped.log.gap_m)
    assert not bad.collision


def test_brake_cancel_mode_driver_resumes() -> None:
    driver = BUILTIN_DRIVERS["d3"]
    r = run_drive(
        DriveConfig(scenario="B", driver_id="d3", seed=5, duration_s=60.0, brake_mode="cancel"),
        driver,
        _table_from(driver, 0.6, "predefined"),
        shorten(_profiles()["B"], 60.0),
    )
    s = r.log.acc_state
    assert not r.collision
    cancelled = (s[1:] == AccState.STANDBY) & (s[:-1] >= AccState.ACTIVE)  # brake: standby
    resumed = (s[1:] == AccState.ACTIVE) & (s[:-1] == AccState.STANDBY)
    assert cancelled.sum() >= 1 and resumed.sum() >= cancelled.sum()
    assert r.metrics.acc_on_s > 55.0  # standby after a cancel still counts as ACC-ON time


def test_bus_silence_faults_and_recovers() -> None:
    driver = BUILTIN_DRIVERS["d4"]
    prof = shorten(_profiles()["manual2"], 40.0)
    r = run_drive(
        DriveConfig(
            scenario="manual2", driver_id="d4", seed=6, duration_s=40.0, faults="all:silence=15-17"
        ),
        driver,
        _table_from(driver, 1.0, "predefined"),
        prof,
    )
    log = r.log
    assert not r.collision and r.metrics.min_gap_m > SAFETY_MIN_GAP_M
    fault_t = log.t_s[log.acc_state == AccState.FAULT]
    assert fault_t.size and 15.0 < fault_t[0] < 16.5
    assert sum(r.summary.faults.values()) >= 1  # counted by the ECU, by input
    assert (
        log.acc_state[log.t_s > 30.0] == AccState.ACTIVE
    ).any()  # SET again once the bus is back


@pytest.mark.slow
def test_adaptation_mode_reaches_the_ecu_and_is_traced() -> None:
    """``DriveConfig.adaptation`` selects the ECU's adaptation; every decision is traced."""
    driver = BUILTIN_DRIVERS["d3"]  # predefined 4 s against a ~2.8 s preference: presses
    table = predefined_table(driver)
    prof = shorten(_profiles()["B"], 60.0)
    widths = {}
    for mode in ("paper", "timegap"):
        cfg = DriveConfig(
            scenario="B",
            driver_id="d3",
            controller="predefined+oa",
            seed=0,
            duration_s=60.0,
            adaptation=AdaptationParams(mode=mode),
        )
        r = run_drive(cfg, driver, table, prof)
        applied = [e for e in r.adaptation_events if e.decision.applied]
        assert len(applied) == r.adaptations >= 1, mode
        assert [e.t_s for e in r.adaptation_events] == sorted(e.t_s for e in r.adaptation_events)
        assert all(e.decision.reason in Reason for e in r.adaptation_events)
        assert applied[-1].table is r.final_table
        before = table
        changed = []
        for e in r.adaptation_events:
            if e.decision.applied:
                changed.append(int(np.count_nonzero(np.abs(e.table.gap_m - before.gap_m) > 1e-9)))
                before = e.table
            else:
                assert e.table is before
        widths[mode] = max(changed)
    assert widths["paper"] <= 9  # the triangular window of Algorithm 1
    assert widths["timegap"] > 30  # a time-gap change spread over +-6 m/s and beyond


def test_adaptation_mode_flag_reaches_the_drive(capsys: pytest.CaptureFixture[str]) -> None:
    assert adaptation_params(None) is None
    params = adaptation_params("timegap")
    assert params is not None and params.mode == "timegap"
    assert (
        main(
            [
                "--driver",
                "d3",
                "--controller",
                "predefined+oa",
                "--duration",
                "20",
                "--adaptation-mode",
                "timegap",
            ]
        )
        == 0
    )
    assert "(timegap adaptation)" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["--adaptation-mode", "magic"])
    assert exc.value.code == 2


@pytest.mark.slow
def test_adapted_tables_are_reproducible() -> None:
    """Two runs of the same +OA drive give identical final tables, metadata included."""
    driver = BUILTIN_DRIVERS["d2"]
    cfg = DriveConfig(
        scenario="B", driver_id="d2", controller="predefined+oa", seed=2, duration_s=40.0
    )
    prof = shorten(_profiles()["B"], 40.0)
    one, two = (run_drive(cfg, driver, predefined_table(driver), prof) for _ in range(2))
    assert one.adaptations >= 1
    assert one.final_table.to_json_dict() == two.final_table.to_json_dict()
    assert one.final_table.created_utc == "2000-01-01T00:00:00Z"  # not the wall clock


def test_negative_seed_is_a_clear_error_even_with_a_given_profile() -> None:
    driver = BUILTIN_DRIVERS["d1"]
    profile = shorten(canonical_profiles(0)["B"], 5.0)
    with pytest.raises(DriveError, match="seed must be >= 0"):
        run_drive(DriveConfig(seed=-1), driver, predefined_table(driver), profile)
