"""Rows of numeric fields as protobuf messages, built and read with numpy.

The bus recorder writes every decoded frame and every control cycle as its own MCAP message
so that Foxglove and PlotJuggler plot the fields over time. Formatting JSON text costs about
1 µs a number in Python (five times python-can's BLF writer per frame, measured); a protobuf
message whose fields are all fixed-width (``double``, ``sfixed64``: wire type 1, eight bytes
each after a one- or two-byte tag) has the same layout for every row, so a whole table of
rows is a few numpy copies into one array (:meth:`ProtoRows.format`), and reads
back the same way (:func:`decode_rows`). The schema is a ``FileDescriptorSet`` (MCAP
``protobuf`` schema encoding), encoded here by hand (no protobuf runtime needed to record);
mcap's own protobuf support library decodes these messages (tested).

Field numbers are 1, 2, … in column order; ``double`` for measured values (NaN kept),
``sfixed64`` for counts, ids, states and booleans (0/1). A channel's layout is also kept in
its MCAP channel metadata (``pacc.layout``: ``name:d`` or ``name:q`` per field, comma
separated) so that the reader needs no protobuf runtime either.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = ["LAYOUT_KEY", "ProtoRows", "decode_rows", "parse_layout"]

#: channel metadata key of a channel's field layout
LAYOUT_KEY = "pacc.layout"
_TYPE_DOUBLE = 1
_TYPE_SFIXED64 = 16
_WIRE_FIXED64 = 1


def _varint(x: int) -> bytes:
    out = bytearray()
    while True:
        b = x & 0x7F
        x >>= 7
        if x:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def _field(number: int, wire: int, payload: bytes | int) -> bytes:
    if wire == 0:
        assert isinstance(payload, int)
        return _varint(number << 3) + _varint(payload)
    assert isinstance(payload, bytes)
    return _varint((number << 3) | 2) + _varint(len(payload)) + payload


def _string(number: int, text: str) -> bytes:
    return _field(number, 2, text.encode())


def _tag(number: int) -> bytes:
    return _varint((number << 3) | _WIRE_FIXED64)


def _dtype(names: Sequence[str], integral: Sequence[bool]) -> np.dtype:
    parts: list[tuple[str, str]] = []
    for i, (_name, is_int) in enumerate(zip(names, integral, strict=True), start=1):
        parts.append((f"t{i}", f"V{len(_tag(i))}"))
        parts.append((f"v{i}", "<i8" if is_int else "<f8"))
    return np.dtype(parts)


def parse_layout(layout: str) -> tuple[list[str], list[bool]]:
    """(names, integral) of a ``pacc.layout`` text."""
    names, integral = [], []
    for part in layout.split(","):
        name, _, kind = part.rpartition(":")
        if not name or kind not in ("d", "q"):
            raise ValueError(f"bad field layout {part!r}")
        names.append(name)
        integral.append(kind == "q")
    return names, integral


class ProtoRows:
    """The protobuf message of one kind of row.

    Args:
        full_name: the message's full name, ``package.Message`` (e.g. ``dbc.ESC_Speed``).
        names: the fields (identifiers), in the table's column order.
        integral: per field, True for ``sfixed64`` (else ``double``).
    """

    def __init__(self, full_name: str, names: Sequence[str], integral: Sequence[bool]) -> None:
        self.full_name = full_name
        self.names = tuple(names)
        self.integral = tuple(bool(x) for x in integral)
        self.dtype = _dtype(self.names, self.integral)
        self.layout = ",".join(
            f"{n}:{'q' if i else 'd'}" for n, i in zip(self.names, self.integral, strict=True)
        )
        # fields 1..15 have a one-byte tag (nine bytes a field), the others two (ten bytes)
        self._short = min(len(self.names), 15)
        tags = [_tag(i) for i in range(1, len(self.names) + 1)]
        self._tags1 = np.frombuffer(b"".join(tags[: self._short]), np.uint8)
        if any(len(tag) != 2 for tag in tags[self._short :]):
            raise ValueError(f"{full_name}: more than 2047 fields")
        self._tags2 = np.frombuffer(b"".join(tags[self._short :]), np.uint8).reshape(-1, 2)
        self._ints = np.flatnonzero(self.integral)

    def descriptor(self) -> bytes:
        """The schema: a serialized ``google.protobuf.FileDescriptorSet`` of one proto3 file
        holding this message."""
        package, _, message = self.full_name.rpartition(".")
        fields = b"".join(
            _field(
                2,
                2,
                _string(1, name)
                + _field(3, 0, number)
                + _field(4, 0, 1)  # LABEL_OPTIONAL
                + _field(5, 0, _TYPE_SFIXED64 if is_int else _TYPE_DOUBLE),
            )
            for number, (name, is_int) in enumerate(
                zip(self.names, self.integral, strict=True), start=1
            )
        )
        proto = _string(1, message) + fields
        file = (
            _string(1, f"{self.full_name.replace('.', '/')}.proto")
            + (_string(2, package) if package else b"")
            + _field(4, 2, proto)
            + _string(12, "proto3")
        )
        return _field(1, 2, file)

    def format(self, table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rows of ``table`` (float64, shape ``(n, len(names))``) as messages: (every
        message's bytes one after the other, uint8; each message's length, int64 ``(n,)``).
        An integral field that is not finite is written 0."""
        n = len(table)
        return self.format_into(table).reshape(-1), np.full(n, self.dtype.itemsize, np.int64)

    def format_into(self, table: np.ndarray, head: int = 0) -> np.ndarray:
        """:meth:`format`'s messages as the rows of a uint8 array ``(n, head + itemsize)``,
        each after ``head`` bytes left for the caller (an MCAP message record's header)."""
        n, width = len(table), len(self.names)
        values = np.array(table, dtype="<f8", order="C")  # a copy: the integral fields in place
        if len(self._ints):
            col = values[:, self._ints]
            values.view("<i8")[:, self._ints] = np.where(np.isfinite(col), col, 0.0)
        value_bytes = values.view(np.uint8).reshape(n, width, 8)
        out = np.empty((n, head + self.dtype.itemsize), dtype=np.uint8)
        short = out[:, head : head + 9 * self._short].reshape(n, self._short, 9)
        short[:, :, 0] = self._tags1
        short[:, :, 1:] = value_bytes[:, : self._short]
        if width > self._short:
            long = out[:, head + 9 * self._short :].reshape(n, width - self._short, 10)
            long[:, :, :2] = self._tags2
            long[:, :, 2:] = value_bytes[:, self._short :]
        return out


def decode_rows(layout: str, payloads: Sequence[bytes]) -> dict[str, np.ndarray]:
    """Columns of messages written by :class:`ProtoRows` with ``layout`` (int64 for the
    ``sfixed64`` fields, float64 else).

    Raises:
        ValueError: a message that is not of this layout.
    """
    names, integral = parse_layout(layout)
    dtype = _dtype(names, integral)
    data = b"".join(payloads)
    if len(data) != dtype.itemsize * len(payloads):
        raise ValueError(f"messages are not {dtype.itemsize} bytes each")
    rows = np.frombuffer(data, dtype=dtype)
    for i in range(1, len(names) + 1):
        want = _tag(i)
        if len(rows) and not (rows[f"t{i}"] == np.frombuffer(want, f"V{len(want)}")[0]).all():
            raise ValueError(f"field {names[i - 1]} has a wrong tag")
    return {name: rows[f"v{i}"].copy() for i, name in enumerate(names, start=1)}
