"""Where a bound signal sits in a payload and how its raw value maps to the logical value:
one :class:`FieldLayout` per bound signal (unit conversion folded into scale and offset, the
usable raw range the DBC's or the binding's inside what the bits hold), and the source
snippets the codec's generated encoders and decoders are made of.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from dbc.errors import BindingError, DbcError


@dataclass(frozen=True)
class FieldLayout:
    """One signal: ``shift`` is its LSB's position in the payload read as one little- or
    big-endian integer (``big_endian``); logical = raw * scale + offset; ``invert`` flips a
    1-bit flag first."""

    key: str
    shift: int
    length: int
    signed: bool
    scale: float
    offset: float
    raw_min: int
    raw_max: int
    big_endian: bool
    invert: bool = False

    @property
    def mask(self) -> int:
        return (1 << self.length) - 1

    @property
    def narrows(self) -> bool:
        """True when the usable range is narrower than what the bits can hold."""
        lo, hi = bit_bounds(self.length, self.signed)
        return self.raw_min > lo or self.raw_max < hi

    @property
    def integral(self) -> bool:
        """True when raw and logical coincide (decode yields an int)."""
        return self.scale == 1 and self.offset == 0

    def le_bits(self, length_bytes: int) -> set[int]:
        """The bit positions of the signal in the payload read as a little-endian integer."""
        if not self.big_endian:
            return set(range(self.shift, self.shift + self.length))
        return {
            (length_bytes - 1 - p // 8) * 8 + p % 8
            for p in range(self.shift, self.shift + self.length)
        }

    def le_shift(self, length_bytes: int) -> int:
        """The little-endian position of a signal within one byte (else DbcError)."""
        if self.shift % 8 + self.length > 8:
            raise DbcError(f"{self.key}: must lie within one byte")
        return min(self.le_bits(length_bytes))


def bit_bounds(length: int, signed: bool) -> tuple[int, int]:
    """Raw range that ``length`` bits hold."""
    if signed:
        return -(1 << (length - 1)), (1 << (length - 1)) - 1
    return 0, (1 << length) - 1


def placement(signal: Any, length_bytes: int) -> tuple[int, bool]:
    """(shift, big-endian) of cantools ``signal``'s LSB in a ``length_bytes`` payload read as
    one integer of the signal's byte order."""
    if signal.byte_order != "big_endian":
        return signal.start, False
    return (length_bytes - 1 - signal.start // 8) * 8 + signal.start % 8 - signal.length + 1, True


def _raw_range(signal: Any, factor: float, override: tuple[float, float] | None) -> tuple[int, int]:
    """Usable raw range: ``override`` (logical units) or the DBC's [min, max] ([0|0]: none),
    within the bits."""
    lo, hi = bit_bounds(signal.length, bool(signal.is_signed))
    scale, offset = float(signal.scale), float(signal.offset)
    pmin: float | None
    pmax: float | None
    if override is not None:
        pmin, pmax = override[0] / factor, override[1] / factor
    else:
        pmin, pmax = signal.minimum, signal.maximum
        if pmin == 0 and pmax == 0:
            pmin = pmax = None
    if pmin is not None:
        lo = max(lo, math.ceil(round((float(pmin) - offset) / scale, 6)))
    if pmax is not None:
        hi = min(hi, math.floor(round((float(pmax) - offset) / scale, 6)))
    if lo > hi:
        raise DbcError(f"signal {signal.name}: empty range")
    return lo, hi


def layout(
    signal: Any,
    key: str,
    length_bytes: int,
    *,
    factor: float = 1.0,
    invert: bool = False,
    override: tuple[float, float] | None = None,
) -> FieldLayout:
    """The layout of cantools ``signal`` bound to ``key``; ``factor`` converts its unit to
    the field's. DbcError: a float or non-positive-scale signal, or one outside the payload;
    BindingError: ``invert`` on anything but a 1-bit unsigned signal."""
    if signal.is_float:
        raise DbcError(f"signal {signal.name}: IEEE float signals are not supported")
    if float(signal.scale) <= 0:
        raise DbcError(f"signal {signal.name}: only positive scales are supported")
    if invert and (signal.length != 1 or signal.is_signed):
        raise BindingError(f"signal {signal.name}: invert needs a 1-bit unsigned signal")
    shift, big = placement(signal, length_bytes)
    if shift < 0 or shift + signal.length > 8 * length_bytes:
        raise DbcError(f"signal {signal.name}: does not fit in {length_bytes} bytes")
    raw_min, raw_max = _raw_range(signal, factor, override)
    return FieldLayout(
        key=key,
        shift=shift,
        length=signal.length,
        signed=bool(signal.is_signed),
        scale=float(signal.scale) * factor,
        offset=float(signal.offset) * factor,
        raw_min=raw_min,
        raw_max=raw_max,
        big_endian=big,
        invert=invert,
    )


def extract(f: FieldLayout) -> str:
    """Source of an expression giving the raw value of ``f`` from ``n_le``/``n_be``."""
    src = f"(({'n_be' if f.big_endian else 'n_le'} >> {f.shift}) & {f.mask:#x})"
    if f.signed:
        sign = 1 << (f.length - 1)
        src = f"(({src} ^ {sign:#x}) - {sign:#x})"
    if f.invert:
        src = f"({src} ^ 1)"
    return src


def physical(f: FieldLayout, raw: str) -> str:
    """Source of the logical value of raw expression ``raw``."""
    if f.integral:
        return raw
    src = f"{raw} * {f.scale!r}"
    return f"({src} + {f.offset!r})" if f.offset else src


def raw_from(f: FieldLayout, value: str) -> str:
    """Source of the raw value of logical expression ``value``."""
    if f.integral:
        src = f"round({value})"
    else:
        inv = 1.0 / f.scale
        body = f"({value} - {f.offset!r})" if f.offset else value
        # multiply by the inverse when it is exact (0.01 -> 100.0), divide otherwise
        src = f"round({body} * {inv!r})" if inv == round(inv) else f"round({body} / {f.scale!r})"
    return f"({src} ^ 1)" if f.invert else src


def placed_le(f: FieldLayout, raw: int, length_bytes: int) -> int:
    """Raw value ``raw`` of ``f`` placed in a payload read as a little-endian integer."""
    bits = (raw & f.mask) << f.shift
    if not f.big_endian:
        return bits
    return int.from_bytes(bits.to_bytes(length_bytes, "big"), "little")
