"""Column-wise decoding of many frames of any DBC message (bound or not), for the bus recorder.

A block of payloads becomes one 64-bit integer per frame; each signal is a shift, a mask, a
sign extension and cantools' own ``raw * scale + offset`` over the column (numpy), so values
equal cantools' ``decode(data, decode_choices=False)`` (tested). Multiplexed, float and
longer-than-8-byte messages are decoded frame by frame with cantools (NaN: not carried).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from dbc.layout import placement

__all__ = ["MessageColumns", "message_columns"]

#: The time column of every decoded block, s (the recording node's clock).
TIME_KEY = "t_s"


@dataclass(frozen=True)
class _SignalColumn:
    name: str
    shift: int
    mask: int
    length: int
    signed: bool
    big_endian: bool
    scale: Any  # int or float, as cantools keeps it
    offset: Any
    integral: bool  # cantools returns ints (scale 1, offset 0, or both integers)


def _is_integer(x: Any) -> bool:
    """cantools' test for an integer scale or offset (an int, or a float with no fraction)."""
    return isinstance(x, int) or (isinstance(x, float) and x.is_integer())


def _column(signal: Any) -> _SignalColumn:
    shift, big = placement(signal, 8)  # the payload padded to 8 bytes on the right
    scale, offset = signal.scale, signal.offset
    integral = (scale == 1 and offset == 0) or (_is_integer(scale) and _is_integer(offset))
    return _SignalColumn(
        name=signal.name,
        shift=shift,
        mask=(1 << signal.length) - 1,
        length=signal.length,
        signed=bool(signal.is_signed),
        big_endian=big,
        scale=scale,
        offset=offset,
        integral=integral,
    )


class MessageColumns:
    """The decoder of one cantools message over blocks of payloads."""

    def __init__(self, message: Any) -> None:
        self.message = message
        self.name: str = message.name
        self.frame_id: int = message.frame_id
        self.length: int = message.length
        self.signal_names: tuple[str, ...] = tuple(s.name for s in message.signals)
        self.vectorised = (
            self.length <= 8
            and not message.is_multiplexed()
            and not any(s.is_float for s in message.signals)
        )
        self._columns = tuple(_column(s) for s in message.signals) if self.vectorised else ()

    def decode(self, payloads: Sequence[bytes]) -> dict[str, np.ndarray]:
        """Every signal over ``payloads`` (each ``length`` bytes), physical values, arrays
        (n,): int64 where cantools gives integers, else float64 (NaN: not carried)."""
        if not self.vectorised:
            return self._decode_each(payloads)
        n = len(payloads)
        buf = np.zeros((n, 8), dtype=np.uint8)
        if n:
            buf[:, : self.length] = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(
                n, self.length
            )
        little = buf.view("<u8").reshape(n)
        big = buf.view(">u8").reshape(n)
        out: dict[str, np.ndarray] = {}
        for c in self._columns:
            word = big if c.big_endian else little
            raw = ((word >> np.uint64(c.shift)) & np.uint64(c.mask)).astype(np.int64)
            if c.signed:
                raw = np.where(raw >= (1 << (c.length - 1)), raw - (1 << c.length), raw)
            if c.scale == 1 and c.offset == 0:
                out[c.name] = raw
            elif c.integral:
                out[c.name] = raw * int(c.scale) + int(c.offset)
            else:
                out[c.name] = raw * float(c.scale) + float(c.offset)
        return out

    def _decode_each(self, payloads: Sequence[bytes]) -> dict[str, np.ndarray]:
        cols: dict[str, list[float]] = {name: [] for name in self.signal_names}
        for data in payloads:
            values = self.message.decode(data, decode_choices=False, scaling=True)
            for name, col in cols.items():
                value = values.get(name)
                col.append(float(value) if isinstance(value, int | float) else math.nan)
        return {name: np.asarray(col, dtype=np.float64) for name, col in cols.items()}

    def dtypes(self) -> dict[str, str]:
        """Signal name -> the dtype :meth:`decode` gives it (``<i8`` or ``<f8``)."""
        if not self.vectorised:
            return dict.fromkeys(self.signal_names, "<f8")
        return {c.name: "<i8" if c.integral else "<f8" for c in self._columns}


def _signal_description(signal: Any) -> str:
    parts = []
    if signal.unit:
        parts.append(f"unit {signal.unit}")
    if signal.minimum is not None or signal.maximum is not None:
        parts.append(f"range [{signal.minimum}, {signal.maximum}]")
    if signal.choices:
        parts.append("choices " + ", ".join(f"{int(k)}={v}" for k, v in signal.choices.items()))
    comment = signal.comment if isinstance(signal.comment, str) else None
    if comment:
        parts.append(comment)
    return "; ".join(parts) or signal.name


def message_columns(columns: MessageColumns) -> dict[str, tuple[str, str]]:
    """Column name -> (dtype, description) of a decoded block: ``t_s`` and every signal with
    its unit, range, choices and comment from the DBC."""
    out = {TIME_KEY: ("<f8", "receive/send time of each frame on the recording node's clock, s")}
    dtypes = columns.dtypes()
    for signal in columns.message.signals:
        out[signal.name] = (dtypes[signal.name], _signal_description(signal))
    return out
