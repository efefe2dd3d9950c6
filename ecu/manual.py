"""The ECU's manual-driving recorder: the driver's car-following stretches as trip logs, the
demonstrations the cloud learns from, recorded on the vehicle as in the paper.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

from dbc.vocab.acc_state import AccState, FaultCode
from dbc.vocab.sampling import MANUAL_MAX_S, MANUAL_MIN_S, PERIOD_EPS_S, keep_interval_s
from dbc.vocab.tripmode import TripMode
from ecu.recorder import RecorderError, Sample, SinkQueue, TripSink

_NOT_ENGAGED = (int(AccState.OFF), int(AccState.STANDBY))
#: input faults a manual demonstration does not care about (the buttons' HMI frame)
_MANUAL_OK = (FaultCode.NONE, FaultCode.HMI_INPUT)


class ManualRecorder:
    """The driver's manual car-following stretches as trip logs (module docstring) to ``sink``.

    ``period_s`` / ``cycle_s``: recording period and control cycle, s (``cycle_s`` 0: the takeover
    recorder's rule); ``min_s`` / ``max_s``: shortest stretch kept, longest trip (longer ones in
    pieces), s; ``meta`` / ``utc_of``: as :class:`ecu.recorder.TakeoverRecorder`'s."""

    def __init__(
        self,
        sink: TripSink,
        *,
        period_s: float = 0.1,
        cycle_s: float = 0.0,
        min_s: float = MANUAL_MIN_S,
        max_s: float = MANUAL_MAX_S,
        meta: Mapping[str, Any] | None = None,
        utc_of: Callable[[float], str] | None = None,
    ) -> None:
        if not (period_s > 0.0 and 0.0 <= min_s <= max_s and math.isfinite(max_s)):
            raise RecorderError("manual recorder: need period_s > 0 and 0 <= min_s <= max_s")
        self.queue = SinkQueue(sink, "manual trip")
        self.period_s = period_s
        self.cycle_s = cycle_s if math.isfinite(cycle_s) and 0.0 <= cycle_s < period_s else 0.0
        #: a cycle is kept this long after the last kept one, s (keep_sample)
        self._interval = keep_interval_s(period_s, self.cycle_s)
        self.min_s = min_s
        self.meta = dict(meta or {})
        self.utc_of = utc_of
        self._max_n = max(1, int(round(max_s / period_s)))
        self._stretch: list[Sample] = []
        self._last_t = -math.inf
        #: no cycle before this time (s) can be kept: the node builds a sample only from
        #: here on (1 ns early: :meth:`sample` decides exactly)
        self.next_due_s = -math.inf
        #: manual trips handed over so far
        self.trips = 0
        #: seconds kept in trips, and seconds of manual stretches shorter than ``min_s``
        self.kept_s = 0.0
        self.short_s = 0.0

    def sample(self, s: Sample, fault: FaultCode) -> None:
        """Offer one cycle's sample and its input check; if kept
        (:func:`~dbc.vocab.sampling.keep_sample`), added to the stretch or ending it."""
        if not (math.isfinite(s.t_s) and s.t_s - self._last_t >= self._interval):
            return
        self._last_t = s.t_s
        self.next_due_s = s.t_s + self._interval - 1e-9
        if fault in _MANUAL_OK and s.acc_state in _NOT_ENGAGED and not math.isnan(s.gap_m):
            self._stretch.append(s)
            if len(self._stretch) >= self._max_n:
                self._close()
        elif self._stretch:
            self._close()

    def set_meta(self, changes: Mapping[str, Any]) -> None:
        """Update the trips' metadata (a driver profile switch): an open stretch is the old
        driver's and ends here."""
        if any(self.meta.get(k) != v for k, v in changes.items()):
            self._close()
            self.meta.update(changes)

    def flush(self) -> None:
        """End of trip: hand over the open stretch (if long enough) and offer the pending
        trips again (also when the stretch is too short to be a trip)."""
        if not self._close():
            self.queue.store()

    def _close(self) -> bool:
        """End the open stretch: a trip if long enough (True: handed to the queue, which
        offered the pending trips too), else counted in :attr:`short_s` (False)."""
        stretch, self._stretch = self._stretch, []
        seconds = len(stretch) * self.period_s
        if not stretch or seconds < self.min_s - PERIOD_EPS_S:
            self.short_s += seconds
            return False
        meta = {**self.meta, "mode": TripMode.MANUAL.value, "index": self.trips}
        self.trips += 1
        self.kept_s += seconds
        self.queue.build(stretch, meta, self.utc_of)
        return True
