"""The bus recorder: every CAN frame, decoded per DBC message, and node internals, to MCAP and live.

One MCAP file per recording (``pacc ecu|sim|drive --can-log FILE``), zstd chunks, one message
per decoded frame and per control cycle with numeric fields, so Foxglove and PlotJuggler plot
every signal over time (the channels: :mod:`ecu.buslog.format`). Every message's ``log_time``
is its frame's or cycle's time in UTC (the :class:`~ecu.buslog.format.TimeBase`), ``t_s`` in
it the node's clock exactly.
"""

from __future__ import annotations

import contextlib
import logging
import operator
import os
import struct
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import can
import numpy as np

from dbc.frame import raw_of
from ecu.buslog.decoded import (
    STRIDE,
    FrameBatch,
    MessageDecoders,
    Rows,
    Tapped,
    cycle_tables,
    floats,
    integral_fields,
)
from ecu.buslog.format import (
    EVENTS_TOPIC,
    FLUSH_S,
    INPUT_FIELDS,
    INPUTS_TOPIC,
    LOG_SCHEMA,
    META_RECORD,
    OUTPUT_FIELDS,
    OUTPUTS_TOPIC,
    RAW_SCHEMA,
    RAW_TOPIC,
    ROWS_S,
    CanLogError,
    TimeBase,
    log_message,
    meta_record,
    utc_ns_array,
)
from ecu.buslog.proto import ProtoRows
from ecu.buslog.sinks import McapSink, Sink, close_all, declare, json_spec, rows_spec
from ecu.signals import NodeInputs, NodeOutputs

log = logging.getLogger(__name__)
_get_inputs = operator.attrgetter(*INPUT_FIELDS)
_get_outputs = operator.attrgetter(*OUTPUT_FIELDS)
#: one cycle's values as kept until its rows are written: t_s, cycle index, the inputs and the
#: outputs in the channels' column order, float64 bytes (no Python object per value)
_pack_cycle = struct.Struct(f"<{2 + len(INPUT_FIELDS) + len(OUTPUT_FIELDS)}d").pack
#: rows per chunk of a whole series written at once (:meth:`CanLogWriter.write_series`)
SERIES_STEP = 20_000


class CanLogWriter:
    """Writes one recording (module docstring) to ``path`` (``path.part`` until :meth:`close`;
    None: only ``sinks``, e.g. :class:`ecu.buslog.live.FoxgloveSink`). Not thread-safe.

    ``db``: the cantools database (None: raw frames only); ``node``: who records (``ecu``, ``sim``,
    ``drive``, ``export``); ``flush_s``: flush interval on the node's clock, s (at most this is lost
    on a kill); ``rows_s`` (>= ``flush_s``), s: how often decoded rows and cycles are written.
    CanLogError: ``path`` cannot be created."""

    def __init__(
        self,
        path: str | os.PathLike[str] | None,
        db: Any,
        time_base: TimeBase,
        *,
        node: str,
        attachments: Mapping[str, bytes] | None = None,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
        flush_s: float = FLUSH_S,
        sinks: Sequence[Sink] = (),
        rows_s: float = ROWS_S,
    ) -> None:
        self.path = Path(path) if path is not None else None
        self.time_base = time_base
        self.flush_s = flush_s
        self.rows_s = max(rows_s, flush_s)
        self._rows_t0: float | None = None
        self.node = node
        self.frames = 0
        self.closed = False
        #: why recording stopped (a failed write), None while it works; raised by close()
        self.error: str | None = None
        #: the node's clock at the first frame or sample (the recording's start)
        self.first_t_s: float | None = None
        # the open block: its frames as tapped, its first frame's, cycle's or sample's time,
        # its cycles and samples
        self._frames: list[Any] = []
        self._tap: Callable[[Tapped], None] = self._frames.extend
        self._block_t0: float | None = None
        self._cycles: list[bytes] = []
        self._cycles_declared = False
        self._samples: dict[str, list[Any]] = {}  # topic -> unwritten rows, one after the other
        # the channels on every sink: raw, decoded per DBC message, sampled, events
        self.sinks: list[Sink] = [McapSink(self.path)] if self.path is not None else []
        self.sinks += sinks
        self._raw = declare(self.sinks, json_spec(RAW_TOPIC, RAW_SCHEMA))
        self._raw_seq = 0
        self._decoders = MessageDecoders(db)
        self._decoded = {
            key: Rows(declare(self.sinks, rows_spec(topic, rows)), rows)
            for key, (_, rows, topic) in self._decoders.rows.items()
        }
        self._pending: list[FrameBatch] = []
        self._series: dict[str, Rows] = {}
        self._events: list[int] | None = None
        self._events_seq = 0
        for sink in self.sinks:
            sink.metadata(META_RECORD, meta_record(time_base, node))
        for name, record in (metadata or {}).items():
            for sink in self.sinks:
                sink.metadata(name, {str(k): str(v) for k, v in record.items()})
        for name, data in (attachments or {}).items():  # stamped with the origin's UTC
            for sink in self.sinks:
                sink.attach(time_base.utc_origin_ns, name, "text/plain", data)
        self._end_chunk()  # a recording killed from now on is readable

    def frame_raw(self, t_s: float, key: int, data: Any, rx: bool) -> None:
        """One frame received (``rx``) or sent at ``t_s`` (s, the node's clock), in the raw
        form of :mod:`dbc.frame`: ``key`` the id with the IDE bit, ``data`` the immutable
        payload (for :data:`dbc.frame.OTHER`, the message itself, kept until the flush)."""
        self._tap((t_s, key, data, rx))

    def frame_and_tick(self, t_s: float, msg: can.Message, rx: bool) -> None:
        """:meth:`frame_raw` of ``msg`` in the raw form (:func:`dbc.frame.raw_of`: its payload
        copied, so a sender may reuse its message), then :meth:`tick`: a tap for a node
        without control cycles."""
        _, key, data = raw_of(msg)
        self._tap((t_s, key, data, rx))
        self.tick(t_s)

    def series(
        self, topic: str, columns: Sequence[str], integral: Sequence[bool] | None = None
    ) -> None:
        """Declare the sampled channel ``topic`` with ``columns`` (besides ``t_s``);
        ``integral``: per column, written as an integer (default: none)."""
        if topic in self._series:
            return
        ints = tuple(integral) if integral is not None else (False,) * len(columns)
        title = "pacc." + topic.strip("/").replace("/", ".")
        rows = ProtoRows(title, ["t_s", *columns], (False, *ints))
        self._series[topic] = Rows(declare(self.sinks, rows_spec(topic, rows)), rows)
        self._samples[topic] = []

    def sample(self, topic: str, t_s: float, values: tuple[Any, ...]) -> None:
        """One sample of a declared channel at ``t_s`` (s): ``values`` in its column order."""
        row = self._samples[topic]
        row.append(t_s)
        row.extend(values)
        if self._block_t0 is None:  # the block starts at its first frame, cycle or sample
            self._block_t0 = self._frames[0] if self._frames else t_s

    def event(self, t_s: float, text: str) -> None:
        """One event text, as ``foxglove.Log`` on ``/ecu/events`` (written at once: events
        are rare); nothing once the recording stopped."""
        if self.error is not None:
            return
        if self._events is None:
            self._events = declare(self.sinks, json_spec(EVENTS_TOPIC, LOG_SCHEMA))
        stamp = self.time_base.utc_ns(t_s)
        doc = log_message(t_s, stamp, text, f"pacc.{self.node}")
        for sink, handle in zip(self.sinks, self._events, strict=True):
            sink.write_one(handle, self._events_seq, stamp, doc)
        self._events_seq += 1

    def cycle(self, t_s: float, inputs: NodeInputs, outputs: NodeOutputs, k: int = -1) -> None:
        """ECU control cycle ``k`` at ``t_s`` (s) on ``/ecu/inputs`` and ``/ecu/outputs``, its
        events on ``/ecu/events``; flushes when due. Never raises: a failure stops the recording."""
        if self.error is not None:
            return
        try:  # written out: one call a cycle
            if not self._cycles_declared:
                self._declare_cycles()
            self._cycles.append(_pack_cycle(t_s, k, *_get_inputs(inputs), *_get_outputs(outputs)))
            if outputs.events:
                for text in outputs.events:
                    self.event(t_s, text)
            t0 = self._block_t0
            if t0 is None:
                t0 = self._block_t0 = self._frames[0] if self._frames else t_s
            if t_s - t0 >= self.flush_s:
                self._flush_due(t_s)
        except Exception as exc:  # noqa: BLE001 - I/O at the edge: never stop the control loop
            self._fail(t_s, exc)

    def _declare_cycles(self) -> None:
        self.series(INPUTS_TOPIC, INPUT_FIELDS, integral_fields(NodeInputs, INPUT_FIELDS))
        outputs = integral_fields(NodeOutputs, OUTPUT_FIELDS)
        self.series(OUTPUTS_TOPIC, ("cycle", *OUTPUT_FIELDS), (True, *outputs))
        self._cycles_declared = True

    def tick(self, t_s: float) -> None:
        """Flush if the oldest unwritten row is ``flush_s`` old at ``t_s``. Never raises: a
        failed write stops the recording (:attr:`error`), not the node."""
        t0 = self._block_t0
        if t0 is None:
            if not self._frames:
                return
            t0 = self._frames[0]
        if t_s - t0 >= self.flush_s:
            try:
                self._flush_due(t_s)
            except Exception as exc:  # noqa: BLE001 - I/O at the edge: never stop the node
                self._fail(t_s, exc)

    def _fail(self, t_s: float, exc: Exception) -> None:
        """Stop recording after a failed write; :meth:`close` reports it (the first one)."""
        if self.error is None:
            self.error = f"recording stopped at t = {t_s:.3f} s: {type(exc).__name__}: {exc}"
            log.error("%s: %s", self.path, self.error)
        self._frames, self._cycles = [], []
        self._tap = lambda _: None  # a stopped recording takes no frames
        for values in self._samples.values():
            values.clear()

    def _flush_due(self, t_s: float) -> None:
        self.flush(self._rows_t0 is not None and t_s - self._rows_t0 >= self.rows_s)

    def flush(self, rows: bool = True) -> None:
        """Write the frames since the last flush as a ``/can/raw`` block and end the chunk
        (every sink); ``rows``: the decoded rows, the cycles and the samples too."""
        t0 = self._block_t0
        if t0 is None and self._frames:
            t0 = self._frames[0]
        if self.first_t_s is None:
            self.first_t_s = t0
        if self._rows_t0 is None:
            self._rows_t0 = t0
        frames = self._frames
        self._block_t0 = None
        if frames:
            self._frames = []
            self._tap = self._frames.extend
            self.frames += len(frames) // STRIDE
            batch = FrameBatch.of(frames)
            t_ns = self.time_base.utc_ns(float(batch.t[0]))
            for sink, handle in zip(self.sinks, self._raw, strict=True):
                sink.write_one(handle, self._raw_seq, t_ns, batch.block())
            self._raw_seq += 1
            if self._decoded:
                self._pending.append(batch)
        if rows:
            self._write_decoded()
            if self._cycles:
                self._write_cycles(b"".join(self._cycles))
                self._cycles = []
            for topic, values in self._samples.items():
                if values:
                    s = self._series[topic]
                    table = np.fromiter(values, np.float64, len(values)).reshape(-1, s.width)
                    self._write_rows(s, table)
                    self._samples[topic] = []
            self._rows_t0 = None
        self._end_chunk()

    def _end_chunk(self) -> None:
        """Make what was written durable on every sink (the file: end the chunk)."""
        for sink in self.sinks:
            sink.flush()

    def _write_cycles(self, cycles: bytes) -> None:
        ins, outs = self._series[INPUTS_TOPIC], self._series[OUTPUTS_TOPIC]
        width = ins.width + outs.width - 1  # t_s, the index, the inputs, the outputs
        t, inputs, outputs = cycle_tables(cycles, ins.width, width)
        t_ns = utc_ns_array(self.time_base, t)
        self._write_rows(ins, inputs, t_ns)
        self._write_rows(outs, outputs, t_ns)

    def _write_rows(self, s: Rows, table: np.ndarray, t_ns: np.ndarray | None = None) -> None:
        """One message per row of ``table`` (``t_s`` first) on ``s``'s channel, stamped
        ``t_ns`` (default: the UTC of ``t_s``)."""
        if t_ns is None:
            t_ns = utc_ns_array(self.time_base, table[:, 0])
        for sink, handle in zip(self.sinks, s.handles, strict=True):
            sink.write_rows(handle, s.seq, t_ns, s.rows, table)
        s.seq += len(table)

    def _write_decoded(self) -> None:
        if not self._pending:
            return
        batch = FrameBatch.join(self._pending)
        self._pending = []
        t_ns = utc_ns_array(self.time_base, batch.t)
        for key, table, sel in self._decoders.tables(batch):
            self._write_rows(self._decoded[key], table, t_ns[sel])

    def write_series(
        self, topic: str, columns: Mapping[str, Iterable[Any]], t_s: Iterable[float]
    ) -> None:
        """Write whole columns of the declared ``topic`` at once (the simulated world after a
        drive), a chunk every :data:`SERIES_STEP` rows; nothing once the recording stopped."""
        if topic not in self._series:
            raise KeyError(topic)
        if self.error is not None:
            return
        s = self._series[topic]
        t = floats(t_s)
        table = np.column_stack([t, *(floats(columns[k]) for k in s.rows.names[1:])])
        for start in range(0, len(t), SERIES_STEP):
            self._write_rows(s, table[start : start + SERIES_STEP])
            self._end_chunk()

    def close(self) -> None:
        """Write what is open, finish the file and rename it to ``path`` (CanLogError: stopped
        earlier, what was written stays in ``.part``; or the file cannot be finished)."""
        if self.closed:
            return
        self.closed = True
        if self.error is not None:
            self._abandon()
            raise CanLogError(f"{self.path}: {self.error}; what was written is in {self.path}.part")
        base = self.time_base
        try:
            self.flush()
            first = self.first_t_s if self.first_t_s is not None else base.clock_origin_s
            end = {**meta_record(base, self.node), "start_utc": base.iso(first)}
            for sink in self.sinks:
                sink.metadata(META_RECORD, end)
        except OSError as exc:
            self._abandon()
            raise CanLogError(f"{self.path}: cannot finish the recording: {exc}") from exc
        close_all(self.sinks)

    def _abandon(self) -> None:
        """Keep what was written (every sink closed as incomplete); never raises."""
        for sink in self.sinks:
            with contextlib.suppress(CanLogError, OSError):
                sink.close(complete=False)

    def __enter__(self) -> CanLogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
