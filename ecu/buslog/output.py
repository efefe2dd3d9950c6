"""The writing half of the bus recorder: what a flush's frames, cycles and samples become.

:class:`~ecu.buslog.writer.CanLogWriter` keeps what a node feeds it (frames as tapped, cycles
as packed bytes, samples) and decides when to flush; :class:`LogOutput` turns each flush into
messages on every sink: the ``/can/raw`` block, the decoded rows of each DBC message, the
cycles' and the sampled channels' rows, events, attachments, metadata, and ends the chunk.
It runs on the node's thread, or in a writer process (:mod:`ecu.buslog.process.remote`) that gets
the same calls with the same arguments, so the file is the same byte for byte.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from ecu.buslog.decoded import FrameBatch, MessageDecoders, Rows, cycle_tables, floats
from ecu.buslog.format import (
    EVENTS_TOPIC,
    INPUTS_TOPIC,
    LOG_SCHEMA,
    META_RECORD,
    OUTPUTS_TOPIC,
    RAW_SCHEMA,
    RAW_TOPIC,
    CanLogError,
    TimeBase,
    log_message,
    meta_record,
    series_columns,
    utc_ns_array,
)
from ecu.buslog.proto import ProtoRows
from ecu.buslog.sinks import Sink, close_all, declare, emit_one, json_spec, rows_spec

__all__ = ["LogOutput"]

#: rows per chunk of a whole series written at once (:meth:`LogOutput.write_series`)
SERIES_STEP = 20_000


class LogOutput:
    """The channels of one recording on ``sinks`` (module docstring): declares the raw and
    the DBC messages' channels, stores the metadata and attachments and ends the first chunk.

    Args:
        sinks: where the messages go (the file, a live view).
        db: the cantools database of the network (``None``: raw frames only).
        time_base: maps the node's clock to UTC.
        node: who records.
        attachments: name -> bytes; metadata: record name -> {key: text}.
    """

    def __init__(
        self,
        sinks: Sequence[Sink],
        db: Any,
        time_base: TimeBase,
        node: str,
        attachments: Mapping[str, bytes] | None = None,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
    ) -> None:
        self.sinks = list(sinks)
        self.time_base = time_base
        self.node = node
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
        for name, data in (attachments or {}).items():
            self.attach(name, data, "text/plain")
        self.end_chunk()  # a recording killed from now on is readable

    def attach(self, name: str, data: bytes, media_type: str) -> None:
        """Store ``data`` as the attachment ``name`` (stamped with the origin's UTC)."""
        for sink in self.sinks:
            sink.attach(self.time_base.utc_origin_ns, name, media_type, data)

    def series(
        self, topic: str, columns: Sequence[str], description: str, integral: Sequence[bool]
    ) -> None:
        """Declare the sampled channel ``topic`` (``t_s`` and ``columns``; per column,
        written as an integer or not); a second declaration is ignored."""
        if topic in self._series:
            return
        title = "pacc." + topic.strip("/").replace("/", ".")
        rows = ProtoRows(title, list(series_columns(columns)), (False, *integral))
        self._series[topic] = Rows(declare(self.sinks, rows_spec(topic, rows)), rows)

    def event(self, t_s: float, text: str) -> None:
        """One event text on ``/ecu/events`` as ``foxglove.Log`` (written at once)."""
        if self._events is None:
            self._events = declare(self.sinks, json_spec(EVENTS_TOPIC, LOG_SCHEMA))
        stamp = self.time_base.utc_ns(t_s)
        doc = log_message(t_s, stamp, text, f"pacc.{self.node}")
        emit_one(self.sinks, self._events, self._events_seq, stamp, doc)
        self._events_seq += 1

    def frames(self, batch: FrameBatch) -> None:
        """The frames of one flush: their ``/can/raw`` block now, their decoded rows kept
        until :meth:`rows`."""
        t_ns = self.time_base.utc_ns(float(batch.t[0]))
        emit_one(self.sinks, self._raw, self._raw_seq, t_ns, batch.block())
        self._raw_seq += 1
        if self._decoded:
            self._pending.append(batch)

    def rows(self, cycles: bytes, samples: Mapping[str, Sequence[float]]) -> None:
        """The rows due: the decoded frames since the last time, the ``cycles`` (float64
        bytes, a cycle after the other: ``t_s``, the index, the inputs, the outputs) and the
        sampled channels' ``samples`` (topic -> rows one after the other)."""
        self._write_decoded()
        if cycles:
            self._write_cycles(cycles)
        for topic, s in self._series.items():
            values = samples.get(topic)
            if values:
                table = np.fromiter(values, np.float64, len(values)).reshape(-1, s.width)
                self._write_rows(s, table)

    def end_chunk(self) -> None:
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
        """Whole columns of the declared ``topic`` at once, one message per row, a chunk
        every :data:`SERIES_STEP` rows."""
        s = self._series[topic]
        t = floats(t_s)
        table = np.column_stack([t, *(floats(columns[k]) for k in s.rows.names[1:])])
        for start in range(0, len(t), SERIES_STEP):
            self._write_rows(s, table[start : start + SERIES_STEP])
            self.end_chunk()

    def finish(self, start_utc: str) -> None:
        """The closing metadata (``start_utc``: the recording's first frame or sample), then
        every sink finished.

        Raises:
            CanLogError: a sink cannot be finished.
            OSError: the closing metadata cannot be written.
        """
        end = {**meta_record(self.time_base, self.node), "start_utc": start_utc}
        for sink in self.sinks:
            sink.metadata(META_RECORD, end)
        close_all(self.sinks)

    def abandon(self) -> None:
        """Keep what was written (every sink closed as incomplete); never raises."""
        for sink in self.sinks:
            with contextlib.suppress(CanLogError, OSError):
                sink.close(complete=False)
