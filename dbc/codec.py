"""The frame codec shared by the ECU and the simulator.

The DBC is loaded once (cantools, ``strict=True``) and bound to logical roles and fields by
the binding table (:mod:`dbc.binding`). For every message, an encoder and a decoder are
compiled once into straight-line Python (shifts and masks on one integer, an unrolled
table CRC), which is what makes them several times faster than cantools' generic
``Message.encode``/``decode``. Encoding fills the alive counter and the E2E CRC; decoding
checks length, CRC and ranges and raises a :class:`~dbc.errors.DecodeError` subclass.

Values are keyed by logical field names (``speed_mps``, ``gap_m`` …), never by signal
names: code above the codec knows roles and fields only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, NamedTuple

from dbc import BINDING_PATH, DBC_PATH
from dbc.binding import Binding, RoleBinding, check_against, load_binding
from dbc.e2e import CRC8_INIT, CRC8_TABLE, CRC8_XOROUT, crc8_update, data_id_of
from dbc.errors import (
    CodecError,
    CrcError,
    DbcError,
    DecodeError,
    DlcError,
    EncodeError,
    RangeError,
    UnknownFrameError,
)

__all__ = [
    "Codec",
    "CodecError",
    "CrcError",
    "DbcError",
    "DecodeError",
    "Decoded",
    "DlcError",
    "EncodeError",
    "MessageCodec",
    "RangeError",
    "UnknownFrameError",
    "load_codec",
]

Value = float | int


class Decoded(NamedTuple):
    """A decoded frame: its role, its field values (physical units) and its alive counter."""

    role: str
    values: dict[str, Value]
    counter: int | None


@dataclass(frozen=True)
class FieldLayout:
    """Where one signal sits in the payload and how raw maps to physical.

    ``shift`` is the position of the signal's least significant bit in the payload read as
    one little-endian (Intel) or big-endian (Motorola) integer, per ``big_endian``.
    """

    key: str
    shift: int
    length: int
    signed: bool
    scale: float
    offset: float
    raw_min: int
    raw_max: int
    big_endian: bool

    @property
    def mask(self) -> int:
        return (1 << self.length) - 1

    @property
    def narrows(self) -> bool:
        """True when the DBC range is narrower than what the bits can hold."""
        lo = -(1 << (self.length - 1)) if self.signed else 0
        hi = (1 << (self.length - 1)) - 1 if self.signed else (1 << self.length) - 1
        return self.raw_min > lo or self.raw_max < hi

    @property
    def integral(self) -> bool:
        """True when raw and physical coincide (decode yields an int)."""
        return self.scale == 1 and self.offset == 0


def _raw_bounds(signal: Any) -> tuple[int, int]:
    """Raw-value bounds of a cantools signal: its DBC [min, max] intersected with its bits."""
    length = signal.length
    if signal.is_signed:
        lo, hi = -(1 << (length - 1)), (1 << (length - 1)) - 1
    else:
        lo, hi = 0, (1 << length) - 1
    scale, offset = float(signal.scale), float(signal.offset)
    if scale <= 0:
        raise DbcError(f"signal {signal.name}: only positive scales are supported")
    if signal.minimum is not None:
        lo = max(lo, math.ceil(round((float(signal.minimum) - offset) / scale, 6)))
    if signal.maximum is not None:
        hi = min(hi, math.floor(round((float(signal.maximum) - offset) / scale, 6)))
    if lo > hi:
        raise DbcError(f"signal {signal.name}: empty range")
    return lo, hi


def _layout(signal: Any, key: str, length_bytes: int) -> FieldLayout:
    if signal.is_float:
        raise DbcError(f"signal {signal.name}: IEEE float signals are not supported")
    big = signal.byte_order == "big_endian"
    if big:
        msb = (length_bytes - 1 - signal.start // 8) * 8 + signal.start % 8
        shift = msb - signal.length + 1
    else:
        shift = signal.start
    if shift < 0 or shift + signal.length > 8 * length_bytes:
        raise DbcError(f"signal {signal.name}: does not fit in {length_bytes} bytes")
    raw_min, raw_max = _raw_bounds(signal)
    return FieldLayout(
        key=key,
        shift=shift,
        length=signal.length,
        signed=bool(signal.is_signed),
        scale=float(signal.scale),
        offset=float(signal.offset),
        raw_min=raw_min,
        raw_max=raw_max,
        big_endian=big,
    )


def _extract(f: FieldLayout) -> str:
    """Source of an expression giving the raw value of ``f`` from ``n_le``/``n_be``."""
    src = f"(({'n_be' if f.big_endian else 'n_le'} >> {f.shift}) & {f.mask:#x})"
    if f.signed:
        sign = 1 << (f.length - 1)
        src = f"(({src} ^ {sign:#x}) - {sign:#x})"
    return src


def _physical(f: FieldLayout, raw: str) -> str:
    if f.integral:
        return raw
    src = f"{raw} * {f.scale!r}"
    return f"({src} + {f.offset!r})" if f.offset else src


def _raw_from(f: FieldLayout, value: str) -> str:
    if f.integral:
        return f"round({value})"
    inv = 1.0 / f.scale
    body = f"({value} - {f.offset!r})" if f.offset else value
    # multiply by the inverse when it is exact (0.01 -> 100.0), divide otherwise
    return f"round({body} * {inv!r})" if inv == round(inv) else f"round({body} / {f.scale!r})"


class MessageCodec:
    """Compiled encoder/decoder of one bound message.

    Attributes:
        role: logical role (``"radar"``); name: DBC message name; frame_id: CAN id;
        length: DLC in bytes; cycle_s: period from GenMsgCycleTime (s, 0 if none);
        fields: logical field names in DBC order; protected: carries CRC and counter;
        crc_byte: index of the E2E CRC byte in the payload, from the binding's CRC signal
        (None: unprotected); data_id: 16-bit E2E data id.
    """

    def __init__(self, message: Any, role: RoleBinding) -> None:
        self.role = role.role
        self.name: str = message.name
        self.frame_id: int = message.frame_id
        self.is_extended: bool = bool(message.is_extended_frame)
        self.length: int = message.length
        self.cycle_s: float = (message.cycle_time or 0) / 1000.0
        self.data_id = data_id_of(self.frame_id)
        by_signal = {signal: key for key, signal in role.fields.items()}
        self.layouts: tuple[FieldLayout, ...] = tuple(
            _layout(s, by_signal[s.name], self.length)
            for s in message.signals
            if s.name in by_signal
        )
        self.fields: tuple[str, ...] = tuple(f.key for f in self.layouts)
        self.protected = role.protected
        self.crc_byte: int | None = None
        self._counter: FieldLayout | None = None
        if role.protected:
            crc = _layout(message.get_signal_by_name(role.crc), "_crc", self.length)
            byte = crc.shift // 8
            self.crc_byte = self.length - 1 - byte if crc.big_endian else byte
            counter_signal = message.get_signal_by_name(role.counter)
            self._counter = _layout(counter_signal, "_counter", self.length)
        self.encode: Callable[[Mapping[str, Any], int], bytes]
        self.decode: Callable[[bytes | bytearray], Decoded]
        self.encode, self.decode = self._compile()

    # -- code generation ---------------------------------------------------------------
    def _crc_lines(self, buf: str, indent: str) -> list[str]:
        """Unrolled CRC over the data id (precomputed) and every byte but the CRC byte."""
        assert self.crc_byte is not None
        start = crc8_update(CRC8_INIT, bytes((self.data_id & 0xFF, self.data_id >> 8)))
        lines = [f"{indent}c = {start:#x}"]
        lines += [
            f"{indent}c = T[c ^ {buf}[{i}]]" for i in range(self.length) if i != self.crc_byte
        ]
        lines.append(f"{indent}c ^= {CRC8_XOROUT:#x}")
        return lines

    def _compile(self) -> tuple[Any, Any]:
        layouts = list(self.layouts)
        counter = self._counter
        need_le = any(not f.big_endian for f in layouts) or (counter and not counter.big_endian)
        need_be = any(f.big_endian for f in layouts) or (counter and counter.big_endian)
        n = self.length
        ns: dict[str, Any] = {
            "T": CRC8_TABLE,
            "Decoded": Decoded,
            "DlcError": DlcError,
            "CrcError": CrcError,
            "EncodeError": EncodeError,
            "role": self.role,
            "range_error": self._range_error,
            "encode_error": self._encode_error,
        }
        # decoder
        d = [
            "def decode(data):",
            f"    if len(data) != {n}:",
            f"        raise DlcError('{self.name}: DLC %d, expected {n}' % len(data))",
        ]
        if self.crc_byte is not None:
            d += self._crc_lines("data", "    ")
            d += [
                f"    if c != data[{self.crc_byte}]:",
                f"        raise CrcError('{self.name}: CRC mismatch')",
            ]
        if need_le:
            d.append("    n_le = int.from_bytes(data, 'little')")
        if need_be:
            d.append("    n_be = int.from_bytes(data, 'big')")
        for i, f in enumerate(layouts):
            d.append(f"    r{i} = {_extract(f)}")
        checks = [f"{f.raw_min} <= r{i} <= {f.raw_max}" for i, f in enumerate(layouts)]
        # on decode, bounds that the bit width already enforces need no test
        narrowing = [c for c, f in zip(checks, layouts, strict=True) if f.narrows]
        if narrowing:
            d.append(f"    if not ({' and '.join(narrowing)}):")
            d.append("        range_error(data)")
        items = ", ".join(f"{f.key!r}: {_physical(f, f'r{i}')}" for i, f in enumerate(layouts))
        cnt = _extract(counter) if counter else "None"
        d.append(f"    return Decoded(role, {{{items}}}, {cnt})")
        # encoder
        e = ["def encode(values, counter=0):", "    try:"]
        e += [f"        r{i} = {_raw_from(f, f'values[{f.key!r}]')}" for i, f in enumerate(layouts)]
        e += [
            "    except (KeyError, TypeError, ValueError, OverflowError) as exc:",
            "        encode_error(values, exc)",
        ]
        if checks:
            e.append(f"    if not ({' and '.join(checks)}):")
            e.append("        encode_error(values, None)")
        le_terms = [
            f"((r{i} & {f.mask:#x}) << {f.shift})" if f.signed else f"(r{i} << {f.shift})"
            for i, f in enumerate(layouts)
            if not f.big_endian
        ]
        be_terms = [
            f"((r{i} & {f.mask:#x}) << {f.shift})" if f.signed else f"(r{i} << {f.shift})"
            for i, f in enumerate(layouts)
            if f.big_endian
        ]
        if counter:
            term = f"((counter & 0xF) << {counter.shift})"
            (be_terms if counter.big_endian else le_terms).append(term)
        e.append(f"    n_le = {' | '.join(le_terms) or '0'}")
        if be_terms:
            e.append(
                f"    n_le |= int.from_bytes(({' | '.join(be_terms)}).to_bytes({n}, 'big'), "
                "'little')"
            )
        if self.crc_byte is not None:
            e.append(f"    b = n_le.to_bytes({n}, 'little')")
            e += self._crc_lines("b", "    ")
            e.append(f"    return (n_le | (c << {8 * self.crc_byte})).to_bytes({n}, 'little')")
        else:
            e.append(f"    return n_le.to_bytes({n}, 'little')")
        source = "\n".join(d + e) + "\n"
        exec(compile(source, f"<codec {self.name}>", "exec"), ns)  # noqa: S102 - generated above
        return ns["encode"], ns["decode"]

    # -- slow paths (errors only) ----------------------------------------------------------
    def _range_error(self, data: bytes | bytearray) -> None:
        n_le, n_be = int.from_bytes(data, "little"), int.from_bytes(data, "big")
        bad = []
        for f in self.layouts:
            raw = ((n_be if f.big_endian else n_le) >> f.shift) & f.mask
            if f.signed and raw >> (f.length - 1):
                raw -= 1 << f.length
            if not f.raw_min <= raw <= f.raw_max:
                bad.append(f"{f.key}={raw * f.scale + f.offset:g}")
        raise RangeError(f"{self.name}: out of DBC range: {', '.join(bad)}")

    def _encode_error(self, values: Mapping[str, Any], exc: BaseException | None) -> None:
        if isinstance(exc, KeyError):
            raise EncodeError(f"{self.name}: missing field {exc.args[0]!r}") from None
        bad = []
        for f in self.layouts:
            value = values.get(f.key)
            try:
                raw = round((float(value) - f.offset) / f.scale)  # type: ignore[arg-type]
            except (TypeError, ValueError, OverflowError):
                bad.append(f"{f.key}={value!r} is not a finite number")
                continue
            if not f.raw_min <= raw <= f.raw_max:
                lo = f.raw_min * f.scale + f.offset
                hi = f.raw_max * f.scale + f.offset
                bad.append(f"{f.key}={value!r} outside [{lo:g}, {hi:g}]")
        raise EncodeError(f"{self.name}: {'; '.join(bad) or exc}")

    def bounds(self, key: str) -> tuple[float, float]:
        """Physical [min, max] of field ``key`` (what encode accepts)."""
        for f in self.layouts:
            if f.key == key:
                return f.raw_min * f.scale + f.offset, f.raw_max * f.scale + f.offset
        raise KeyError(key)


class Codec:
    """All bound messages of one vehicle network, by role and by frame id."""

    def __init__(self, db: Any, binding: Binding) -> None:
        check_against(binding, db)
        self.db = db
        self.binding = binding
        self.by_role: dict[str, MessageCodec] = {}
        self.by_id: dict[int, MessageCodec] = {}
        for role in binding.roles.values():
            mc = MessageCodec(db.get_message_by_name(role.message), role)
            if mc.cycle_s <= 0:  # receivers time out by the period, senders send by it
                raise DbcError(f"role {role.role}: message {mc.name} has no GenMsgCycleTime")
            self.by_role[role.role] = mc
            self.by_id[mc.frame_id] = mc

    def encode(self, role: str, values: Mapping[str, Any], counter: int = 0) -> bytes:
        """Payload of ``role`` with ``values`` (physical units), alive ``counter`` and CRC."""
        try:
            mc = self.by_role[role]
        except KeyError:
            raise EncodeError(f"no role {role!r} in the binding") from None
        return mc.encode(values, counter)

    def decode(self, frame_id: int, data: bytes | bytearray) -> Decoded:
        """Decode and check one frame; raise a :class:`DecodeError` subclass if unusable."""
        mc = self.by_id.get(frame_id)
        if mc is None:
            raise UnknownFrameError(f"unknown frame id {frame_id:#x}")
        return mc.decode(data)


def _load_db(dbc_path: Path) -> Any:
    # cantools costs ~0.3 s of start-up: only loading a DBC needs it (not `pacc ecu --help`)
    import cantools  # noqa: PLC0415

    try:
        return cantools.database.load_file(str(dbc_path), database_format="dbc", strict=True)
    except FileNotFoundError as exc:
        raise DbcError(f"DBC file not found: {dbc_path}") from exc
    except Exception as exc:  # cantools raises its own ParseError, ValueError, UnicodeError…
        raise DbcError(f"cannot load DBC {dbc_path}: {exc}") from exc


@lru_cache(maxsize=8)
def _load_codec(dbc_path: Path, binding_path: Path) -> Codec:
    binding = load_binding(binding_path)
    return Codec(_load_db(dbc_path), binding)


def load_codec(dbc_path: str | Path | None = None, binding_path: str | Path | None = None) -> Codec:
    """The codec of a DBC and binding (defaults: the packaged pacc network), loaded once.

    Raises:
        DbcError: the DBC or the binding cannot be read, parsed or matched.
    """
    dbc = Path(dbc_path).resolve() if dbc_path else DBC_PATH
    binding = Path(binding_path).resolve() if binding_path else BINDING_PATH
    return _load_codec(dbc, binding)
