"""Reading a bus recording (:mod:`ecu.canlog`) back: frames, decoded signals, internals.

:func:`read_canlog` reads the whole file in one sequential pass (CRCs checked, the MCAP
footer required), so a truncated or corrupt file is refused with :class:`CanLogError`
naming the file and the cause, never read in part. :func:`messages` turns the raw frames
into python-can messages stamped with UTC seconds, as python-can's own readers do.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import can
import numpy as np

from ecu.canlog import (
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

__all__ = ["CanLog", "Frames", "messages", "read_canlog"]


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
        return (self.flags & FLAG_RX) != 0


@dataclass
class CanLog:
    """A recording read back (see :mod:`ecu.canlog` for the channels)."""

    path: Path
    frames: Frames
    #: DBC message name -> signal (and ``t_s``) -> values, every block joined
    decoded: dict[str, dict[str, list[Any]]]
    #: internals topic (``/ecu/outputs`` …) -> column -> values
    series: dict[str, dict[str, np.ndarray]]
    events: list[tuple[float, str]]
    metadata: dict[str, dict[str, str]]
    attachments: dict[str, bytes]
    time_base: TimeBase
    node: str = ""
    topics: list[str] = field(default_factory=list)


class _Collect:
    """What the pass over the records gathered."""

    def __init__(self) -> None:
        self.schemas: dict[int, Any] = {}
        self.channels: dict[int, Any] = {}
        self.blocks: dict[str, list[dict[str, Any]]] = {}
        self.events: list[tuple[float, str]] = []
        self.metadata: dict[str, dict[str, str]] = {}
        self.attachments: dict[str, bytes] = {}
        self.footer = False


def _scan(path: Path) -> _Collect:
    from mcap import records  # noqa: PLC0415 - mcap only when a recording is read
    from mcap.stream_reader import StreamReader  # noqa: PLC0415

    found = _Collect()
    try:
        with path.open("rb") as stream:
            for record in StreamReader(stream, validate_crcs=True).records:
                if isinstance(record, records.Channel):
                    found.channels[record.id] = record
                elif isinstance(record, records.Message):
                    ch = found.channels.get(record.channel_id)
                    if ch is None:
                        raise CanLogError(f"{path}: message on an unknown channel")
                    doc = json.loads(record.data)
                    if ch.topic == EVENTS_TOPIC:
                        found.events.append((float(doc["t_s"]), str(doc["text"])))
                    else:
                        found.blocks.setdefault(ch.topic, []).append(doc)
                elif isinstance(record, records.Metadata):
                    found.metadata[record.name] = dict(record.metadata)
                elif isinstance(record, records.Attachment):
                    found.attachments[record.name] = bytes(record.data)
                elif isinstance(record, records.Footer):
                    found.footer = True
    except CanLogError:
        raise
    except FileNotFoundError:
        raise CanLogError(f"{path}: no such recording") from None
    except IsADirectoryError:
        raise CanLogError(f"{path}: is a directory, not a recording") from None
    except Exception as exc:  # noqa: BLE001 - mcap raises many types on corrupt input
        kind = type(exc).__name__
        reason = "truncated" if kind in ("EndOfFile", "error") else "corrupt or not MCAP"
        raise CanLogError(f"{path}: {reason} recording ({kind}: {exc})") from exc
    return found


def _join(blocks: list[dict[str, Any]]) -> dict[str, list[Any]]:
    out: dict[str, list[Any]] = {}
    for doc in blocks:
        for k, v in doc.items():
            out.setdefault(k, []).extend(v)
    return out


def _frames(blocks: list[dict[str, Any]], path: Path) -> Frames:
    cols = _join(blocks)
    try:
        data = [bytes.fromhex(h) for h in cols.get("data", [])]
        frames = Frames(
            t_s=np.asarray(cols.get("t_s", []), dtype=np.float64),
            id=np.asarray(cols.get("id", []), dtype=np.int64),
            flags=np.asarray(cols.get("flags", []), dtype=np.int64),
            dlc=np.asarray(cols.get("dlc", []), dtype=np.int64),
            data=data,
        )
    except (ValueError, TypeError) as exc:
        raise CanLogError(f"{path}: bad {RAW_TOPIC} block: {exc}") from None
    n = len(data)
    if not (len(frames.t_s) == len(frames.id) == len(frames.flags) == len(frames.dlc) == n):
        raise CanLogError(f"{path}: {RAW_TOPIC} columns differ in length")
    return frames


def _series(cols: dict[str, list[Any]]) -> dict[str, np.ndarray]:
    return {
        k: np.asarray([np.nan if x is None else x for x in v], dtype=np.float64)
        for k, v in cols.items()
    }


def read_canlog(path: str | os.PathLike[str]) -> CanLog:
    """Read a recording of :mod:`ecu.canlog`.

    Raises:
        CanLogError: missing, not MCAP, truncated (no footer), bad CRC, or not a pacc bus
            recording (no ``/can/raw`` channel and no ``pacc`` metadata).
    """
    path = Path(path)
    found = _scan(path)
    if not found.footer:
        raise CanLogError(f"{path}: truncated recording (no MCAP footer)")
    meta = found.metadata.get(META_RECORD, {})
    topics = sorted({c.topic for c in found.channels.values()})
    if meta.get("format") != FORMAT or RAW_TOPIC not in topics:
        raise CanLogError(
            f"{path}: not a pacc bus recording (format {meta.get('format')!r}; topics "
            f"{topics or 'none'})"
        )
    try:
        base = TimeBase(int(meta["utc_origin_ns"]), float(meta["clock_origin_s"]))
    except (KeyError, ValueError) as exc:
        raise CanLogError(f"{path}: bad time base in the metadata: {exc}") from None
    decoded: dict[str, dict[str, list[Any]]] = {}
    series: dict[str, dict[str, np.ndarray]] = {}
    for topic, blocks in found.blocks.items():
        if topic == RAW_TOPIC:
            continue
        if topic.startswith("/can/"):
            decoded[topic.removeprefix("/can/")] = _join(blocks)
        else:
            series[topic] = _series(_join(blocks))
    return CanLog(
        path=path,
        frames=_frames(found.blocks.get(RAW_TOPIC, []), path),
        decoded=decoded,
        series=series,
        events=found.events,
        metadata=found.metadata,
        attachments=found.attachments,
        time_base=base,
        node=meta.get("node", ""),
        topics=topics,
    )


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
