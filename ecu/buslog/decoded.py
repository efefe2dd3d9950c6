"""The frames of one flush as the recorder writes them: the raw block, and per DBC message a
table of decoded signals (one row per frame, float64) for its protobuf channel; the control
cycles' tables likewise. The tap keeps each frame in the raw form of :mod:`dbc.frame`; a flush
reads the columns a field at a time (:meth:`FrameBatch.of`).
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator, Sequence
from typing import Any

import numpy as np

from dbc.columns import MessageColumns, message_columns
from dbc.frame import ID_MASK, OTHER, message_of
from ecu.buslog.blocks import encode_block
from ecu.buslog.format import (
    FLAG_ERROR,
    FLAG_EXTENDED,
    FLAG_REMOTE,
    FLAG_RX,
    frame_flags,
)
from ecu.buslog.proto import ProtoRows

#: A frame as the recorder's tap keeps it, flat, four items a frame: (time on the node's clock,
#: s; raw key, :mod:`dbc.frame`; the payload, or the message for ``OTHER``; received)
Tapped = tuple[float, int, Any, bool]
#: items a frame in the flat list of :data:`Tapped`
STRIDE = 4


_INTEGRAL_TYPES = ("bool", "int", "AccState", "FaultCode")


def floats(values: Iterable[Any]) -> np.ndarray:
    """``values`` (an array, a sequence or any iterable) as a float64 array."""
    if not isinstance(values, np.ndarray | list | tuple):
        values = list(values)
    return np.asarray(values, dtype=np.float64)


def cycle_tables(
    cycles: bytes, in_width: int, width: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The control cycles kept as float64 bytes (``width`` values a cycle: ``t_s``, index, inputs,
    outputs) as ``t_s`` ``(n,)``, the inputs' rows ``(n, in_width)`` (``t_s`` first) and the
    outputs' rows (``t_s``, index, outputs)."""
    data = np.frombuffer(cycles, np.float64).reshape(-1, width)
    inputs = np.concatenate([data[:, :1], data[:, 2 : in_width + 1]], axis=1)
    outputs = np.concatenate([data[:, :2], data[:, in_width + 1 :]], axis=1)
    return data[:, 0], inputs, outputs


def integral_fields(cls: type, names: Sequence[str]) -> tuple[bool, ...]:
    """Per field of the dataclass ``cls``: written as an integer (bool, int, an IntEnum)."""
    hints = {k: str(v) for k, v in cls.__annotations__.items()}
    return tuple(hints.get(n) in _INTEGRAL_TYPES for n in names)


class Rows:
    """One channel of rows: its handle in every sink, its row format, the next sequence
    number."""

    def __init__(self, handles: list[int], rows: ProtoRows) -> None:
        self.handles = handles
        self.rows = rows
        self.width = len(rows.names)
        self.seq = 0


class FrameBatch:
    """Frames as arrays, shape ``(n,)``: times (s), ids, flags, DLCs, payload lengths; and
    the payloads (a list)."""

    def __init__(
        self,
        t: np.ndarray,
        ids: np.ndarray,
        flags: np.ndarray,
        dlcs: np.ndarray,
        lens: np.ndarray,
        datas: list[Any],
    ) -> None:
        self.t, self.ids, self.flags, self.dlcs, self.lens = t, ids, flags, dlcs, lens
        self.datas = datas
        self.n = len(t)

    @classmethod
    def of(cls, frames: Sequence[Any]) -> FrameBatch:
        """The batch of the tapped frames (:data:`Tapped`, flat, at least one frame), read an
        attribute at a time over all frames."""
        t, ids, flags, dlcs, lens, datas = _columns(frames)
        u8 = np.uint8
        return cls(
            np.frombuffer(t, np.float64),
            np.frombuffer(ids, np.uint32),
            np.frombuffer(flags, u8),
            np.frombuffer(dlcs, u8),
            np.frombuffer(lens, u8),
            datas,
        )

    @classmethod
    def join(cls, batches: Sequence[FrameBatch]) -> FrameBatch:
        """One batch of the frames of ``batches``, in order."""
        if len(batches) == 1:
            return batches[0]
        t, ids, flags, dlcs, lens = (
            np.concatenate([getattr(b, k) for b in batches])
            for k in ("t", "ids", "flags", "dlcs", "lens")
        )
        return cls(t, ids, flags, dlcs, lens, [d for b in batches for d in b.datas])

    def block(self) -> bytes:
        """The ``/can/raw`` block of these frames (:func:`encode_block`)."""
        return encode_block(
            {
                "t_s": self.t,
                "id": self.ids,
                "flags": self.flags,
                "dlc": self.dlcs,
                "len": self.lens,
                "data": np.frombuffer(b"".join(self.datas), dtype=np.uint8),
            },
            ragged=("data",),
        )


def _columns(frames: Sequence[Any]) -> tuple[bytes, bytes, bytes, bytes, bytes, list[Any]]:
    """The columns of the tapped frames (:data:`Tapped`, flat) as little-endian bytes: ``t_s``
    (float64), id (uint32), flags, dlc, payload length (uint8 each); and the payloads."""
    ts, keys, items, rxs = (frames[i::STRIDE] for i in range(STRIDE))
    n = len(ts)
    if OTHER not in keys:  # classic data frames only: no per-frame Python code
        karr = np.fromiter(keys, np.uint32, n)
        rx = np.frombuffer(bytes(map(bool, rxs)), np.uint8)
        ext = (karr >> np.uint32(31)).astype(np.uint8)
        lens = bytes(map(len, items))
        return (
            struct.pack(f"<{n}d", *ts),
            (karr & np.uint32(ID_MASK)).astype("<u4").tobytes(),
            (ext * np.uint8(FLAG_EXTENDED) | rx * np.uint8(FLAG_RX)).tobytes(),
            lens,  # a classic frame's DLC is its length
            lens,
            list(items),
        )
    msgs = [
        item if key == OTHER else message_of((t, key, item), None)
        for t, key, item in zip(ts, keys, items, strict=True)
    ]
    datas = [m.data for m in msgs]
    flags = bytes(
        frame_flags(m, r)
        if m.is_fd or m.is_error_frame or m.is_remote_frame
        else (FLAG_EXTENDED if m.is_extended_id else 0) | (FLAG_RX if r else 0)
        for m, r in zip(msgs, rxs, strict=True)
    )
    return (
        struct.pack(f"<{n}d", *ts),
        struct.pack(f"<{n}I", *(m.arbitration_id for m in msgs)),
        flags,
        bytes(m.dlc for m in msgs),
        bytes(map(len, datas)),
        datas,
    )


class MessageDecoders:
    """The decoder and the protobuf row of every message of ``db`` (a cantools database)."""

    def __init__(self, db: Any) -> None:
        self.rows: dict[tuple[int, bool], tuple[MessageColumns, ProtoRows, str]] = {}
        for message in db.messages if db is not None else ():
            dec = MessageColumns(message)
            cols = message_columns(dec)
            ints = [not d.endswith("f8") for d, _ in cols.values()]
            rows = ProtoRows(f"dbc.{message.name}", list(cols), ints)
            key = (message.frame_id, bool(message.is_extended_frame))
            self.rows[key] = (dec, rows, f"/can/{message.name}")

    def tables(self, b: FrameBatch) -> Iterator[tuple[tuple[int, bool], np.ndarray, np.ndarray]]:
        """(message key, table ``t_s`` then every signal, float64 ``(k, 1 + signals)``, the
        frames' indices in ``b``) of every DBC message with frames in ``b``."""
        if not self.rows or not b.n:
            return
        order = np.argsort(b.ids, kind="stable")
        ids, starts, counts = np.unique(b.ids[order], return_index=True, return_counts=True)
        for frame_id, start, count in zip(
            ids.tolist(), starts.tolist(), counts.tolist(), strict=True
        ):
            idx = order[start : start + count]
            fl = b.flags[idx]
            for ext in (False, True):
                found = self.rows.get((frame_id, ext))
                if found is None:
                    continue
                dec = found[0]
                ok = ((fl & (FLAG_ERROR | FLAG_REMOTE)) == 0) & (((fl & FLAG_EXTENDED) != 0) == ext)
                sel = idx[ok & (b.lens[idx] == dec.length)]
                if not len(sel):
                    continue
                cols = dec.decode([b.datas[i] for i in sel.tolist()])
                table = np.column_stack(
                    [b.t[sel], *(np.asarray(v, dtype=np.float64) for v in cols.values())]
                )
                yield (frame_id, ext), table, sel
