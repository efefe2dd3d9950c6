"""The frames of one flush as the recorder writes them: the raw block, and per DBC message a
table of decoded signals (one row per frame) for its protobuf channel.

The frames are grouped by id with one sort; each DBC message's frames (its id, standard or
extended, not error or remote frames, the DBC's length: any other frame stays in ``/can/raw``
only) are decoded column by column (:mod:`dbc.columns`: cantools' values).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np

from dbc.columns import MessageColumns, message_columns
from ecu.buslog.blocks import encode_block
from ecu.buslog.format import FLAG_ERROR, FLAG_EXTENDED, FLAG_REMOTE
from ecu.buslog.proto import ProtoRows

__all__ = ["FrameBatch", "MessageDecoders", "integral_fields"]

_INTEGRAL_TYPES = ("bool", "int", "AccState", "FaultCode")


def integral_fields(cls: type, names: Sequence[str]) -> tuple[bool, ...]:
    """Per field of the dataclass ``cls``: written as an integer (bool, int, an IntEnum)."""
    hints = {k: str(v) for k, v in cls.__annotations__.items()}
    return tuple(hints.get(n) in _INTEGRAL_TYPES for n in names)


class FrameBatch:
    """Frames as arrays, shape ``(n,)``, and the payloads."""

    def __init__(
        self,
        t: list[float],
        ids: list[int],
        flags: list[int],
        dlcs: list[int],
        datas: list[bytes],
    ) -> None:
        n = len(t)
        self.n = n
        self.datas = datas
        self.t = np.fromiter(t, np.float64, n)
        self.ids = np.fromiter(ids, np.uint32, n)
        self.flags = np.fromiter(flags, np.uint8, n)
        self.dlcs = np.fromiter(dlcs, np.uint8, n)
        self.lens = np.fromiter(map(len, datas), np.uint8, n)

    @classmethod
    def join(cls, batches: Sequence[FrameBatch]) -> FrameBatch:
        """One batch of the frames of ``batches``, in order."""
        if len(batches) == 1:
            return batches[0]
        out = cls([], [], [], [], [])
        out.datas = [d for b in batches for d in b.datas]
        out.n = len(out.datas)
        for name in ("t", "ids", "flags", "dlcs", "lens"):
            setattr(out, name, np.concatenate([getattr(b, name) for b in batches]))
        return out

    def block(self) -> bytes:
        """The ``/can/raw`` block of these frames."""
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
