"""Manual-driving recorder: the driver's car-following stretches (ACC not engaged, a lead,
inputs good) as manual trip logs, the takeover recorder's sampling, a failing sink retried
(also at the end of the trip), a clock UTC cannot map, and the ACC-on time the takeover
recorder keeps for the trip report."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from dbc.vocab.acc_state import AccState, FaultCode
from dbc.vocab.dgpt import predefined
from dbc.vocab.sampling import MANUAL_MAX_S, keep_sample
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import read_trip
from ecu.buslog.format import TimeBase
from ecu.config import EcuConfig
from ecu.manual import ManualRecorder
from ecu.node import EcuNode
from ecu.recorder import RecorderError, Sample, TakeoverRecorder, directory_sink
from ecu.signals import NodeInputs

OFF, STANDBY, ACTIVE = int(AccState.OFF), int(AccState.STANDBY), int(AccState.ACTIVE)


def feed(
    rec: ManualRecorder,
    t0: float,
    t1: float,
    *,
    state: int = OFF,
    lead: bool = True,
    fault: FaultCode = FaultCode.NONE,
    dt: float = 0.02,
) -> float:
    """50-Hz cycles from t0 to t1 (exclusive), s; returns t1."""
    t = t0
    while t < t1 - 1e-9:
        gap = 30.0 + t if lead else math.nan
        rec.sample(Sample(t, 20.0, gap, 20.0, 0.1, 0.2, 0.0, state), fault)
        t = round(t + dt, 6)
    return t


def test_a_manual_stretch_becomes_one_trip_at_10_hz() -> None:
    out: list[Trip] = []
    rec = ManualRecorder(out.append, meta={"driver_id": "d2", "condition": "default"})
    feed(rec, 0.0, 15.0)
    assert not out  # still open
    feed(rec, 15.0, 16.0, state=ACTIVE)  # the ACC engages: the stretch ends
    assert len(out) == 1
    trip = out[0]
    assert len(trip) == 150 and trip.t_s[0] == 0.0 and trip.t_s[-1] == pytest.approx(14.9)
    assert trip.meta == {"driver_id": "d2", "condition": "default", "mode": "manual", "index": 0}
    assert trip.gap_m[10] == pytest.approx(31.0) and trip.accel_pedal[0] == pytest.approx(0.2)
    assert rec.trips == 1 and rec.kept_s == pytest.approx(15.0)


@pytest.mark.parametrize(
    ("why", "kwargs"),
    [
        ("no lead", {"lead": False}),
        ("ACC active", {"state": ACTIVE}),
        ("stale speed", {"fault": FaultCode.SPEED_INPUT}),
        ("stale pedals", {"fault": FaultCode.PEDAL_INPUT}),
        ("stale radar", {"fault": FaultCode.RADAR_INPUT}),
    ],
)
def test_what_is_not_manual_following_ends_the_stretch(why: str, kwargs: dict[str, object]) -> None:
    out: list[Trip] = []
    rec = ManualRecorder(out.append, min_s=5.0)
    feed(rec, 0.0, 6.0)
    feed(rec, 6.0, 6.5, **kwargs)  # type: ignore[arg-type]
    feed(rec, 6.5, 9.0)  # 2.5 s: shorter than min_s
    rec.flush()
    assert [len(t) for t in out] == [60], why
    assert rec.short_s == pytest.approx(2.5)


def test_standby_and_a_stale_hmi_are_still_manual() -> None:
    out: list[Trip] = []
    rec = ManualRecorder(out.append, min_s=1.0)
    feed(rec, 0.0, 1.0, state=STANDBY)
    feed(rec, 1.0, 2.0, fault=FaultCode.HMI_INPUT)  # the buttons' frame: not needed
    rec.flush()
    assert [len(t) for t in out] == [20]


def test_a_long_stretch_is_handed_over_in_pieces() -> None:
    out: list[Trip] = []
    rec = ManualRecorder(out.append, min_s=2.0, max_s=5.0)
    feed(rec, 0.0, 11.5)
    rec.flush()
    assert [len(t) for t in out] == [50, 50]  # the last 1.5 s is too short
    assert out[1].t_s[0] == pytest.approx(5.0) and [t.meta["index"] for t in out] == [0, 1]
    assert rec.short_s == pytest.approx(1.5)
    assert MANUAL_MAX_S >= 60.0


def test_a_failing_sink_is_retried_and_never_raises(tmp_path: Path) -> None:
    stored: list[Trip] = []
    broken = [True]

    def sink(trip: Trip) -> None:
        if broken[0]:
            raise OSError("disk full")
        stored.append(trip)

    rec = ManualRecorder(sink, min_s=1.0)
    feed(rec, 0.0, 2.0)
    feed(rec, 2.0, 2.1, lead=False)
    assert rec.queue.sink_errors == 1 and len(rec.queue.pending) == 1 and not stored
    broken[0] = False
    feed(rec, 2.1, 4.0)
    rec.flush()
    assert [len(t) for t in stored] == [20, 19]
    assert not rec.queue.pending


def test_a_driver_switch_ends_the_stretch() -> None:
    out: list[Trip] = []
    rec = ManualRecorder(out.append, min_s=1.0, meta={"driver_id": "d1"})
    feed(rec, 0.0, 2.0)
    rec.set_meta({"driver_id": "d1"})  # unchanged: goes on
    feed(rec, 2.0, 3.0)
    rec.set_meta({"driver_id": "d4"})
    feed(rec, 3.0, 5.0)
    rec.flush()
    assert [(len(t), t.meta["driver_id"]) for t in out] == [(30, "d1"), (20, "d4")]


def test_directory_sink_and_bad_arguments(tmp_path: Path) -> None:
    rec = ManualRecorder(directory_sink(tmp_path, "manual"), min_s=1.0, utc_of=lambda t: "X")
    feed(rec, 0.0, 2.0)
    rec.flush()
    trip = read_trip(tmp_path / "manual_0000.mcap")
    assert trip.meta["mode"] == "manual" and trip.meta["start_utc"] == "X" and len(trip) == 20
    with pytest.raises(RecorderError):
        ManualRecorder(lambda t: None, min_s=20.0, max_s=10.0)


def test_the_node_records_manual_driving_beside_the_takeovers() -> None:
    """EcuNode(manual_sink=...): the ACC off behind a lead, then the driver engages."""
    manual: list[Trip] = []
    node = EcuNode(EcuConfig(), predefined(1.5, driver_id="d5"), manual_sink=manual.append)
    inp = NodeInputs(v_mps=20.0, lead_valid=True, gap_m=35.0)
    for k in range(1000):  # 20 s at 50 Hz; main switch on at 5 s, SET at 12 s
        inp.main_switch = k >= 250
        inp.set_button = 600 <= k < 610
        node.step(inp, k * 0.02)
    node.finish()
    assert node.state is AccState.ACTIVE
    assert len(manual) == 1 and manual[0].meta["driver_id"] == "d5"
    assert manual[0].t_s[-1] == pytest.approx(11.9)  # SET at 12 s engages in its own cycle
    assert set(manual[0].acc_state.tolist()) == {OFF, STANDBY}


def test_the_takeover_recorder_keeps_the_acc_on_time() -> None:
    rec = TakeoverRecorder(lambda t: None)
    for k in range(500):  # OFF 2 s, STANDBY 2 s, ACTIVE 4 s, STANDBY 2 s (counted: engaged)
        t = k * 0.02
        state = OFF if t < 2 else STANDBY if t < 4 else ACTIVE if t < 8 else STANDBY
        rec.sample(Sample(t, 20.0, 30.0, 20.0, 0.0, 0.0, 0.0, state))
    assert rec.acc_on_s == pytest.approx(5.9)  # 4 + 2 s, less the last sample's 0.1


def test_jittering_real_time_cycles_are_kept_every_fifth() -> None:
    """keep_sample: a real-time ECU's cycles jitter (here +-4 ms around the 20-ms grid); the
    manual recorder keeps every 5th, where ``period_s - 1 µs`` drifts to the 6th."""
    rng = np.random.default_rng(7)
    times = np.arange(1000) * 0.02 + rng.uniform(-0.004, 0.004, 1000)
    kept, strict, last, last_strict = [], [], -math.inf, -math.inf
    for t in times.tolist():
        if keep_sample(t, last, 0.1, 0.02):
            kept.append(t)
            last = t
        if keep_sample(t, last_strict, 0.1, 0.0):
            strict.append(t)
            last_strict = t
    assert len(kept) == 200 and np.abs(np.diff(kept) - 0.1).max() < 0.009
    assert len(strict) < 190  # the old rule loses samples to the jitter
    out: list[Trip] = []
    rec = ManualRecorder(out.append, cycle_s=0.02, min_s=1.0)
    offered: list[Trip] = []  # as the node offers: only from next_due_s on
    pre = ManualRecorder(offered.append, cycle_s=0.02, min_s=1.0)
    for t in times.tolist():
        rec.sample(Sample(t, 20.0, 30.0, 20.0, 0.0, 0.0, 0.0, OFF), FaultCode.NONE)
        if t >= pre.next_due_s:
            pre.sample(Sample(t, 20.0, 30.0, 20.0, 0.0, 0.0, 0.0, OFF), FaultCode.NONE)
    rec.flush()
    pre.flush()
    assert [len(t) for t in out] == [200]
    assert np.array_equal(offered[0].t_s, out[0].t_s)


def test_flush_retries_the_pending_trips_behind_a_short_open_stretch() -> None:
    """A trip the sink refused is offered again at the end of the trip, also when the
    stretch still open then is too short to be a trip."""
    stored: list[Trip] = []
    broken = [True]

    def sink(trip: Trip) -> None:
        if broken[0]:
            raise OSError(28, "No space left on device")
        stored.append(trip)

    rec = ManualRecorder(sink, min_s=5.0, cycle_s=0.02)
    feed(rec, 0.0, 6.0)
    feed(rec, 6.0, 7.0, state=ACTIVE)  # the stretch ends: the sink fails, the trip is kept
    assert len(rec.queue.pending) == 1 and not stored
    broken[0] = False  # room again
    feed(rec, 7.0, 8.0)  # 1 s open at the end: too short
    rec.flush()
    assert [len(t) for t in stored] == [60] and not rec.queue.pending
    assert rec.queue.sink_errors == 1 and rec.short_s == pytest.approx(1.0)


def test_flush_retries_the_pending_segments_behind_an_empty_takeover() -> None:
    """The takeover recorder alike: a takeover opened with nothing recorded yet."""
    stored: list[Trip] = []
    broken = [True]

    def sink(trip: Trip) -> None:
        if broken[0]:
            raise OSError(28, "No space left on device")
        stored.append(trip)

    rec = TakeoverRecorder(sink, pre_s=1.0, post_s=0.5)
    rec.start(0.0, "brake")
    rec.release(0.0, "none")
    for k in range(6):  # the post window ends at the last sample: the sink fails
        rec.sample(Sample(k * 0.1, 20.0, 30.0, 20.0, 0.0, 0.0, 0.5, ACTIVE))
    assert len(rec.queue.pending) == 1 and not stored
    broken[0] = False
    rec.start(0.6, "accel")  # nothing sampled since the segment: an empty one
    rec.flush()
    assert [len(t) for t in stored] == [6] and not rec.queue.pending


def test_a_clock_utc_cannot_map_costs_the_field_not_the_trip_nor_the_loop(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """utc_of raising (the node's clock at 1e12 s: a year past 9999) is logged, the trips
    keep everything else, and EcuNode.step never raises."""
    manual: list[Trip] = []
    takeovers: list[Trip] = []
    base = TimeBase.now(0.0)
    node = EcuNode(
        EcuConfig(pre_trigger_s=0.5, post_trigger_s=0.5),
        predefined(1.5, driver_id="d1"),
        takeovers.append,
        utc_of=base.iso,
        manual_sink=manual.append,
        manual_min_s=1.0,
    )
    inp = NodeInputs(v_mps=20.0, lead_valid=True, gap_m=30.0)
    t0 = 1e12
    for k in range(100):  # 2 s of manual following, then the radar times out
        node.step(inp, t0 + k * 0.02)
    inp.radar_ok = False
    for k in range(100, 110):
        node.step(inp, t0 + k * 0.02)
    node.finish()
    assert len(manual) == 1 and "start_utc" not in manual[0].meta
    assert manual[0].meta["driver_id"] == "d1" and len(manual[0]) == 20
    assert "no start_utc" in caplog.text
    ok = TakeoverRecorder(takeovers.append, utc_of=base.iso)
    ok.start(1e12, "brake")
    ok.sample(Sample(1e12, 20.0, 30.0, 20.0, 0.0, 0.0, 0.5, ACTIVE))
    ok.flush()
    assert len(takeovers) == 1 and "start_utc" not in takeovers[0].meta
