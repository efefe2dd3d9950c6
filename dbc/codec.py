"""The frame codec shared by the ECU and the simulator.

The DBC is loaded once (cantools) and bound to logical roles and fields by
the binding table (:mod:`dbc.binding`). For every message, an encoder and a decoder are
compiled once into straight-line Python (shifts and masks on one integer, an unrolled
table CRC), which is what makes them several times faster than cantools' generic
``Message.encode``/``decode``. Encoding fills the alive counter and the E2E CRC; decoding
checks length, CRC and ranges and raises a :class:`~dbc.errors.DecodeError` subclass.

Values are keyed by logical field names (``speed_mps``, ``gap_m`` …), never by signal
names: code above the codec knows roles and fields only.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from functools import lru_cache
from pathlib import Path
from typing import Any, NamedTuple

from dbc import BINDING_PATH, DBC_PATH, checksums
from dbc.binding import Binding, PartBinding, check_against, load_binding
from dbc.e2e import CRC8_TABLE, crc8_update, data_id_of
from dbc.errors import (
    BindingError,
    CodecError,
    CrcError,
    DbcError,
    DecodeError,
    DlcError,
    EncodeError,
    RangeError,
    UnknownFrameError,
)
from dbc.layout import FieldLayout, extract, layout, physical, placed_le, raw_from
from dbc.schema import ROLES
from dbc.units import UnitError, conversion

__all__ = [
    "BindingError",
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
    "RoleCodec",
    "UnknownFrameError",
    "load_codec",
    "network_paths",
]

Value = float | int


class Decoded(NamedTuple):
    """A decoded frame: its role, its field values (physical units) and its alive counter."""

    role: str
    values: dict[str, Value]
    counter: int | None


class MessageCodec:
    """Compiled encoder/decoder of one bound message (one part of a role).

    Attributes:
        role: logical role (``"radar"``); key: the role for its first message,
        ``role#i`` for its i-th further one (the key of its alive counter and E2E state);
        name: DBC message name; frame_id: CAN id; length: DLC in bytes; cycle_s: period
        (binding ``cycle_ms`` or GenMsgCycleTime, s, 0 if none); fields: logical field
        names in DBC order; checksum: its kind (:mod:`dbc.checksums`); protected: carries
        a checksum; crc_byte: index of the byte holding the checksum (None: none);
        counter_modulo: alive counter period (0: no counter); data_id: 16-bit E2E data id.
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
        self.data_id = data_id_of(self.frame_id)
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
        self.protected = self._cs is not None
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
        cs = layout(signal, "_checksum", self.length)
        self._cs = cs
        self._cs_shift = cs.le_shift(self.length)
        byte = self._cs_shift // 8
        last = self.length - 1
        need = {
            "pacc_crc8": (cs.length == 8 and self._cs_shift % 8 == 0, "one whole byte"),
            "autosar_p01": (cs.length == 8 and self._cs_shift % 8 == 0, "one whole byte"),
            "toyota": (cs.length == 8 and self._cs_shift == 8 * last, "the whole last byte"),
            "honda": (cs.length == 4 and self._cs_shift == 8 * last, "the last byte's low nibble"),
        }
        ok, where = need[self.checksum]
        if not ok:
            raise BindingError(f"{self.name}: a {self.checksum} checksum must be {where}")
        self.crc_byte = byte
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

    # -- code generation ---------------------------------------------------------------
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
        need_le = (
            generic
            or any(not f.big_endian for f in layouts)
            or (counter is not None and not counter.big_endian)
        )
        need_be = any(f.big_endian for f in layouts) or (counter is not None and counter.big_endian)
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
            d.append("        range_error(data)")
        items = ", ".join(f"{f.key!r}: {physical(f, f'r{i}')}" for i, f in enumerate(layouts))
        cnt = extract(counter) if counter else "None"
        if counter and self.counter_modulo < 1 << counter.length:  # AUTOSAR P01: 15 invalid
            d.append(f"    if {cnt} >= {self.counter_modulo}:")
            d.append(f"        raise RangeError('{self.name}: alive counter out of range')")
        d.append(f"    return Decoded(role, {{{items}}}, {cnt})")
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

    def _compile(self) -> tuple[Any, Any]:
        ns: dict[str, Any] = {
            "T": CRC8_TABLE,
            "CS": self._cs_fn,
            "Decoded": Decoded,
            "DlcError": DlcError,
            "CrcError": CrcError,
            "RangeError": RangeError,
            "EncodeError": EncodeError,
            "role": self.role,
            "range_error": self._range_error,
            "encode_error": self._encode_error,
        }
        source = "\n".join(self._decode_source() + self._encode_source()) + "\n"
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
            if f.invert:
                raw ^= 1
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


class RoleCodec:
    """One role: its messages (parts), and the values of fields no signal carries.

    Attributes:
        role: the role; parts: its message codecs, the first one first; defaults: logical
        values of the fields bound to a constant or left out (optional), which receivers
        assume; fields: every field the role gives a value (signal-bound or default).
    """

    def __init__(self, role: str, parts: tuple[MessageCodec, ...], consts: dict[str, float]):
        self.role = role
        self.parts = parts
        self.defaults: dict[str, Value] = {
            k: spec.default
            for k, spec in ROLES[role].items()
            if not any(k in p.fields for p in parts)
        }
        self.defaults.update(consts)
        self.fields: tuple[str, ...] = tuple(
            [f for p in parts for f in p.fields] + list(self.defaults)
        )

    def part_of(self, key: str) -> MessageCodec | None:
        """The message carrying field ``key`` (None: a constant or an unbound field)."""
        for p in self.parts:
            if key in p.fields:
                return p
        return None

    def bounds(self, key: str) -> tuple[float, float]:
        """Logical [min, max] of ``key``: its signal's, or (v, v) for a default ``v``."""
        part = self.part_of(key)
        if part is not None:
            return part.bounds(key)
        if key in self.defaults:
            v = float(self.defaults[key])
            return v, v
        raise KeyError(key)

    @property
    def cycle_s(self) -> float:
        """The shortest period of the role's messages, s."""
        return min(p.cycle_s for p in self.parts)


class Codec:
    """All bound messages of one vehicle network, by role and by frame id.

    ``by_role[role]`` is the role's first message; ``roles[role]`` the whole role.
    """

    def __init__(self, db: Any, binding: Binding, dbc_path: Path | None = None) -> None:
        check_against(binding, db)
        self.db = db
        self.binding = binding
        #: the DBC file the network was loaded from (None: built from a database in memory)
        self.dbc_path = dbc_path
        self.by_role: dict[str, MessageCodec] = {}
        self.roles: dict[str, RoleCodec] = {}
        self.by_id: dict[int, MessageCodec] = {}
        for rb in binding.roles.values():
            parts = []
            for i, part in enumerate(rb.parts):
                key = rb.role if i == 0 else f"{rb.role}#{i}"
                mc = MessageCodec(db.get_message_by_name(part.message), part, rb.role, key)
                if mc.cycle_s <= 0:  # receivers time out by the period, senders send by it
                    raise DbcError(
                        f"role {rb.role}: message {mc.name} has no GenMsgCycleTime "
                        "(give cycle_ms in the binding)"
                    )
                if mc.frame_id in self.by_id:
                    raise BindingError(f"message {mc.name} is bound twice")
                self.by_id[mc.frame_id] = mc
                parts.append(mc)
            self.by_role[rb.role] = parts[0]
            self.roles[rb.role] = RoleCodec(rb.role, tuple(parts), rb.consts)

    def parts(self) -> list[MessageCodec]:
        """Every bound message, role by role."""
        return [p for rc in self.roles.values() for p in rc.parts]

    def encode(self, role: str, values: Mapping[str, Any], counter: int = 0) -> bytes:
        """Payload of a one-message ``role`` with ``values``, alive ``counter`` and checksum."""
        try:
            rc = self.roles[role]
        except KeyError:
            raise EncodeError(f"no role {role!r} in the binding") from None
        if len(rc.parts) != 1:
            raise EncodeError(f"role {role} spans {len(rc.parts)} messages: encode each part")
        return rc.parts[0].encode(values, counter)

    def decode(self, frame_id: int, data: bytes | bytearray) -> Decoded:
        """Decode and check one frame; raise a :class:`DecodeError` subclass if unusable."""
        mc = self.by_id.get(frame_id)
        if mc is None:
            raise UnknownFrameError(f"unknown frame id {frame_id:#x}")
        return mc.decode(data)


def _load_db(dbc_path: Path) -> Any:
    # cantools costs ~0.3 s of start-up: only loading a DBC needs it (not `pacc ecu --help`)
    import cantools  # noqa: PLC0415

    # not strict: real networks overlap signals pacc does not use (opendbc's Toyota PCS_HUD);
    # the codec checks the signals the binding names (fit, overlap, ranges) itself
    try:
        return cantools.database.load_file(str(dbc_path), database_format="dbc", strict=False)
    except FileNotFoundError as exc:
        raise DbcError(f"DBC file not found: {dbc_path}") from exc
    except Exception as exc:  # cantools raises its own ParseError, ValueError, UnicodeError…
        raise DbcError(f"cannot load DBC {dbc_path}: {exc}") from exc


@lru_cache(maxsize=8)
def _load_codec(dbc_path: Path, binding_path: Path) -> Codec:
    binding = load_binding(binding_path)
    return Codec(_load_db(dbc_path), binding, dbc_path)


def network_paths(
    dbc_path: str | Path | None = None, binding_path: str | Path | None = None
) -> tuple[Path, Path]:
    """The (DBC, binding) files of a network, as the command line gives them.

    Neither: the packaged pacc network. A binding alone: the DBC its ``dbc`` key names,
    beside the binding file. Both: the binding must name that DBC's file. A DBC alone is
    refused: a binding written for another network would not fit it.

    Raises:
        BindingError: a DBC without a binding, or a binding that names another DBC.
    """
    if binding_path is None:
        if dbc_path is not None:
            raise BindingError(
                f"--dbc {dbc_path} needs --binding FILE: the table that maps pacc's roles to "
                "that network's messages (docs/vehicles.md)"
            )
        return DBC_PATH, BINDING_PATH
    binding_file = Path(binding_path).resolve()
    named = load_binding(binding_file).dbc
    if dbc_path is None:
        if not named:
            raise BindingError(f"{binding_path} names no dbc file: give --dbc")
        return (binding_file.parent / named).resolve(), binding_file
    dbc_file = Path(dbc_path).resolve()
    if named and Path(named).name != dbc_file.name:
        raise BindingError(f"{binding_path} binds {named}, not {dbc_file.name}")
    return dbc_file, binding_file


def load_codec(dbc_path: str | Path | None = None, binding_path: str | Path | None = None) -> Codec:
    """The codec of a DBC and binding, loaded once.

    Defaults: the packaged pacc DBC and binding; a binding alone brings the DBC it names
    (beside it). The library, unlike the command line, lets a test pair an edited pacc DBC
    with the packaged binding: :meth:`Codec` still checks that they fit.

    Raises:
        DbcError: the DBC or the binding cannot be read, parsed or matched (a
            :class:`BindingError` for the binding).
    """
    if binding_path is not None and dbc_path is None:
        dbc, binding = network_paths(None, binding_path)
        return _load_codec(dbc, binding)
    dbc = Path(dbc_path).resolve() if dbc_path else DBC_PATH
    binding = Path(binding_path).resolve() if binding_path else BINDING_PATH
    return _load_codec(dbc, binding)
