"""One bound message's encoder and decoder, generated once as straight-line Python (shifts and
masks on one integer, an unrolled table CRC: several times cantools' speed). Encoding fills
the alive counter and checksum; decoding checks length, checksum and ranges, raising a
:class:`~dbc.errors.DecodeError` subclass. ``tools/compile.py`` may compile the same source
ahead (mypyc: ``dbc._compiled_codecs``).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any, NamedTuple

from dbc import checksums
from dbc.binding import PartBinding
from dbc.e2e import CRC8_TABLE, crc8_update
from dbc.errors import BindingError, CrcError, DbcError, DlcError, EncodeError, RangeError
from dbc.layout import FieldLayout, extract, layout, physical, placed_le, raw_from
from dbc.units import UnitError, conversion

Value = float | int


def _compiled_factories() -> dict[str, Any]:
    """Source text -> factory of its compiled (encode, decode) pair from
    ``dbc._compiled_codecs`` (empty in the pure-Python install)."""
    try:
        module = importlib.import_module("dbc._compiled_codecs")
    except ModuleNotFoundError as exc:
        if exc.name != "dbc._compiled_codecs":  # the module is there but cannot load
            raise
        return {}
    return dict(module.FACTORIES)


_COMPILED = _compiled_factories()


def compiled_codecs() -> int:
    """How many message codecs this process has compiled ahead (0: the pure install)."""
    return len(_COMPILED)


class Decoded(NamedTuple):
    """A decoded frame: its role, its field values (physical units) and its alive counter."""

    role: str
    values: dict[str, Value]
    counter: int | None


class MessageCodec:
    """Compiled encoder/decoder of one bound message (one part of a role).

    Attributes: ``role``; ``key`` (the role, ``role#i`` for its i-th further message: its
    counter's and E2E state's key); ``name``, ``frame_id``, ``length`` (bytes); ``cycle_s``
    (s, 0: none); ``fields`` (DBC order); ``checksum`` kind; ``crc_byte`` (None: none);
    ``counter_modulo`` (0: no counter); ``data_id`` (16-bit E2E data id).
    """

    def __init__(self, message: Any, part: PartBinding, role: str, key: str | None = None) -> None:
        self.role = role
        self.key = key or role
        self.name: str = message.name
        self.frame_id: int = message.frame_id
        self.is_extended: bool = bool(message.is_extended_frame)
        self.length: int = message.length
        cycle_ms = part.cycle_ms if part.cycle_ms is not None else (message.cycle_time or 0)
        self.cycle_s: float = cycle_ms / 1000.0
        self.data_id = self.frame_id & 0xFFFF  # the 16-bit E2E data id
        by_signal = {fb.signal: fb for fb in part.fields.values()}
        layouts = []
        for s in message.signals:
            fb = by_signal.get(s.name)
            if fb is None:
                continue
            try:
                unit = fb.unit if fb.unit is not None else s.unit
                factor = conversion(fb.key, unit) * fb.scale
            except UnitError as exc:
                raise BindingError(f"role {role}: {self.name}.{s.name}: {exc}") from None
            layouts.append(
                layout(s, fb.key, self.length, factor=factor, invert=fb.invert, override=fb.range)
            )
        self.layouts: tuple[FieldLayout, ...] = tuple(layouts)
        self.fields: tuple[str, ...] = tuple(f.key for f in self.layouts)
        self.checksum = part.checksum
        self.crc_byte: int | None = None
        self._cs: FieldLayout | None = None
        self._cs_shift = 0
        self._cs_fn: checksums.Checksum | None = None
        if part.checksum_signal is not None:
            self._bind_checksum(message.get_signal_by_name(part.checksum_signal))
        # not ``self._cs is not None``: mypy narrows it to None, which mypyc would enforce
        self.protected = part.checksum_signal is not None
        self._counter: FieldLayout | None = None
        self.counter_modulo = 0
        if part.counter is not None:
            self._bind_counter(message.get_signal_by_name(part.counter))
        self._const_le = 0
        const_layouts = [self._bind_constant(message, n, v) for n, v in part.constants.items()]
        self._check_overlaps([*self.layouts, *const_layouts])
        self.encode: Callable[[Mapping[str, Any], int], bytes]
        self.decode: Callable[[bytes | bytearray], Decoded]
        self.encode, self.decode = self._compile()

    def _bind_counter(self, signal: Any) -> None:
        counter = layout(signal, "_counter", self.length)
        if counter.signed or not 1 <= counter.length <= 8:
            raise BindingError(f"{self.name}: counter {signal.name} must be 1-8 bit unsigned")
        self._counter = counter
        self.counter_modulo = checksums.COUNTER_MODULO.get(self.checksum, 1 << counter.length)
        if self.counter_modulo > 1 << counter.length:
            raise BindingError(f"{self.name}: counter {signal.name} is too narrow")

    def _bind_constant(self, message: Any, name: str, value: float) -> FieldLayout:
        """Fix signal ``name`` at ``value`` (physical) in every frame encoded."""
        cl = layout(message.get_signal_by_name(name), name, self.length)
        raw = round((value - cl.offset) / cl.scale)
        if not cl.raw_min <= raw <= cl.raw_max:
            raise BindingError(f"{self.name}: constant {name} = {value:g} outside its range")
        self._const_le |= placed_le(cl, raw, self.length)
        return cl

    def _bind_checksum(self, signal: Any) -> None:
        self._cs = cs = layout(signal, "_checksum", self.length)
        self._cs_shift = cs.le_shift(self.length)
        last = self.length - 1
        need = {
            "toyota": (cs.length == 8 and self._cs_shift == 8 * last, "the whole last byte"),
            "honda": (cs.length == 4 and self._cs_shift == 8 * last, "the last byte's low nibble"),
        }  # a table CRC: one whole byte
        whole = (cs.length == 8 and self._cs_shift % 8 == 0, "one whole byte")
        ok, where = need.get(self.checksum, whole)
        if not ok:
            raise BindingError(f"{self.name}: a {self.checksum} checksum must be {where}")
        self.crc_byte = byte = self._cs_shift // 8
        if self.checksum not in checksums.TABLE_CRCS:  # table CRCs are generated inline
            self._cs_fn = checksums.make(self.checksum, self.frame_id, self.length, byte)

    def _check_overlaps(self, layouts: list[FieldLayout]) -> None:
        used: dict[int, str] = {}
        extra = [x for x in (self._cs, self._counter) if x is not None]
        for f in [*layouts, *extra]:
            for bit in f.le_bits(self.length):
                if bit in used:
                    raise DbcError(f"{self.name}: bound signals {used[bit]} and {f.key} overlap")
                used[bit] = f.key

    def _crc_lines(self, buf: str, indent: str) -> list[str]:
        """Unrolled CRC over the data id (precomputed) and every byte but the CRC byte."""
        assert self.crc_byte is not None
        init, xorout = checksums.TABLE_CRCS[self.checksum]
        start = crc8_update(init, bytes((self.data_id & 0xFF, self.data_id >> 8)))
        lines = [f"{indent}c = {start:#x}"]
        lines += [
            f"{indent}c = T[c ^ {buf}[{i}]]" for i in range(self.length) if i != self.crc_byte
        ]
        if xorout:
            lines.append(f"{indent}c ^= {xorout:#x}")
        return lines

    def _decode_source(self) -> list[str]:
        layouts, counter, n = list(self.layouts), self._counter, self.length
        generic = self._cs is not None and self.checksum not in checksums.TABLE_CRCS
        placed = [*layouts, *([counter] if counter else [])]
        need_le = generic or any(not f.big_endian for f in placed)
        need_be = any(f.big_endian for f in placed)
        d = [
            "def decode(data):",
            f"    if len(data) != {n}:",
            f"        raise DlcError('{self.name}: DLC %d, expected {n}' % len(data))",
        ]
        if self.checksum in checksums.TABLE_CRCS:
            d += self._crc_lines("data", "    ")
            d += [
                f"    if c != data[{self.crc_byte}]:",
                f"        raise CrcError('{self.name}: CRC mismatch')",
            ]
        if need_le:
            d.append("    n_le = int.from_bytes(data, 'little')")
        if generic:
            assert self._cs is not None
            s, m = self._cs_shift, self._cs.mask
            d += [
                f"    if (n_le >> {s}) & {m:#x} != CS((n_le & {~(m << s):#x}).to_bytes({n}, "
                "'little')):",
                f"        raise CrcError('{self.name}: {self.checksum} checksum mismatch')",
            ]
        if need_be:
            d.append("    n_be = int.from_bytes(data, 'big')")
        for i, f in enumerate(layouts):
            d.append(f"    r{i} = {extract(f)}")
        # on decode, bounds that the bit width already enforces need no test
        narrowing = [
            f"{f.raw_min} <= r{i} <= {f.raw_max}" for i, f in enumerate(layouts) if f.narrows
        ]
        if narrowing:
            d.append(f"    if not ({' and '.join(narrowing)}):")
            d.append(f"        range_error({', '.join(f'r{i}' for i in range(len(layouts)))})")
        items = ", ".join(f"{f.key!r}: {physical(f, f'r{i}')}" for i, f in enumerate(layouts))
        cnt = extract(counter) if counter else "None"
        if counter and self.counter_modulo < 1 << counter.length:  # AUTOSAR P01: 15 invalid
            d.append(f"    if {cnt} >= {self.counter_modulo}:")
            d.append(f"        raise RangeError('{self.name}: alive counter out of range')")
        # tuple.__new__ of the NamedTuple: what Decoded(...) gives, without its Python __new__
        d.append(f"    return new_tuple(Decoded, (role, {{{items}}}, {cnt}))")
        return d

    def _encode_source(self) -> list[str]:
        layouts, counter, n = list(self.layouts), self._counter, self.length
        e = ["def encode(values, counter=0):", "    try:"]
        e += [f"        r{i} = {raw_from(f, f'values[{f.key!r}]')}" for i, f in enumerate(layouts)]
        e += [
            "    except (KeyError, TypeError, ValueError, OverflowError) as exc:",
            "        encode_error(values, exc)",
        ]
        checks = [f"{f.raw_min} <= r{i} <= {f.raw_max}" for i, f in enumerate(layouts)]
        if checks:
            e.append(f"    if not ({' and '.join(checks)}):")
            e.append("        encode_error(values, None)")

        def term(i: int, f: FieldLayout) -> str:
            return f"((r{i} & {f.mask:#x}) << {f.shift})" if f.signed else f"(r{i} << {f.shift})"

        le_terms = [term(i, f) for i, f in enumerate(layouts) if not f.big_endian]
        be_terms = [term(i, f) for i, f in enumerate(layouts) if f.big_endian]
        if counter:
            cterm = f"((counter & {counter.mask:#x}) << {counter.shift})"
            (be_terms if counter.big_endian else le_terms).append(cterm)
        if self._const_le:
            le_terms.append(f"{self._const_le:#x}")
        e.append(f"    n_le = {' | '.join(le_terms) or '0'}")
        if be_terms:
            e.append(
                f"    n_le |= int.from_bytes(({' | '.join(be_terms)}).to_bytes({n}, 'big'), "
                "'little')"
            )
        if self.checksum in checksums.TABLE_CRCS:
            e.append(f"    b = n_le.to_bytes({n}, 'little')")
            e += self._crc_lines("b", "    ")
            e.append(f"    return (n_le | (c << {8 * self.crc_byte})).to_bytes({n}, 'little')")  # type: ignore[operator]
        elif self._cs is not None:
            e.append(
                f"    return (n_le | (CS(n_le.to_bytes({n}, 'little')) << {self._cs_shift}))"
                f".to_bytes({n}, 'little')"
            )
        else:
            e.append(f"    return n_le.to_bytes({n}, 'little')")
        return e

    def source(self) -> str:
        """The Python source of this message's ``decode`` and ``encode`` functions."""
        return "\n".join(self._decode_source() + self._encode_source()) + "\n"

    def namespace(self) -> dict[str, Any]:
        """The names the generated source reads (a fresh dict)."""
        return {
            "T": CRC8_TABLE,
            "CS": self._cs_fn,
            "Decoded": Decoded,
            "new_tuple": tuple.__new__,
            "DlcError": DlcError,
            "CrcError": CrcError,
            "RangeError": RangeError,
            "EncodeError": EncodeError,
            "role": self.role,
            "range_error": self._range_error,
            "encode_error": self._encode_error,
        }

    def _compile(self) -> tuple[Any, Any]:
        ns = self.namespace()
        source = self.source()
        factory = _COMPILED.get(source)
        if factory is not None:  # the same source, compiled ahead by tools/compile.py (mypyc)
            encode, decode = factory(ns)
            return encode, decode
        exec(compile(source, f"<codec {self.name}>", "exec"), ns)  # noqa: S102 - generated above
        return ns["encode"], ns["decode"]

    def _range_error(self, *raws: int) -> None:
        """The decode error naming the fields whose raw values (``raws``) are out of range."""
        bad = [
            f"{f.key}={r * f.scale + f.offset:g}"
            for f, r in zip(self.layouts, raws, strict=True)
            if not f.raw_min <= r <= f.raw_max
        ]
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
            if f.invert:
                raw ^= 1
            if not f.raw_min <= raw <= f.raw_max:
                lo, hi = self.bounds(f.key)
                bad.append(f"{f.key}={value!r} outside [{lo:g}, {hi:g}]")
        raise EncodeError(f"{self.name}: {'; '.join(bad) or exc}")

    def bounds(self, key: str) -> tuple[float, float]:
        """Logical [min, max] of field ``key`` (what encode accepts)."""
        for f in self.layouts:
            if f.key == key:
                if f.invert:
                    return 0.0, 1.0
                return f.raw_min * f.scale + f.offset, f.raw_max * f.scale + f.offset
        raise KeyError(key)
