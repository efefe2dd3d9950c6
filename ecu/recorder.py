"""Takeover recorder: a pre-trigger ring buffer and complete takeover segments for a sink.

The node feeds one sample per cycle; the recorder keeps one every ``period_s`` (10 Hz by
default) in a ring buffer holding the last ``pre_s`` seconds. When a takeover starts the
buffer becomes the head of a new segment; samples are appended through the pedal release and
a post window of ``post_s`` seconds, then the segment is handed to the sink as a
:class:`pacc.vocab.triplog.Trip` with ``meta["mode"] == "takeover"``. A new takeover during
the post window extends the open segment (its post window restarts at the next release).

The sink is I/O at the edge: any exception it raises is caught, logged and counted in
:attr:`TakeoverRecorder.sink_errors`; recording never stops the control loop. A segment the
sink refused is kept (up to :data:`MAX_PENDING` of them) and offered again, in order, at the
next emit and at :meth:`TakeoverRecorder.flush`.
:func:`directory_sink` writes each segment as an MCAP file into a directory.
"""

from __future__ import annotations

import logging
import math
import os
from collections import deque
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ecu import EcuError
from pacc.vocab.triplog import Trip
from pacc.vocab.triplog_file import write_trip
from pacc.vocab.tripmode import TripMode

log = logging.getLogger(__name__)

TripSink = Callable[[Trip], None]
#: Segments kept for a retry while the sink fails; beyond it the oldest is dropped (logged).
MAX_PENDING = 64


class RecorderError(EcuError):
    """The takeover directory cannot be used."""


@dataclass(frozen=True, slots=True)
class Sample:
    """One recorded instant: SI units, pedals 0..1, ``acc_state`` an AccState code.

    ``gap_m`` and ``v_lead_mps`` are NaN without a lead.
    """

    t_s: float
    v_mps: float
    gap_m: float
    v_lead_mps: float
    a_mps2: float
    accel_pedal: float
    brake_pedal: float
    acc_state: int


class TakeoverRecorder:
    """Ring buffer plus open segment; see the module docstring.

    Args:
        sink: receives each complete segment.
        period_s: recording period, s.
        pre_s: pre-trigger length, s.
        post_s: post-release length, s.
        meta: metadata copied into every segment (driver_id, condition, seed, ...).
        utc_of: maps a sample time (the node's clock, s) to ISO 8601 UTC; when given, every
            segment's ``meta["start_utc"]`` is its first sample's, and the trip log is
            stamped with real UTC (a real-time ECU, whose clock is the boot clock).
    """

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
        self.sink = sink
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
        self.sink_errors = 0
        #: segments the sink refused so far and not yet stored
        self.pending: deque[Trip] = deque()

    def sample(self, s: Sample) -> None:
        """Offer one sample; kept if ``period_s`` has passed since the last kept one.

        A sample with a non-finite time is ignored (it would stop the recording for good).
        """
        if not (math.isfinite(s.t_s) and s.t_s - self._last_t >= self.period_s - 1e-6):
            return
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
        if self._segment is not None:
            self._emit()
        else:
            self._store_pending()

    def _emit(self) -> None:
        seg = self._segment or []
        self._segment = None
        self._release_s = None
        if not seg:
            return
        meta = {
            **self.meta,
            **self._seg_meta,
            "mode": TripMode.TAKEOVER.value,
            "index": self.segments,
        }
        if self.utc_of is not None:
            meta["start_utc"] = self.utc_of(seg[0].t_s)
        cols = list(
            zip(
                *(
                    (
                        s.t_s,
                        s.v_mps,
                        s.gap_m,
                        s.v_lead_mps,
                        s.a_mps2,
                        s.accel_pedal,
                        s.brake_pedal,
                        s.acc_state,
                    )
                    for s in seg
                ),
                strict=True,
            )
        )
        self.segments += 1
        try:
            trip = Trip(
                t_s=np.asarray(cols[0]),
                v_mps=np.asarray(cols[1]),
                gap_m=np.asarray(cols[2]),
                v_lead_mps=np.asarray(cols[3]),
                a_mps2=np.asarray(cols[4]),
                accel_pedal=np.clip(np.asarray(cols[5]), 0.0, 1.0),
                brake_pedal=np.clip(np.asarray(cols[6]), 0.0, 1.0),
                acc_state=np.asarray(cols[7], dtype=np.int64),
                meta=meta,
            )
        except Exception as exc:  # noqa: BLE001 - never stop the control loop
            self.sink_errors += 1
            log.error("takeover segment %d not built: %s", meta["index"], exc)
            return
        if len(self.pending) >= MAX_PENDING:
            lost = self.pending.popleft()
            log.error("takeover segment %s dropped: sink failing", lost.meta.get("index"))
        self.pending.append(trip)
        self._store_pending()

    def _store_pending(self) -> None:
        """Hand the pending segments to the sink, oldest first, until one fails."""
        while self.pending:
            trip = self.pending[0]
            try:
                self.sink(trip)
            except Exception as exc:  # noqa: BLE001 - I/O edge: never stop the control loop
                self.sink_errors += 1
                log.error(
                    "takeover segment %s not stored (kept for a retry): %s",
                    trip.meta.get("index"),
                    exc,
                )
                return
            self.pending.popleft()


def directory_sink(directory: str | os.PathLike[str]) -> TripSink:
    """A sink writing each segment to ``directory/takeover_NNNN.mcap``, never overwriting.

    The directory is created if needed; numbering continues after the files already there.
    """
    d = Path(directory)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RecorderError(f"{d}: cannot create takeover directory: {exc.strerror}") from None
    if not os.access(d, os.W_OK):
        raise RecorderError(f"{d}: takeover directory is not writable")

    counter = [len(list(d.glob("takeover_*.mcap")))]

    def write(trip: Trip) -> None:
        path = d / f"takeover_{counter[0]:04d}.mcap"
        while path.exists():
            counter[0] += 1
            path = d / f"takeover_{counter[0]:04d}.mcap"
        write_trip(path, trip)
        counter[0] += 1
        log.info("takeover segment written: %s (%d samples)", path, len(trip))

    return write


__all__ = [
    "MAX_PENDING",
    "RecorderError",
    "Sample",
    "TakeoverRecorder",
    "TripSink",
    "directory_sink",
]
