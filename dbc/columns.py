"""Column-wise decoding of many frames of any DBC message (bound or not), for the bus recorder.

A block of payloads becomes one 64-bit integer per frame; each signal is a shift, a mask, a
sign extension and cantools' own ``raw * scale + offset`` over the column (numpy), so values
equal cantools' ``decode(data, decode_choices=False)`` (tested). Multiplexed, float and
longer-than-8-byte messages are decoded frame by frame with cantools (NaN: not carried).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from dbc.layout import placement

#: The time column of every decoded block, s (the recording node's clock).
TIME_KEY = "t_s"


def _integral(signal: Any) -> bool:
    """Whether cantools decodes ``signal`` to ints: scale 1 and offset 0, or both integers
    (an int, or a float with no fraction: cantools' own test)."""
    pair = (signal.scale, signal.offset)
    whole = all(isinstance(x, int) or (isinstance(x, float) and x.is_integer()) for x in pair)
    return pair == (1, 0) or whole


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
        #: per signal: the signal, its LSB's shift and byte order in the payload padded to 8
        #: bytes (one integer per frame), and whether it decodes to ints
        self._columns = tuple(
            (s, *placement(s, 8), _integral(s))
            for s in (message.signals if self.vectorised else ())
        )

    def decode(self, payloads: Sequence[bytes]) -> dict[str, np.ndarray]:
        """Every signal over ``payloads`` (each ``length`` bytes), physical values, arrays
        (n,): int64 where cantools gives integers, else float64 (NaN: not carried)."""
        if not self.vectorised:
            return self._decode_each(payloads)
        n = len(payloads)
        buf = np.zeros((n, 8), dtype=np.uint8)
        if n:
            data = np.frombuffer(b"".join(payloads), dtype=np.uint8)
            buf[:, : self.length] = data.reshape(n, self.length)
        little = buf.view("<u8").reshape(n)
        big = buf.view(">u8").reshape(n)
        out: dict[str, np.ndarray] = {}
        for s, shift, big_endian, integral in self._columns:
            word = big if big_endian else little
            mask = np.uint64((1 << s.length) - 1)
            raw = ((word >> np.uint64(shift)) & mask).astype(np.int64)
            if s.is_signed:
                raw = np.where(raw >= (1 << (s.length - 1)), raw - (1 << s.length), raw)
            if integral:
                out[s.name] = raw * int(s.scale) + int(s.offset)
            else:
                out[s.name] = raw * float(s.scale) + float(s.offset)
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
        return {s.name: "<i8" if integral else "<f8" for s, _, _, integral in self._columns}


def _signal_description(signal: Any) -> str:
    parts = []
    if signal.unit:
        parts.append(f"unit {signal.unit}")
    if signal.minimum is not None or signal.maximum is not None:
        parts.append(f"range [{signal.minimum}, {signal.maximum}]")
    if signal.choices:
        parts.append("choices " + ", ".join(f"{int(k)}={v}" for k, v in signal.choices.items()))
    if isinstance(signal.comment, str) and signal.comment:
        parts.append(signal.comment)
    return "; ".join(parts) or signal.name


def message_columns(columns: MessageColumns) -> dict[str, tuple[str, str]]:
    """Column name -> (dtype, description) of a decoded block: ``t_s`` and every signal with
    its unit, range, choices and comment from the DBC."""
    dtypes = columns.dtypes()
    return {
        TIME_KEY: ("<f8", "receive/send time of each frame on the recording node's clock, s"),
        **{s.name: (dtypes[s.name], _signal_description(s)) for s in columns.message.signals},
    }
