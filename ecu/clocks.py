"""The two clocks that run the ECU's control cycles: lockstep and real time.

Both keep one cycle grid, ``t0 + k * cycle_s`` (s), fixed by the first call. **Lockstep**
(:meth:`CycleClock.advance_to`): the simulator owns time; pending frames are stamped
``now_s``, then every cycle due runs (a jump over :data:`MAX_CATCHUP_S` skips the missed
cycles). **Real time** (:meth:`CycleClock.run_realtime`): cycles from ``time.monotonic``,
blocking in the port's receive between deadlines; :meth:`CycleClock.stop` ends it.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable

from ecu import EcuError
from ecu.busio import BusIO

log = logging.getLogger(__name__)

#: Largest clock jump (s) that advance_to catches up cycle by cycle; beyond it, it skips.
MAX_CATCHUP_S = 10.0
#: Real-time cycle start times kept for jitter statistics (the last minute at 50 Hz).
MAX_CYCLE_STARTS = 3000
#: Round-off margin of a cycle's due time, s.
DUE_EPS_S = 1e-9

#: Runs the cycle of index ``k`` at time ``t_s``.
RunCycle = Callable[[float, int], None]


class RuntimeClockError(EcuError):
    """The runtime was given a time it cannot run to (not finite)."""


class CycleClock:
    """The cycle grid of one node (period ``cycle_s``, s) and the two ways of running it."""

    def __init__(self, cycle_s: float) -> None:
        self.cycle_s = cycle_s
        self.t0: float | None = None
        #: index of the next cycle on the grid
        self.k = 0
        #: cycles not run because the clock jumped (lockstep) or the loop overran (real time)
        self.skipped = 0
        #: real time: start times of the latest cycles (s, monotonic), for jitter statistics
        self.starts: deque[float] = deque(maxlen=MAX_CYCLE_STARTS)
        self._max_catchup = int(MAX_CATCHUP_S / cycle_s)
        self._stop = threading.Event()

    def advance_to(self, now_s: float, port: BusIO, run_cycle: RunCycle) -> None:
        """Drain ``port`` at ``now_s`` and run every cycle due up to ``now_s`` (RuntimeClockError:
        ``now_s`` not finite, or the cycle grid overflows: a host bug; nothing is consumed)."""
        if not math.isfinite(now_s):
            raise RuntimeClockError(f"advance_to: time must be finite, got {now_s}")
        t0, cycle = self.t0, self.cycle_s
        if t0 is None:
            cycles = 0.0
        else:
            cycles = (now_s - t0) / cycle
            if not math.isfinite(cycles):
                raise RuntimeClockError(f"advance_to: {now_s} s is beyond the cycle grid")
        port.drain(now_s)
        if t0 is None:
            self.t0 = t0 = now_s
        behind = int(cycles) - self.k
        if behind > self._max_catchup:  # a jump of the host clock: skip, do not replay
            log.warning("advance_to: %d cycles behind, skipping %d", behind, behind - 1)
            self.skipped += behind - 1
            self.k += behind - 1
        due = now_s + DUE_EPS_S
        while (t := t0 + self.k * cycle) <= due:
            run_cycle(t, self.k)
            self.k += 1

    def run_realtime(
        self,
        duration_s: float | None,
        port: BusIO,
        run_cycle: RunCycle,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """Run cycles on ``clock`` for ``duration_s`` s (None: until :meth:`stop`)."""
        if duration_s is not None and not duration_s >= 0.0:
            raise RuntimeClockError(f"run_realtime: duration must be >= 0 s, got {duration_s}")
        try:
            start = clock()
            self.t0 = start if self.t0 is None else self.t0
            first_k = self.k
            end = math.inf if duration_s is None else start + duration_s
            next_t = start
            while not self._stop.is_set():
                now = clock()
                while now < next_t:
                    now = port.receive(next_t - now, clock)
                if now >= end:
                    break
                self.starts.append(now)
                port.drain(now)
                run_cycle(now, self.k)
                self.k += 1
                next_t = self._skip_overrun(start + (self.k - first_k) * self.cycle_s, clock())
        finally:
            self._stop.clear()  # consumed: the next run starts afresh

    def _skip_overrun(self, next_t: float, now: float) -> float:
        """The next deadline, moved past the missed ones if the loop overran by more than a
        period (counted in :attr:`skipped`) instead of bursting them."""
        if next_t < now - self.cycle_s:
            skipped = int((now - next_t) / self.cycle_s)
            self.k += skipped
            self.skipped += skipped
            next_t += skipped * self.cycle_s
        return next_t

    def stop(self) -> None:
        """Ask :meth:`run_realtime` to return after the current cycle, or at once if called
        before it starts (thread-safe, signal-safe)."""
        self._stop.set()
