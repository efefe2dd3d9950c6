"""A drive's bus recording and live view: opened on the ECU's port, the simulated world
streamed as it runs or added at the end, the lockstep loop held to the wall clock.

A lockstep drive runs hundreds of times faster than real time and writes the simulated world
(``/sim/world``) after its last tick: fine for a recording file, useless to a person watching
the loop in Foxglove (``--foxglove``). So, for a live view:

- :class:`WorldFeed` samples the world's new rows into the recorder as the drive runs, and
  ``/sim/world`` reaches the live sinks with the frames (``pacc drive``, ``pacc sim``,
  ``pacc hil``);
- :class:`Pacer` holds a lockstep loop to ``pace`` times real time (``pacc drive --pace``;
  1 by default with ``--foxglove``).

Neither changes the drive: the same frames, the same rows (tested). Without a live view the
world is written at the end in one call (:func:`record_world`), as it always was.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from dbc.codec import Codec
from ecu import EcuError
from ecu.buslog.format import WORLD_TOPIC, TimeBase
from ecu.buslog.recording import open_recording
from ecu.buslog.sinks import Sink
from ecu.buslog.writer import CanLogWriter
from ecu.node import EcuNode
from pacc.vocab import FormatError
from pacc.vocab.dgpt import Dgpt
from sim_bus.world import WORLD_COLUMNS, World, WorldLog

if TYPE_CHECKING:
    from sim_bus.study.drive import DriveConfig

__all__ = [
    "WORLD_DESCRIPTION",
    "Pacer",
    "WorldFeed",
    "after_tick",
    "drive_recorder",
    "finish_recording",
    "record_world",
]

#: the description of the ``/sim/world`` channel
WORLD_DESCRIPTION = "the simulated world: plant, lead, driver"


def drive_recorder(
    path: Path | None,
    cfg: DriveConfig,
    ecu: EcuNode,
    table: Dgpt,
    codec: Codec,
    base: TimeBase,
    live: Sequence[Sink] = (),
) -> CanLogWriter:
    """The bus recorder of a drive: the ECU's port, simulated time on ``base``."""
    # a setting left at its default (None) is absent, never the string 'None'
    settings = {k: str(v) for k, v in dataclasses.asdict(cfg).items() if v is not None}
    return open_recording(
        path,
        codec,
        base,
        node="drive",
        config=ecu.config,
        table=table,
        metadata={"drive": settings},
        sinks=live,
    )


def finish_recording(recorder: CanLogWriter, log: WorldLog, streamed: bool = False) -> str | None:
    """Add the world to the recording (unless a :class:`WorldFeed` ``streamed`` it) and close
    it; the failure's text (None: written). A failed recording does not cost the drive's
    results."""
    try:
        if not streamed:
            record_world(recorder, log)
        recorder.close()
    except (EcuError, FormatError, OSError) as exc:
        return str(exc)
    return None


def record_world(recorder: CanLogWriter, log: WorldLog) -> None:
    """The simulated world of a finished drive (:class:`WorldLog`) on ``/sim/world``, at once."""
    columns = {name: getattr(log, name) for name in WORLD_COLUMNS}
    recorder.series(WORLD_TOPIC, WORLD_COLUMNS, WORLD_DESCRIPTION)
    recorder.write_series(WORLD_TOPIC, columns, log.t_s)


class WorldFeed:
    """``/sim/world`` sampled into ``recorder`` while ``world`` runs: call it after each tick.

    One row per driver step (20 Hz), the columns and values :func:`record_world` writes
    after a drive; the recorder sends them with its next rows (every 0.2 s of the node's
    clock with a live view). A drive fed this way must not also call :func:`record_world`
    (:func:`finish_recording` with ``streamed``), or its rows would be written twice.
    """

    def __init__(self, recorder: CanLogWriter, world: World) -> None:
        self.recorder = recorder
        self.world = world
        #: the world's rows sampled so far
        self.rows = 0
        recorder.series(WORLD_TOPIC, WORLD_COLUMNS, WORLD_DESCRIPTION)

    def __call__(self) -> None:
        """Sample the rows the world logged since the last call."""
        rows = self.world.logged_since(self.rows)
        if not rows:
            return
        self.rows += len(rows)
        if self.recorder.error is not None or self.recorder.closed:
            return  # a stopped recording takes nothing (its close says why)
        sample = self.recorder.sample
        for row in rows:
            sample(WORLD_TOPIC, float(row[0]), tuple(float(x) for x in row[1:]))


class Pacer:
    """Hold a loop to ``pace`` times real time: call it with the simulated time (s) each tick.

    The first call sets the origin; later calls sleep while the simulation is ahead of
    ``pace`` × the wall time since. A loop slower than that is never held: it falls behind,
    it skips nothing.

    Raises:
        ValueError: ``pace`` is not > 0.
    """

    def __init__(self, pace: float) -> None:
        if not pace > 0:
            raise ValueError(f"pace must be > 0, got {pace}")
        self.pace = pace
        self._origin: float | None = None

    def __call__(self, sim_s: float) -> None:
        now = time.perf_counter()
        if self._origin is None:
            self._origin = now - sim_s / self.pace
            return
        ahead = self._origin + sim_s / self.pace - now
        if ahead > 0:
            time.sleep(ahead)


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
