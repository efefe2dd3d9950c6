"""The bus recorder: every CAN frame, decoded per DBC message, and node internals, in MCAP.

One MCAP file per recording (``pacc ecu|sim|drive --can-log FILE``), zstd-compressed chunks,
JSON-encoded messages with JSON schemas (the layout: :mod:`ecu.buslog.format`):

- ``/can/raw``: every frame the node received (``rx``) or sent, in bus order;
- ``/can/<Message>`` (schema ``dbc.<Message>``, generated from the DBC): the frames of one
  DBC message decoded (:mod:`dbc.columns`: cantools' values, column by column);
- node internals on their own channels: ``/ecu/inputs`` and ``/ecu/outputs`` (the node's
  checked inputs and its outputs of every control cycle: request, state, desired gap, table
  version …), ``/sim/world`` (the simulated truth); ``/ecu/events`` one message per event.

A message holds a block: what one channel collected during ``block_s`` of the node's clock,
one row per frame or cycle, every column a base64 little-endian array (:mod:`ecu.buslog.blocks`).
One MCAP message and one JSON text per frame would cost more than the drive being recorded;
a block costs one of each per channel (bench/canlog.py measures the recorder against
python-can's BLF writer). Every message's ``log_time`` is real UTC: the recording's
:class:`~ecu.buslog.format.TimeBase` maps the node's clock onto the wall clock (lockstep: the
UTC of the drive's start plus the simulated time). The DBC, the binding, the ECU
configuration and its starting table are MCAP attachments; what ran (node, time base, drive
settings) are MCAP metadata records. The file is written as ``FILE.part`` and renamed when
closed.
"""

from __future__ import annotations

import contextlib
import json
import logging
import operator
import os
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import can
import numpy as np

from dbc.columns import MessageColumns, message_columns
from ecu.buslog.blocks import block_schema, encode_block
from ecu.buslog.format import (
    BLOCK_S,
    EVENT_SCHEMA,
    EVENTS_TOPIC,
    FLAG_ERROR,
    FLAG_EXTENDED,
    FLAG_REMOTE,
    FLAG_RX,
    FORMAT,
    INPUT_FIELDS,
    INPUTS_TOPIC,
    META_RECORD,
    OUTPUT_FIELDS,
    OUTPUTS_TOPIC,
    RAW_SCHEMA,
    RAW_SCHEMA_NAME,
    RAW_TOPIC,
    CanLogError,
    TimeBase,
    frame_flags,
    series_columns,
)
from ecu.signals import NodeInputs, NodeOutputs

__all__ = ["CanLogWriter", "FrameTap"]

log = logging.getLogger(__name__)
_get_inputs = operator.attrgetter(*INPUT_FIELDS)
_get_outputs = operator.attrgetter(*OUTPUT_FIELDS)


class _Series:
    """One channel of sampled internals: the values of the open block, row after row in one
    flat list (no tuple per row: fewer objects for the garbage collector to track)."""

    def __init__(self, channel: int, columns: tuple[str, ...]) -> None:
        self.channel = channel
        self.columns = columns
        self.width = 1 + len(columns)  # t_s first
        self.values: list[Any] = []
        self.seq = 0


class CanLogWriter:
    """Writes one recording (module docstring). Not thread-safe: one node's thread feeds it.

    Args:
        path: the MCAP file to write (``path.part`` until :meth:`close`).
        db: the cantools database of the network (``None``: raw frames only).
        time_base: maps the node's clock to UTC.
        node: who records (``ecu``, ``sim``, ``drive``, ``export``).
        attachments: name -> bytes, stored as MCAP attachments (DBC, binding, config …).
        metadata: record name -> {key: text}, stored as MCAP metadata records.
        block_s: length of a block on the node's clock, s.

    Raises:
        CanLogError: ``path`` cannot be created.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        db: Any,
        time_base: TimeBase,
        *,
        node: str,
        attachments: Mapping[str, bytes] | None = None,
        metadata: Mapping[str, Mapping[str, str]] | None = None,
        block_s: float = BLOCK_S,
    ) -> None:
        # mcap costs ~0.1 s of start-up: only a recording needs it
        from mcap.writer import CompressionType, Writer  # noqa: PLC0415

        self.path = Path(path)
        self._tmp = self.path.with_name(self.path.name + ".part")
        if self.path.is_dir():
            raise CanLogError(f"{self.path}: is a directory, not a recording file")
        try:
            self._stream = self._tmp.open("wb")
        except OSError as exc:
            raise CanLogError(f"{self.path}: cannot write the recording: {exc.strerror}") from None
        self.time_base = time_base
        self.block_s = block_s
        self._writer = Writer(self._stream, compression=CompressionType.ZSTD)
        self._writer.start(profile=FORMAT, library="pacc.ecu.canlog")
        raw_schema = self._schema(RAW_SCHEMA_NAME, RAW_SCHEMA)
        self._raw_channel = self._writer.register_channel(RAW_TOPIC, "json", raw_schema)
        self._raw_seq = 0
        self._decoders: dict[tuple[int, bool], tuple[MessageColumns, int]] = {}
        self._decoded_seq: dict[int, int] = {}
        if db is not None:
            for message in db.messages:
                dec = MessageColumns(message)
                title = f"dbc.{message.name}"
                desc = (
                    f"{message.name} (frame id {message.frame_id:#x}, {message.length} bytes) "
                    "decoded from the DBC, one row per frame"
                )
                sid = self._schema(title, block_schema(title, desc, message_columns(dec)))
                ch = self._writer.register_channel(f"/can/{message.name}", "json", sid)
                key = (message.frame_id, bool(message.is_extended_frame))
                self._decoders[key] = (dec, ch)
                self._decoded_seq[ch] = 0
        self._series: dict[str, _Series] = {}
        self._events_channel: int | None = None
        self._events_seq = 0
        # the open block's frames, one list per column (no tuple per frame)
        self._ft: list[float] = []
        self._fid: list[int] = []
        self._ffl: list[int] = []
        self._fdlc: list[int] = []
        self._fdata: list[bytes] = []
        self._block_t0: float | None = None
        self.frames = 0
        self.closed = False
        #: why recording stopped (a failed write), None while it works; raised by close()
        self.error: str | None = None
        self.node = node
        #: the node's clock at the first frame or sample (the recording's start)
        self.first_t_s: float | None = None
        for name, record in (metadata or {}).items():
            self._writer.add_metadata(name, {str(k): str(v) for k, v in record.items()})
        for name, data in (attachments or {}).items():
            self.attach(name, data)

    def _schema(self, name: str, schema: Mapping[str, Any]) -> int:
        sid: int = self._writer.register_schema(name, "jsonschema", json.dumps(schema).encode())
        return sid

    # -- what a node feeds ---------------------------------------------------------------

    def attach(self, name: str, data: bytes, media_type: str = "text/plain") -> None:
        """Store ``data`` as the attachment ``name`` (stamped with the origin's UTC)."""
        stamp = self.time_base.utc_origin_ns
        self._writer.add_attachment(stamp, stamp, name, media_type, data)

    def frame(self, t_s: float, msg: can.Message, rx: bool) -> None:
        """One frame received (``rx``) or sent at ``t_s`` on the node's clock."""
        if self.error is not None:
            return
        flags = FLAG_RX if rx else 0
        if msg.is_extended_id:
            flags |= FLAG_EXTENDED
        if msg.is_fd or msg.is_error_frame or msg.is_remote_frame:
            flags = frame_flags(msg, rx)
        self._ft.append(t_s)
        self._fid.append(msg.arbitration_id)
        self._ffl.append(flags)
        self._fdlc.append(msg.dlc)
        self._fdata.append(bytes(msg.data))
        if self._block_t0 is None:
            self._block_t0 = t_s

    def frame_and_tick(self, t_s: float, msg: can.Message, rx: bool) -> None:
        """:meth:`frame`, then :meth:`tick`: a tap for a node without control cycles."""
        self.frame(t_s, msg, rx)
        self.tick(t_s)

    def series(self, topic: str, columns: Sequence[str], description: str = "") -> None:
        """Declare the sampled channel ``topic`` with ``columns`` (besides ``t_s``)."""
        if topic in self._series:
            return
        title = "pacc." + topic.strip("/").replace("/", ".")
        schema = block_schema(title, description or topic, series_columns(columns))
        sid = self._schema(title, schema)
        channel = self._writer.register_channel(topic, "json", sid)
        self._series[topic] = _Series(channel, tuple(columns))

    def sample(self, topic: str, t_s: float, values: tuple[Any, ...]) -> None:
        """One sample of a declared channel: ``values`` in its column order."""
        row = self._series[topic].values
        row.append(t_s)
        row.extend(values)
        if self._block_t0 is None:
            self._block_t0 = t_s

    def event(self, t_s: float, text: str) -> None:
        """One event text (written at once: events are rare)."""
        if self._events_channel is None:
            sid = self._schema("pacc.EcuEvent", EVENT_SCHEMA)
            self._events_channel = self._writer.register_channel(EVENTS_TOPIC, "json", sid)
        stamp = self.time_base.utc_ns(t_s)
        data = json.dumps({"t_s": t_s, "text": text}).encode()
        self._writer.add_message(self._events_channel, stamp, data, stamp, self._events_seq)
        self._events_seq += 1

    def cycle(self, t_s: float, inputs: NodeInputs, outputs: NodeOutputs, k: int = -1) -> None:
        """ECU control cycle ``k``: its inputs and outputs on ``/ecu/inputs`` and
        ``/ecu/outputs`` (``cycle`` the index on the node's cycle grid), its events on
        ``/ecu/events``; closes the block when it is due. Never raises: a failed write stops
        the recording (:attr:`error`), not the node."""
        if self.error is not None:
            return
        try:
            self._cycle(t_s, inputs, outputs, k)
        except Exception as exc:  # noqa: BLE001 - I/O at the edge: never stop the control loop
            self._fail(t_s, exc)

    def _cycle(self, t_s: float, inputs: NodeInputs, outputs: NodeOutputs, k: int) -> None:
        if INPUTS_TOPIC not in self._series:
            self.series(INPUTS_TOPIC, INPUT_FIELDS, "the ECU node's checked inputs per cycle")
            self.series(
                OUTPUTS_TOPIC, ("cycle", *OUTPUT_FIELDS), "the ECU node's outputs per cycle"
            )
        ins = self._series[INPUTS_TOPIC].values
        ins.append(t_s)
        ins.extend(_get_inputs(inputs))
        outs = self._series[OUTPUTS_TOPIC].values
        outs.append(t_s)
        outs.append(k)
        outs.extend(_get_outputs(outputs))
        if self._block_t0 is None:
            self._block_t0 = t_s
        for text in outputs.events:
            self.event(t_s, text)
        if t_s - self._block_t0 >= self.block_s:
            self.flush()

    def tick(self, t_s: float) -> None:
        """Close the open block if it is ``block_s`` old at ``t_s``. Never raises: a failed
        write stops the recording (:attr:`error`), not the node."""
        if self._block_t0 is not None and t_s - self._block_t0 >= self.block_s:
            try:
                self.flush()
            except Exception as exc:  # noqa: BLE001 - I/O at the edge: never stop the node
                self._fail(t_s, exc)

    def _fail(self, t_s: float, exc: Exception) -> None:
        """Stop recording after a failed write; :meth:`close` reports it."""
        self.error = f"recording stopped at t = {t_s:.3f} s: {type(exc).__name__}: {exc}"
        log.error("%s: %s", self.path, self.error)
        self._clear_frames()
        for s in self._series.values():
            s.values = []

    def _clear_frames(self) -> None:
        self._ft, self._fid, self._ffl, self._fdlc, self._fdata = [], [], [], [], []

    # -- blocks --------------------------------------------------------------------------

    def flush(self) -> None:
        """Write the open block of every channel."""
        if self.first_t_s is None:
            self.first_t_s = self._block_t0
        if self._ft:
            self._write_frames(self._ft, self._fid, self._ffl, self._fdlc, self._fdata)
            self._clear_frames()
        for s in self._series.values():
            if s.values:
                self._write_series(s)
        self._block_t0 = None

    def _write_frames(
        self,
        t: list[float],
        ids: list[int],
        flags: list[int],
        dlcs: list[int],
        datas: list[bytes],
    ) -> None:
        n = len(t)
        t_arr = np.fromiter(t, np.float64, n)
        id_arr = np.fromiter(ids, np.uint32, n)
        flag_arr = np.fromiter(flags, np.uint8, n)
        len_arr = np.fromiter(map(len, datas), np.uint8, n)
        payload = b"".join(datas)
        doc = encode_block(
            {
                "t_s": t_arr,
                "id": id_arr,
                "flags": flag_arr,
                "dlc": np.fromiter(dlcs, np.uint8, n),
                "len": len_arr,
                "data": np.frombuffer(payload, dtype=np.uint8),
            },
            ragged=("data",),
        )
        stamp = self.time_base.utc_ns(t[0])
        self._writer.add_message(self._raw_channel, stamp, doc, stamp, self._raw_seq)
        self._raw_seq += 1
        self.frames += n
        if self._decoders:
            self._write_decoded(t_arr, id_arr, flag_arr, len_arr, datas)

    def _write_decoded(
        self,
        t: np.ndarray,
        ids: np.ndarray,
        flags: np.ndarray,
        lens: np.ndarray,
        datas: Sequence[bytes],
    ) -> None:
        usable = (flags & (FLAG_ERROR | FLAG_REMOTE)) == 0
        extended = (flags & FLAG_EXTENDED) != 0
        for (frame_id, ext), (dec, channel) in self._decoders.items():
            mask = (ids == frame_id) & usable & (extended == ext) & (lens == dec.length)
            idx = np.flatnonzero(mask)  # a wrong length stays in /can/raw only
            if not len(idx):
                continue
            cols = {"t_s": t[idx]}
            cols.update(dec.decode([datas[i] for i in idx.tolist()]))
            stamp = self.time_base.utc_ns(float(t[idx[0]]))
            seq = self._decoded_seq[channel]
            self._writer.add_message(channel, stamp, encode_block(cols), stamp, seq)
            self._decoded_seq[channel] = seq + 1

    def _write_series(self, s: _Series) -> None:
        # booleans 0/1, NaN kept; one C-level pass over the flat list
        table = np.fromiter(s.values, np.float64, len(s.values)).reshape(-1, s.width)
        s.values = []
        self._write_table(s, table)

    def _write_table(self, s: _Series, table: np.ndarray) -> None:
        """One block of ``s`` from ``table``, shape ``(n, s.width)``, ``t_s`` first."""
        cols = {"t_s": table[:, 0]}
        for j, name in enumerate(s.columns, start=1):
            cols[name] = table[:, j]
        stamp = self.time_base.utc_ns(float(table[0, 0]))
        self._writer.add_message(s.channel, stamp, encode_block(cols), stamp, s.seq)
        s.seq += 1

    def write_series(
        self, topic: str, columns: Mapping[str, Iterable[Any]], t_s: Iterable[float]
    ) -> None:
        """Write whole columns at once (e.g. the simulated world after a drive), in blocks of
        ``block_s``; ``topic`` must be declared with the columns' names."""
        s = self._series[topic]
        t = np.asarray(list(t_s), dtype=np.float64)
        table = np.column_stack(
            [t, *(np.asarray(list(columns[k]), dtype=np.float64) for k in s.columns)]
        )
        start = 0
        while start < len(t):
            end = int(np.searchsorted(t, t[start] + self.block_s, side="left"))
            end = max(end, start + 1)
            self._write_table(s, table[start:end])
            start = end

    # -- end -----------------------------------------------------------------------------

    def close(self) -> None:
        """Write what is open, finish the file and rename it to ``path``."""
        if self.closed:
            return
        self.closed = True
        if self.error is not None:
            with contextlib.suppress(Exception):
                self._stream.close()
            raise CanLogError(f"{self.path}: {self.error}; what was written is in {self._tmp.name}")
        base = self.time_base
        first = self.first_t_s if self.first_t_s is not None else base.clock_origin_s
        start = {
            "format": FORMAT,
            "node": self.node,
            "utc_origin_ns": str(base.utc_origin_ns),
            "clock_origin_s": repr(base.clock_origin_s),
            "start_utc": base.iso(first),
        }
        try:
            self.flush()
            self._writer.add_metadata(META_RECORD, start)
            self._writer.finish()  # type: ignore[no-untyped-call]
            self._stream.close()
            self._tmp.replace(self.path)
        except OSError as exc:
            with contextlib.suppress(OSError):
                self._stream.close()
            raise CanLogError(f"{self.path}: cannot finish the recording: {exc}") from exc

    def __enter__(self) -> CanLogWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


#: A frame tap: (time on the node's clock, frame, received) -> None.
FrameTap = Callable[[float, can.Message, bool], None]
