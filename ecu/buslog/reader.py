"""Reading a bus recording (:mod:`ecu.buslog.writer`) back: frames, decoded signals, internals.

:func:`read_canlog` reads the whole file in one sequential pass (CRCs checked). By default the
MCAP footer is required, so a truncated or corrupt file is refused with :class:`CanLogError`
naming the file and the cause. With ``recover=True`` a file without its end (a ``.part`` left
by a killed recorder) is read up to its last complete chunk, and :attr:`CanLog.complete` is
False (:attr:`CanLog.note` says what was read). One format, ``pacc.canlog/2`` (a raw block
per flush, a protobuf message per decoded frame and per cycle). :func:`messages` turns the raw
frames into python-can messages stamped with UTC seconds, as python-can's own readers do.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can
import numpy as np

from dbc.vocab.mcap_errors import mcap_errors
from ecu.buslog.blocks import BlockError, decode_block
from ecu.buslog.format import (
    EVENTS_TOPIC,
    FLAG_BRS,
    FLAG_ERROR,
    FLAG_ESI,
    FLAG_EXTENDED,
    FLAG_FD,
    FLAG_REMOTE,
    FLAG_RX,
    FORMAT,
    META_RECORD,
    RAW_TOPIC,
    CanLogError,
    TimeBase,
)
from ecu.buslog.proto import LAYOUT_KEY, decode_rows


@dataclass
class Frames:
    """Every frame of a recording in bus order; arrays of shape ``(n,)``, ``data`` a list."""

    t_s: np.ndarray
    id: np.ndarray
    flags: np.ndarray
    dlc: np.ndarray
    data: list[bytes]

    def __len__(self) -> int:
        return len(self.data)

    @property
    def rx(self) -> np.ndarray:
        """True for the frames the recording node received, shape ``(n,)``."""
        rx: np.ndarray = (self.flags & FLAG_RX) != 0
        return rx


@dataclass
class CanLog:
    """A recording read back (see :mod:`ecu.buslog.writer` for the channels)."""

    path: Path
    frames: Frames
    #: DBC message name -> signal (and ``t_s``) -> values, every block joined
    decoded: dict[str, dict[str, np.ndarray]]
    #: internals topic (``/ecu/outputs`` …) -> column -> values
    series: dict[str, dict[str, np.ndarray]]
    events: list[tuple[float, str]]
    metadata: dict[str, dict[str, str]]
    attachments: dict[str, bytes]
    time_base: TimeBase
    node: str = ""
    topics: list[str] = field(default_factory=list)
    #: False: the file has no end (a killed recording), read up to its last complete chunk
    complete: bool = True
    #: what recovery read, for a warning ("" when complete)
    note: str = ""


def mcap_records(path: Path, recover: bool) -> tuple[list[Any], str]:
    """Every record of the MCAP file ``path`` in file order (CRCs checked), and what stopped the
    reading ("" at the end); ``recover`` reads a file cut short up to its last complete record
    (CanLogError: missing, not MCAP, cut short without ``recover`` or before a channel)."""
    from mcap import records  # noqa: PLC0415 - mcap only when a recording is read
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    out: list[Any] = []
    with mcap_errors(path, "recording", CanLogError), path.open("rb") as stream:
        try:
            for record in StreamReader(stream, validate_crcs=True).records:
                out.append(record)
        except Exception as exc:  # noqa: BLE001 - mcap raises many types at a cut
            if not recover or not any(isinstance(r, records.Channel) for r in out):
                raise
            return out, f"{type(exc).__name__} at byte {stream.tell()}"
    return out, ""


def _scan(path: Path, recover: bool) -> tuple[Any, ...]:
    """The file's channels, messages' data by topic, events, metadata, attachments, whether it
    has its footer, and what cut it short."""
    from mcap import records  # noqa: PLC0415

    got, tail_error = mcap_records(path, recover)
    channels: dict[int, Any] = {}
    blocks: dict[str, list[bytes]] = {}  # topic -> its messages' data
    events: list[tuple[float, str]] = []
    metadata: dict[str, dict[str, str]] = {}
    attachments: dict[str, bytes] = {}
    footer = False
    for rec in got:
        if isinstance(rec, records.Message):
            ch = channels.get(rec.channel_id)
            if ch is None:
                raise CanLogError(f"{path}: message on an unknown channel")
            if ch.topic == EVENTS_TOPIC:
                doc = json.loads(rec.data)
                t = doc.get("t_s")
                events.append((float("nan") if t is None else float(t), str(doc["message"])))
            else:
                blocks.setdefault(ch.topic, []).append(rec.data)
        elif isinstance(rec, records.Channel):
            channels[rec.id] = rec
        elif isinstance(rec, records.Metadata):
            metadata[rec.name] = dict(rec.metadata)
        elif isinstance(rec, records.Attachment):
            attachments[rec.name] = bytes(rec.data)
        elif isinstance(rec, records.Footer):
            footer = True
    return channels, blocks, events, metadata, attachments, footer, tail_error


def _frames(blocks: list[dict[str, np.ndarray]], path: Path) -> Frames:
    if not blocks:
        empty = np.zeros(0, dtype=np.int64)
        return Frames(np.zeros(0), empty, empty, empty, [])
    try:
        cols = {k: np.concatenate([b[k] for b in blocks]) for k in blocks[0]}
        lens = cols["len"].astype(np.int64)
        payload = cols["data"].tobytes()
        ends = np.cumsum(lens).tolist()
        if (ends[-1] if ends else 0) != len(payload):
            raise CanLogError(f"{path}: {RAW_TOPIC} payload lengths do not add up")
        starts = [0, *ends[:-1]]
        return Frames(
            t_s=cols["t_s"].astype(np.float64),
            id=cols["id"].astype(np.int64),
            flags=cols["flags"].astype(np.int64),
            dlc=cols["dlc"].astype(np.int64),
            data=[payload[a:b] for a, b in zip(starts, ends, strict=True)],
        )
    except KeyError as exc:
        raise CanLogError(f"{path}: {RAW_TOPIC} block lacks column {exc}") from None
    except ValueError as exc:  # columns of different lengths
        raise CanLogError(f"{path}: bad {RAW_TOPIC} block: {exc}") from None


def read_canlog(path: str | os.PathLike[str], *, recover: bool = False) -> CanLog:
    """Read a recording of :mod:`ecu.buslog.writer` (CanLogError: missing, not MCAP, truncated
    unless ``recover``, bad CRC, or no ``/can/raw`` channel and no ``pacc`` metadata)."""
    path = Path(path)
    channels, blocks, events, metadata, attachments, footer, tail_error = _scan(path, recover)
    if not footer and not recover:
        raise CanLogError(f"{path}: truncated recording (no MCAP footer)")
    meta = metadata.get(META_RECORD, {})
    layouts = {c.topic: c.metadata.get(LAYOUT_KEY) for c in channels.values()}
    topics = sorted(layouts)
    fmt = meta.get("format")
    if fmt != FORMAT or RAW_TOPIC not in topics:
        raise CanLogError(
            f"{path}: not a pacc bus recording (format {fmt!r}; topics {topics or 'none'})"
        )
    try:
        base = TimeBase(int(meta.get("utc_origin_ns", 0)), float(meta.get("clock_origin_s", 0)))
    except ValueError as exc:
        raise CanLogError(f"{path}: bad time base in the metadata: {exc}") from None
    try:
        raw = [decode_block(b) for b in blocks.get(RAW_TOPIC, [])]
    except BlockError as exc:
        raise CanLogError(f"{path}: corrupt block: {exc}") from None
    decoded: dict[str, dict[str, np.ndarray]] = {}
    series: dict[str, dict[str, np.ndarray]] = {}
    for topic, data in blocks.items():
        if topic == RAW_TOPIC:
            continue
        try:
            layout = layouts[topic]
            if layout is None:
                raise ValueError(f"channel has no {LAYOUT_KEY}")
            joined = decode_rows(layout, data)
        except (ValueError, KeyError) as exc:
            raise CanLogError(f"{path}: messages of {topic} do not match: {exc}") from None
        if topic.startswith("/can/"):
            decoded[topic.removeprefix("/can/")] = joined
        else:
            series[topic] = joined
    frames = _frames(raw, path)
    note = ""
    if not footer:
        note = (
            f"{path}: unfinished recording (no MCAP end: the recorder was killed?); read "
            f"{len(frames)} frames up to its last complete chunk"
            + (f" ({tail_error})" if tail_error else "")
        )
    return CanLog(
        path=path,
        frames=frames,
        decoded=decoded,
        series=series,
        events=events,
        metadata=metadata,
        attachments=attachments,
        time_base=base,
        node=meta.get("node", ""),
        topics=topics,
        complete=footer,
        note=note,
    )


def read_recording(path: str | os.PathLike[str], warn: Callable[[str], None]) -> CanLog:
    """:func:`read_canlog` for a command: a recording killed mid-run (``.part``) is read up
    to its last complete chunk and ``warn`` gets one line saying so."""
    log = read_canlog(path, recover=True)
    if not log.complete:
        warn(log.note + "; pacc export FILE.part FILE.mcap makes it a complete file")
    return log


def messages(log: CanLog) -> Iterator[can.Message]:
    """The recording's frames as python-can messages, ``timestamp`` in UTC seconds and
    ``is_rx`` from the direction, in bus order."""
    f = log.frames
    base = log.time_base
    for t, fid, fl, dlc, data in zip(
        f.t_s.tolist(), f.id.tolist(), f.flags.tolist(), f.dlc.tolist(), f.data, strict=True
    ):
        yield can.Message(
            timestamp=base.utc_ns(t) / 1e9,
            arbitration_id=fid,
            is_extended_id=bool(fl & FLAG_EXTENDED),
            is_remote_frame=bool(fl & FLAG_REMOTE),
            is_error_frame=bool(fl & FLAG_ERROR),
            is_fd=bool(fl & FLAG_FD),
            is_rx=bool(fl & FLAG_RX),
            bitrate_switch=bool(fl & FLAG_BRS),
            error_state_indicator=bool(fl & FLAG_ESI),
            dlc=dlc,
            data=data,
            check=False,
        )
