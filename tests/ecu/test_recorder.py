"""Takeover recorder: pre-trigger ring buffer, post window, merged takeovers, MCAP sink."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import read_trip
from ecu.recorder import (
    MAX_PENDING,
    RecorderError,
    Sample,
    SinkQueue,
    TakeoverRecorder,
    directory_sink,
)


def feed(rec: TakeoverRecorder, t0: float, t1: float, state: int = 2, dt: float = 0.02) -> float:
    t = t0
    while t < t1 - 1e-9:
        rec.sample(Sample(t, 20.0, 30.0 if state != 1 else math.nan, 20.0, 0.0, 0.1, 0.0, state))
        t = round(t + dt, 6)
    return t


def test_segment_spans_pre_takeover_and_post() -> None:
    out: list[Trip] = []
    rec = TakeoverRecorder(out.append, meta={"driver_id": "d1"})
    feed(rec, 0.0, 20.0)
    rec.start(20.0, "brake")
    feed(rec, 20.0, 22.0, state=3)
    rec.release(22.0, "applied")
    feed(rec, 22.0, 26.9)
    assert not out  # the post window is still open
    feed(rec, 26.9, 30.0)
    assert len(out) == 1
    trip = out[0]
    assert trip.t_s[0] == pytest.approx(15.0) and trip.t_s[-1] == pytest.approx(27.0)
    assert len(trip) == 121  # 50 pre + 20 takeover + 51 post (10 Hz, both ends)
    assert trip.meta["mode"] == "takeover" and trip.meta["driver_id"] == "d1"
    assert trip.meta["takeovers"] == [
        {"start_s": 20.0, "pedal": "brake", "release_s": 22.0, "adaptation": "applied"}
    ]
    assert set(trip.acc_state.tolist()) == {2, 3}


def test_takeover_in_post_window_extends_segment() -> None:
    out: list[Trip] = []
    rec = TakeoverRecorder(out.append)
    feed(rec, 0.0, 10.0)
    rec.start(10.0, "accel")
    feed(rec, 10.0, 11.0, state=3)
    rec.release(11.0, "short_takeover")
    feed(rec, 11.0, 14.0)
    rec.start(14.0, "accel")
    feed(rec, 14.0, 16.0, state=3)
    rec.release(16.0, "applied")
    feed(rec, 16.0, 25.0)
    assert len(out) == 1
    assert [x["adaptation"] for x in out[0].meta["takeovers"]] == ["short_takeover", "applied"]
    assert out[0].t_s[-1] == pytest.approx(21.0)


def test_flush_emits_open_segment_and_short_history() -> None:
    out: list[Trip] = []
    rec = TakeoverRecorder(out.append)
    feed(rec, 0.0, 1.0)
    rec.start(1.0, "accel")
    feed(rec, 1.0, 2.0, state=3)
    rec.flush()
    assert len(out) == 1 and out[0].t_s[0] == 0.0
    assert "release_s" not in out[0].meta["takeovers"][0]


def test_sink_failure_counted_not_raised() -> None:
    def broken(trip: Trip) -> None:
        raise OSError("disk full")

    rec = TakeoverRecorder(broken)
    feed(rec, 0.0, 1.0)
    rec.start(1.0, "accel")
    rec.flush()
    assert rec.queue.sink_errors == 1 and rec.segments == 1


def _takeover(rec: TakeoverRecorder, t0: float) -> None:
    """History, a 2-s takeover from ``t0 + 10`` s and its full post window."""
    feed(rec, t0, t0 + 10.0)
    rec.start(t0 + 10.0, "accel")
    feed(rec, t0 + 10.0, t0 + 12.0, state=3)
    rec.release(t0 + 12.0, "applied")
    feed(rec, t0 + 12.0, t0 + 18.0)


def test_segment_survives_a_sink_failure_and_is_stored_later(tmp_path: Path) -> None:
    """The takeover medium goes away for a while (here the directory is replaced by a file):
    the segment is kept and stored at the next emit, or at the end of the trip."""
    d = tmp_path / "to"
    rec = TakeoverRecorder(directory_sink(d))
    d.rmdir()
    d.write_text("the medium is gone")
    _takeover(rec, 0.0)
    assert rec.queue.sink_errors >= 1 and rec.segments == 1
    d.unlink()
    d.mkdir()
    _takeover(rec, 30.0)  # the medium is back: both segments are written
    files = sorted(d.glob("*.mcap"))
    assert [read_trip(f).meta["index"] for f in files] == [0, 1]
    d.rename(tmp_path / "away")
    d.write_text("gone again")
    _takeover(rec, 60.0)
    d.unlink()
    d.mkdir()
    rec.flush()  # end of trip: the pending segment is stored
    assert [read_trip(f).meta["index"] for f in d.glob("*.mcap")] == [2]


def test_directory_sink_writes_mcap(tmp_path: Path) -> None:
    sink = directory_sink(tmp_path / "to")
    rec = TakeoverRecorder(sink, meta={"seed": 3})
    for k in range(2):
        feed(rec, 30.0 * k, 30.0 * k + 10.0)
        rec.start(30.0 * k + 10.0, "accel")
        feed(rec, 30.0 * k + 10.0, 30.0 * k + 12.0, state=3)
        rec.release(30.0 * k + 12.0, "applied")
        feed(rec, 30.0 * k + 12.0, 30.0 * k + 18.0)
    files = sorted((tmp_path / "to").glob("*.mcap"))
    assert [f.name for f in files] == ["takeover_0000.mcap", "takeover_0001.mcap"]
    back = read_trip(files[1])
    assert back.meta["mode"] == "takeover" and back.meta["seed"] == 3 and back.meta["index"] == 1
    assert len(back) == 50 + 20 + 51
    # a second recorder on the same directory never overwrites
    sink2 = directory_sink(tmp_path / "to")
    rec2 = TakeoverRecorder(sink2)
    feed(rec2, 0.0, 1.0)
    rec2.start(1.0, "brake")
    rec2.flush()
    assert len(list((tmp_path / "to").glob("*.mcap"))) == 3


def test_directory_sink_refuses_a_file(tmp_path: Path) -> None:
    f = tmp_path / "plain"
    f.write_text("x")
    with pytest.raises(RecorderError, match="cannot create"):
        directory_sink(f)


def test_segments_of_a_real_time_ecu_are_stamped_with_utc(tmp_path: Path) -> None:
    from mcap.reader import make_reader  # noqa: PLC0415

    from ecu.buslog.format import TimeBase  # noqa: PLC0415

    base = TimeBase(1_790_000_000_000_000_000, 5000.0)  # boot clock 5000 s = that UTC
    rec = TakeoverRecorder(directory_sink(tmp_path), utc_of=base.iso)
    feed(rec, 5000.0, 5010.0)
    rec.start(5010.0, "accel")
    feed(rec, 5010.0, 5012.0, state=3)
    rec.release(5012.0, "applied")
    rec.flush()
    path = tmp_path / "takeover_0000.mcap"
    trip = read_trip(path)
    assert trip.meta["start_utc"] == base.iso(5005.0) == "2026-09-21T14:13:25.000000Z"
    with path.open("rb") as fh:
        stamps = sorted(m.log_time for _, _, m in make_reader(fh).iter_messages())
    # the first sample at its UTC, the others at their offsets from it
    assert stamps[0] == base.utc_ns(5005.0) and stamps[-1] == base.utc_ns(trip.t_s[-1])
    assert trip.t_s[0] == pytest.approx(5005.0)  # the samples keep the node's clock


def test_segments_without_a_utc_map_keep_their_old_stamps(tmp_path: Path) -> None:
    from mcap.reader import make_reader  # noqa: PLC0415

    rec = TakeoverRecorder(directory_sink(tmp_path))
    feed(rec, 0.0, 10.0)
    rec.start(10.0, "brake")
    rec.release(11.0, "applied")
    rec.flush()
    path = tmp_path / "takeover_0000.mcap"
    assert "start_utc" not in read_trip(path).meta
    with path.open("rb") as fh:
        first = min(m.log_time for _, _, m in make_reader(fh).iter_messages())
    assert first == 5_000_000_000  # t_s itself: lockstep segments stay byte-identical


def test_the_queue_counts_what_the_sink_took_and_what_was_lost() -> None:
    """A sink down for MAX_PENDING + 6 trips: the 6 oldest are lost, none stored; back up, the
    rest are stored in order; a trip that cannot be built (no samples) is lost too."""
    stored: list[int] = []
    up = False

    def sink(trip: Trip) -> None:
        if not up:
            raise OSError("disk full")
        stored.append(int(trip.meta["index"]))

    queue = SinkQueue(sink, "trip")
    sample = Sample(0.0, 10.0, 30.0, 10.0, 0.0, 0.0, 0.0, 2)
    for i in range(MAX_PENDING + 6):
        queue.build([sample, Sample(0.1, 10.0, 30.0, 10.0, 0.0, 0.0, 0.0, 2)], {"index": i})
    assert (queue.stored, queue.lost, len(queue.pending)) == (0, 6, MAX_PENDING)
    up = True
    queue.store()
    assert stored == list(range(6, MAX_PENDING + 6)) and queue.stored == MAX_PENDING
    queue.build([], {"index": -1})
    assert (queue.stored, queue.lost, len(queue.pending)) == (MAX_PENDING, 7, 0)
