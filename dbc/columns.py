"""Column-wise decoding of many frames of one DBC message, and the JSON schema of the result.

The bus recorder (:mod:`ecu.canlog`) decodes a block of frames at a time: the payloads of one
message become an ``(n, 8)`` byte array, read as one 64-bit integer per frame (little- or
big-endian, as the signal), and each signal is a shift, a mask, a sign extension and
``raw * scale + offset`` over the whole column (numpy). The arithmetic is cantools' own
(``raw * scale + offset`` in float64; integers when scale is 1 and offset 0, or both are
integers), so the values equal ``cantools``' ``Message.decode(data, decode_choices=False)``
frame by frame (tested). Messages this cannot vectorise — multiplexed ones, IEEE float
signals, payloads longer than 8 bytes — are decoded frame by frame with cantools, with
``None`` for a signal a frame does not carry.

Works on the cantools message itself, not on pacc's binding: every message of any DBC gets
a decoded channel, bound or not.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["MessageColumns", "message_schema"]

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
    big = signal.byte_order == "big_endian"
    if big:  # payload padded to 8 bytes on the right and read as one big-endian integer
        msb = (7 - signal.start // 8) * 8 + signal.start % 8
        shift = msb - signal.length + 1
    else:
        shift = signal.start
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
    """The decoder of one cantools message over blocks of payloads.

    Args:
        message: a ``cantools.database.can.Message``.
    """

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

    def decode(self, payloads: Sequence[bytes]) -> dict[str, list[Any]]:
        """Every signal of the message over ``payloads`` (each exactly ``length`` bytes),
        physical values, as lists of length ``len(payloads)`` (``None``: not carried)."""
        if not payloads:
            return {name: [] for name in self.signal_names}
        if not self.vectorised:
            return self._decode_each(payloads)
        n = len(payloads)
        buf = np.zeros((n, 8), dtype=np.uint8)
        buf[:, : self.length] = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(
            n, self.length
        )
        little = buf.view("<u8").reshape(n)
        big = buf.view(">u8").reshape(n)
        out: dict[str, list[Any]] = {}
        for c in self._columns:
            word = big if c.big_endian else little
            raw = ((word >> np.uint64(c.shift)) & np.uint64(c.mask)).astype(np.int64)
            if c.signed:
                raw = np.where(raw >= (1 << (c.length - 1)), raw - (1 << c.length), raw)
            if c.scale == 1 and c.offset == 0:
                out[c.name] = raw.tolist()
            elif c.integral:
                out[c.name] = (raw * int(c.scale) + int(c.offset)).tolist()
            else:
                out[c.name] = (raw * float(c.scale) + float(c.offset)).tolist()
        return out

    def _decode_each(self, payloads: Sequence[bytes]) -> dict[str, list[Any]]:
        out: dict[str, list[Any]] = {name: [] for name in self.signal_names}
        for data in payloads:
            values = self.message.decode(data, decode_choices=False, scaling=True)
            for name, col in out.items():
                value = values.get(name)
                col.append(value if isinstance(value, int | float) else None)
        return out


def _signal_schema(signal: Any) -> dict[str, Any]:
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
    kind = "integer" if _column(signal).integral and not signal.is_float else "number"
    return {
        "type": "array",
        "items": {"type": [kind, "null"]},
        "description": "; ".join(parts) or signal.name,
    }


def message_schema(message: Any) -> dict[str, Any]:
    """The JSON schema of a decoded block of ``message``: ``t_s`` plus one array per signal,
    each signal's unit, range, choices and comment from the DBC in its description."""
    props: dict[str, Any] = {
        TIME_KEY: {
            "type": "array",
            "items": {"type": "number"},
            "description": "receive/send time of each frame on the recording node's clock, s",
        }
    }
    for signal in message.signals:
        props[signal.name] = _signal_schema(signal)
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": f"dbc.{message.name}",
        "description": (
            f"{message.name} (frame id {message.frame_id:#x}, {message.length} bytes) decoded "
            "from the DBC, one array element per frame"
        ),
        "type": "object",
        "properties": props,
        "required": [TIME_KEY, *(s.name for s in message.signals)],
    }
