"""A drive's bus recording and live view: opened on the ECU's port, the simulated world
streamed as it runs or added at the end, the lockstep loop held to the wall clock.

For a live view (``--foxglove``) :class:`WorldFeed` samples the world into the recorder as the
drive runs and :class:`Pacer` holds the loop to ``pace`` times real time; neither changes the
drive. Without one the world is written at the end (:func:`finish_recording`).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

from dbc.vocab import FormatError
from ecu import EcuError
from ecu.buslog.format import WORLD_TOPIC
from ecu.buslog.writer import CanLogWriter
from sim_bus.world import WORLD_COLUMNS, World, WorldLog

#: the paces a drive may be held to, times real time (1e-3: 1 s of drive per 17 min)
MIN_PACE, MAX_PACE = 1e-3, 1e6
#: a paced loop this far behind (s of wall time) starts again from where it is (no burst)
RESYNC_S = 0.25


def finish_recording(recorder: CanLogWriter, log: WorldLog, streamed: bool = False) -> str | None:
    """Add the world to the recording (unless a :class:`WorldFeed` ``streamed`` it) and close
    it; the failure's text (None: written). A failed recording does not cost the drive's
    results."""
    try:
        if not streamed:  # the world of the finished drive, at once
            columns = {name: getattr(log, name) for name in WORLD_COLUMNS}
            recorder.series(WORLD_TOPIC, WORLD_COLUMNS)
            recorder.write_series(WORLD_TOPIC, columns, log.t_s)
        recorder.close()
    except (EcuError, FormatError, OSError) as exc:
        return str(exc)
    return None


class WorldFeed:
    """``/sim/world`` sampled into ``recorder`` while ``world`` runs (one row per driver step,
    20 Hz): call it after each tick."""

    def __init__(self, recorder: CanLogWriter, world: World) -> None:
        self.recorder = recorder
        self.world = world
        #: the world's rows sampled so far
        self.rows = 0
        recorder.series(WORLD_TOPIC, WORLD_COLUMNS)

    def __call__(self) -> None:
        """Sample the rows the world logged since the last call."""
        rows = self.world.logged_since(self.rows)
        if not rows:
            return
        if self.recorder.error is not None or self.recorder.closed:
            self.rows += len(rows)
            return  # a stopped recording takes nothing (its close says why)
        sample = self.recorder.sample
        for row in rows:
            sample(WORLD_TOPIC, float(row[0]), tuple(float(x) for x in row[1:]))
            self.rows += 1  # counted once written: an interrupt between rows loses none


class Pacer:
    """Hold a loop to ``pace`` times real time (:data:`MIN_PACE`..:data:`MAX_PACE`, else
    ValueError): call it with the simulated time (s) each tick. A loop more than
    :data:`RESYNC_S` behind goes on from where it is (a pause, not a burst).
    """

    def __init__(
        self,
        pace: float,
        clock: Callable[[], float] = time.perf_counter,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if not MIN_PACE <= pace <= MAX_PACE:
            raise ValueError(f"pace must be within {MIN_PACE:g}..{MAX_PACE:g}, got {pace}")
        self.pace = pace
        self.clock = clock
        self.sleep = sleep
        self._origin: float | None = None

    def __call__(self, sim_s: float) -> None:
        """Wait until the wall clock reaches ``sim_s`` (s of simulated time) at the pace."""
        now = self.clock()
        ahead = math.nan if self._origin is None else self._origin + sim_s / self.pace - now
        if not ahead >= -RESYNC_S:  # the first call, or too far behind: start from here
            self._origin = now - sim_s / self.pace
        elif ahead > 0:
            self.sleep(ahead)


def after_tick(feed: WorldFeed | None, pace: float | None) -> Callable[[float], None] | None:
    """What a live or paced drive does after each tick, given the simulated time (s); None
    when it does nothing (the fast loop)."""
    pacer = Pacer(pace) if pace is not None else None
    if feed is None:
        return pacer
    if pacer is None:
        return lambda _t_s: feed()

    def after(t_s: float) -> None:
        feed()
        pacer(t_s)

    return after
