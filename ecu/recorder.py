"""The ECU's takeover recorder and the queue its trips, and the manual ones, go through.

:class:`TakeoverRecorder` keeps one sample every ``period_s`` (s) in a ring buffer of the last
``pre_s`` seconds; a takeover makes the buffer the head of a segment, which runs through the
pedal release and ``post_s`` seconds after it (a takeover in that window extends it) and goes
to the sink as a :class:`dbc.vocab.triplog.Trip` with ``meta["mode"] == "takeover"``.
"""

from __future__ import annotations

import logging
import math
import os
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass, fields
from operator import attrgetter
from pathlib import Path
from typing import Any

import numpy as np

from dbc.vocab.acc_state import AccState
from dbc.vocab.sampling import PERIOD_EPS_S
from dbc.vocab.triplog import Trip
from dbc.vocab.triplog_file import write_trip
from dbc.vocab.tripmode import TripMode
from ecu import EcuError

log = logging.getLogger(__name__)

TripSink = Callable[[Trip], None]
#: Trips kept for a retry while the sink fails; beyond it the oldest is dropped (logged).
MAX_PENDING = 64
_ENGAGED = (int(AccState.ACTIVE), int(AccState.OVERRIDE))


class RecorderError(EcuError):
    """The takeover directory cannot be used."""


@dataclass(frozen=True, slots=True)
class Sample:
    """One recorded instant: SI units, pedals 0..1, ``acc_state`` an AccState code."""

    t_s: float
    v_mps: float
    gap_m: float
    v_lead_mps: float
    a_mps2: float
    accel_pedal: float
    brake_pedal: float
    acc_state: int


_values = attrgetter(*(f.name for f in fields(Sample)))


def trip_of(samples: list[Sample], meta: dict[str, Any]) -> Trip:
    """The samples as a trip log, pedals clipped to 0..1 (TripLogError: not a valid trip)."""
    t, v, gap, v_lead, a, accel, brake, state = (
        np.asarray(c) for c in zip(*map(_values, samples), strict=True)
    )
    return Trip(
        t_s=t,
        v_mps=v,
        gap_m=gap,
        v_lead_mps=v_lead,
        a_mps2=a,
        accel_pedal=np.clip(accel, 0.0, 1.0),
        brake_pedal=np.clip(brake, 0.0, 1.0),
        acc_state=state.astype(np.int64),
        meta=meta,
    )


class SinkQueue:
    """Trips on their way to ``sink``: a refused trip is kept (up to :data:`MAX_PENDING`) and
    offered again, in order; the sink's exceptions are logged and counted, never raised
    (``what``: the trips' name in log lines)."""

    def __init__(self, sink: TripSink, what: str) -> None:
        self.sink = sink
        self.what = what
        self.sink_errors = 0
        #: trips the sink took, and trips lost (not built, or dropped beyond MAX_PENDING)
        self.stored = 0
        self.lost = 0
        #: trips the sink refused so far and not yet stored
        self.pending: deque[Trip] = deque()

    def build(
        self,
        samples: list[Sample],
        meta: dict[str, Any],
        utc_of: Callable[[float], str] | None = None,
    ) -> None:
        """Queue the trip of ``samples`` (``meta["start_utc"] = utc_of(first t_s)`` when given)
        and store what is pending; a trip that cannot be built is counted, logged and dropped.
        Never raises."""
        if utc_of is not None and samples:
            try:
                meta["start_utc"] = utc_of(samples[0].t_s)
            except Exception as exc:  # noqa: BLE001 - never stop the control loop
                log.error("%s %s: no start_utc: %s", self.what, meta.get("index"), exc)
        try:
            trip = trip_of(samples, meta)
        except Exception as exc:  # noqa: BLE001 - never stop the control loop
            self.sink_errors += 1
            self.lost += 1
            log.error("%s %s not built: %s", self.what, meta.get("index"), exc)
            self.store()
            return
        if len(self.pending) >= MAX_PENDING:
            lost = self.pending.popleft()
            self.lost += 1
            log.error("%s %s dropped: sink failing", self.what, lost.meta.get("index"))
        self.pending.append(trip)
        self.store()

    def store(self) -> None:
        """Hand the pending trips to the sink, oldest first, until one fails."""
        while self.pending:
            trip = self.pending[0]
            try:
                self.sink(trip)
            except Exception as exc:  # noqa: BLE001 - I/O edge: never stop the control loop
                self.sink_errors += 1
                log.error(
                    "%s %s not stored (kept for a retry): %s",
                    self.what,
                    trip.meta.get("index"),
                    exc,
                )
                return
            self.pending.popleft()
            self.stored += 1


class TakeoverRecorder:
    """Ring buffer plus open segment (module docstring) for ``sink``: ``period_s`` / ``pre_s`` /
    ``post_s`` recording period, pre-trigger and post-release lengths, s; ``meta`` copied into every
    segment; ``utc_of``: node clock (s) -> ISO 8601 UTC for ``meta["start_utc"]``."""

    def __init__(
        self,
        sink: TripSink,
        *,
        period_s: float = 0.1,
        pre_s: float = 5.0,
        post_s: float = 5.0,
        meta: Mapping[str, Any] | None = None,
        utc_of: Callable[[float], str] | None = None,
    ) -> None:
        if not (period_s > 0.0 and pre_s >= 0.0 and post_s >= 0.0):
            raise RecorderError("recorder periods must be positive")
        self.queue = SinkQueue(sink, "takeover segment")
        self.period_s = period_s
        self.post_s = post_s
        self.meta = dict(meta or {})
        self.utc_of = utc_of
        self._ring: deque[Sample] = deque(maxlen=max(1, int(round(pre_s / period_s))))
        self._segment: list[Sample] | None = None
        self._seg_meta: dict[str, Any] = {}
        self._release_s: float | None = None
        self._last_t: float = -math.inf
        self.segments = 0
        #: seconds the ACC was on so far (kept samples' resolution)
        self.acc_on_s = 0.0
        self._engaged = False
        self._on = False

    def sample(self, s: Sample) -> None:
        """Offer one sample; kept if ``period_s`` has passed since the last kept one."""
        if not (math.isfinite(s.t_s) and s.t_s - self._last_t >= self.period_s - PERIOD_EPS_S):
            return
        if self._on:
            self.acc_on_s += s.t_s - self._last_t
        engaged = s.acc_state in _ENGAGED
        self._engaged = self._engaged or engaged
        self._on = engaged or (self._engaged and s.acc_state == AccState.STANDBY)
        self._last_t = s.t_s
        if self._segment is None:
            self._ring.append(s)
            return
        self._segment.append(s)
        if self._release_s is not None and s.t_s - self._release_s >= self.post_s - 1e-6:
            self._emit()

    def start(self, t_s: float, pedal: str) -> None:
        """A takeover starts at ``t_s`` (s) with ``pedal`` ("accel", "brake" or "both")."""
        if self._segment is None:
            self._segment = list(self._ring)
            self._ring.clear()
            # the metadata as of the segment's start: a later change (profile switch) is the
            # next segment's
            self._seg_meta = {**self.meta, "takeovers": []}
        self._release_s = None
        self._seg_meta["takeovers"].append({"start_s": t_s, "pedal": pedal})

    def release(self, t_s: float, decision: str) -> None:
        """The takeover's pedal was released at ``t_s``; ``decision`` is the adaptation's."""
        if self._segment is None:
            return
        self._release_s = t_s
        takeovers = self._seg_meta["takeovers"]
        if takeovers:
            takeovers[-1].update(release_s=t_s, adaptation=decision)

    def flush(self) -> None:
        """Emit the open segment now and retry the pending ones (end of trip)."""
        if not self._emit():
            self.queue.store()

    def _emit(self) -> bool:
        """Hand the open segment to the queue; False if there was none (nothing offered)."""
        seg = self._segment or []
        self._segment = None
        self._release_s = None
        if not seg:
            return False
        meta = {
            **self.meta,
            **self._seg_meta,
            "mode": TripMode.TAKEOVER.value,
            "index": self.segments,
        }
        self.segments += 1
        self.queue.build(seg, meta, self.utc_of)
        return True


def directory_sink(directory: str | os.PathLike[str], prefix: str = "takeover") -> TripSink:
    """A sink writing each trip to ``directory/<prefix>_NNNN.mcap``, never overwriting."""
    d = Path(directory)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecorderError(f"{d}: cannot create {prefix} directory: {exc.strerror}") from None
    if not os.access(d, os.W_OK):
        raise RecorderError(f"{d}: {prefix} directory is not writable")

    counter = [len(list(d.glob(f"{prefix}_*.mcap")))]

    def write(trip: Trip) -> None:
        path = d / f"{prefix}_{counter[0]:04d}.mcap"
        while path.exists():
            counter[0] += 1
            path = d / f"{prefix}_{counter[0]:04d}.mcap"
        write_trip(path, trip)
        counter[0] += 1
        log.info("%s trip written: %s (%d samples)", prefix, path, len(trip))

    return write
