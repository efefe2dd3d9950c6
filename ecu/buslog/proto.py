"""Rows of numeric fields as protobuf messages, built and read with numpy."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: channel metadata key of a channel's field layout
LAYOUT_KEY = "pacc.layout"


def _tag(number: int) -> bytes:
    """The varint key of field ``number``, wire type 1 (fixed 64 bits)."""
    key, out = (number << 3) | 1, bytearray()
    while key > 0x7F:
        out.append(key & 0x7F | 0x80)
        key >>= 7
    return bytes([*out, key])


def _dtype(integral: Sequence[bool]) -> np.dtype:
    parts: list[tuple[str, str]] = []
    for i, is_int in enumerate(integral, start=1):
        parts += [(f"t{i}", f"V{len(_tag(i))}"), (f"v{i}", "<i8" if is_int else "<f8")]
    return np.dtype(parts)


class ProtoRows:
    """The protobuf message of one kind of row: ``full_name`` ``package.Message``, the fields'
    ``names`` in the table's column order, ``integral`` per field (sfixed64, else double)."""

    def __init__(self, full_name: str, names: Sequence[str], integral: Sequence[bool]) -> None:
        self.full_name = full_name
        self.names = tuple(names)
        self.integral = tuple(bool(x) for x in integral)
        self.dtype = _dtype(self.integral)
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
        from google.protobuf import (  # type: ignore[import-untyped]  # noqa: PLC0415
            descriptor_pb2,  # only to declare a channel
        )

        field = descriptor_pb2.FieldDescriptorProto
        package, _, name = self.full_name.rpartition(".")
        file = descriptor_pb2.FileDescriptorProto(
            name=f"{self.full_name.replace('.', '/')}.proto", package=package, syntax="proto3"
        )
        message = file.message_type.add(name=name)
        for number, (fname, is_int) in enumerate(
            zip(self.names, self.integral, strict=True), start=1
        ):
            message.field.add(
                name=fname,
                number=number,
                label=field.LABEL_OPTIONAL,
                type=field.TYPE_SFIXED64 if is_int else field.TYPE_DOUBLE,
            )
        out: bytes = descriptor_pb2.FileDescriptorSet(file=[file]).SerializeToString()
        return out

    def format_into(self, table: np.ndarray, head: int = 0) -> np.ndarray:
        """The rows of ``table`` (float64 ``(n, len(names))``) as messages: a uint8 array
        ``(n, head + itemsize)``, each row after ``head`` bytes left for the caller (a record
        header); a non-finite integral field is written 0."""
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
    ``sfixed64`` fields, float64 else; ValueError: a message not of this layout)."""
    names, kinds = zip(*(part.rpartition(":")[::2] for part in layout.split(",")), strict=True)
    if not all(names) or not set(kinds) <= {"d", "q"}:
        raise ValueError(f"bad field layout {layout!r}")
    dtype = _dtype([kind == "q" for kind in kinds])
    data = b"".join(payloads)
    if len(data) != dtype.itemsize * len(payloads):
        raise ValueError(f"messages are not {dtype.itemsize} bytes each")
    rows = np.frombuffer(data, dtype=dtype)
    for i in range(1, len(names) + 1):
        want = _tag(i)
        if len(rows) and not (rows[f"t{i}"] == np.frombuffer(want, f"V{len(want)}")[0]).all():
            raise ValueError(f"field {names[i - 1]} has a wrong tag")
    return {name: rows[f"v{i}"].copy() for i, name in enumerate(names, start=1)}
