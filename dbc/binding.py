"""The binding table (TOML): pacc's logical roles and fields → a vehicle's messages and signals.

Driving another vehicle means writing a table, not code (docs/vehicles.md): a role spans one
or more messages (``[[roles.ego]]``); a field is a signal name, a table ``{ signal, unit,
scale, invert, range }`` or ``{ const = value }``; per message ``constants``, ``unused``,
``checksum`` with ``checksum_signal``, ``counter`` and ``cycle_ms``. A version 1 ``crc`` key
means ``checksum = "pacc_crc8"``. Loading checks the table against :mod:`dbc.schema`:
:class:`BindingError` at start, never a KeyError in the control loop.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

from dbc import DATA_DIR
from dbc.checksums import KINDS
from dbc.errors import BindingError
from dbc.schema import OPTIONAL_ROLES, REQUIRED_ROLES, ROLES


@dataclass(frozen=True)
class FieldBinding:
    """One field bound to one signal: ``unit`` (None: the DBC's), ``invert`` (a 1-bit flag
    of opposite sense), ``range`` (usable [min, max] in the field's unit; None: the DBC's),
    ``scale`` (a further factor > 0 after the unit conversion)."""

    key: str
    signal: str
    unit: str | None = None
    invert: bool = False
    range: tuple[float, float] | None = None
    scale: float = 1.0


@dataclass(frozen=True)
class PartBinding:
    """One message of a role: its bound fields, E2E signals, constants and period."""

    message: str
    fields: dict[str, FieldBinding]
    checksum: str = "none"
    checksum_signal: str | None = None
    counter: str | None = None
    constants: dict[str, float] = field(default_factory=dict)
    unused: tuple[str, ...] = ()
    cycle_ms: float | None = None

    def signals(self) -> list[str]:
        """Every signal this part names (fields, checksum, counter, constants, unused)."""
        named = [f.signal for f in self.fields.values()] + list(self.constants)
        named += [s for s in (self.checksum_signal, self.counter) if s]
        return named + list(self.unused)


@dataclass(frozen=True)
class RoleBinding:
    """One role: its messages (parts) and the fields held constant (``{ const = v }``)."""

    role: str
    parts: tuple[PartBinding, ...]
    consts: dict[str, float] = field(default_factory=dict)

    def bound(self) -> set[str]:
        """Every field this role gives a value: signal-bound or constant."""
        return set(self.consts).union(*(part.fields for part in self.parts))


@dataclass(frozen=True)
class Binding:
    """A whole vehicle binding: the DBC file it belongs to and its roles."""

    dbc: str
    roles: dict[str, RoleBinding]
    path: Path | None = None


def _num(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise BindingError(f"{where} must be a finite number")
    return float(value)


def _range(rng: Any, where: str) -> tuple[float, float]:
    if not (isinstance(rng, list) and len(rng) == 2):
        raise BindingError(f"{where} must be [min, max]")
    lo, hi = (_num(v, where) for v in rng)
    if lo > hi:
        raise BindingError(f"{where} is empty")
    return lo, hi


def _field(key: str, spec: Any, where: str, consts: dict[str, float]) -> FieldBinding | None:
    """Parse one field entry; a ``{ const = v }`` lands in ``consts`` (returns None)."""
    if isinstance(spec, str):
        return FieldBinding(key=key, signal=spec)
    if not isinstance(spec, dict):
        raise BindingError(f"{where}: field {key} must be a signal name or a table")
    unknown = set(spec) - {"signal", "unit", "invert", "range", "const", "scale"}
    if unknown:
        raise BindingError(f"{where}: field {key}: unknown keys {sorted(unknown)}")
    if "const" in spec:
        if set(spec) != {"const"}:
            raise BindingError(f"{where}: field {key}: a const takes no other key")
        consts[key] = _num(spec["const"], f"{where}: field {key}.const")
        return None
    signal, unit, invert, rng = (spec.get(k) for k in ("signal", "unit", "invert", "range"))
    if not isinstance(signal, str) or not signal:
        raise BindingError(f"{where}: field {key}.signal must be a signal name")
    if unit is not None and not isinstance(unit, str):
        raise BindingError(f"{where}: field {key}.unit must be a string")
    if invert is not None and not isinstance(invert, bool):
        raise BindingError(f"{where}: field {key}.invert must be true or false")
    bounds = None if rng is None else _range(rng, f"{where}: field {key}.range")
    scale = _num(spec.get("scale", 1.0), f"{where}: field {key}.scale")
    if scale <= 0:
        raise BindingError(f"{where}: field {key}.scale must be > 0")
    return FieldBinding(
        key=key, signal=signal, unit=unit, invert=bool(invert), range=bounds, scale=scale
    )


_PART_KEYS = {f.name for f in fields(PartBinding)} | {"crc"}  # crc: version 1


def _names(value: Any, where: str) -> tuple[str, ...]:
    if not (isinstance(value, list) and all(isinstance(v, str) for v in value)):
        raise BindingError(f"{where} must be a list of signal names")
    return tuple(value)


def _e2e(table: dict[str, Any], where: str) -> tuple[str, str | None, str | None]:
    """(checksum kind, checksum signal, counter signal) of a part table."""
    crc, counter = table.get("crc"), table.get("counter")
    checksum = table.get("checksum", "none")
    checksum_signal = table.get("checksum_signal")
    if crc is not None:  # version 1: pacc's CRC-8 and counter, both or neither
        if "checksum" in table or checksum_signal is not None:
            raise BindingError(f"{where}: crc (version 1) or checksum, not both")
        if counter is None:
            raise BindingError(f"{where}: give both crc and counter, or neither")
        checksum, checksum_signal = "pacc_crc8", crc
    for name, value in (("checksum_signal", checksum_signal), ("counter", counter)):
        if value is not None and not isinstance(value, str):
            raise BindingError(f"{where}.{name} must be a signal name")
    if checksum not in KINDS:
        raise BindingError(f"{where}: checksum {checksum!r} is not one of {', '.join(KINDS)}")
    if (checksum == "none") != (checksum_signal is None):
        raise BindingError(f"{where}: a checksum needs its checksum_signal, and only then")
    return checksum, checksum_signal, counter


def _part(table: Any, where: str, consts: dict[str, float]) -> PartBinding:
    if not isinstance(table, dict):
        raise BindingError(f"{where} must be a table")
    unknown = set(table) - _PART_KEYS
    if unknown:
        raise BindingError(f"{where}: unknown keys {sorted(unknown)}")
    message = table.get("message")
    if not isinstance(message, str) or not message:
        raise BindingError(f"{where}.message must be a message name")
    fields_raw = table.get("fields", {})
    if not isinstance(fields_raw, dict):
        raise BindingError(f"{where}.fields must map field names to signals")
    parsed = {key: _field(key, spec, where, consts) for key, spec in fields_raw.items()}
    fields = {key: fb for key, fb in parsed.items() if fb is not None}
    checksum, checksum_signal, counter = _e2e(table, where)
    constants_raw = table.get("constants", {})
    if not isinstance(constants_raw, dict):
        raise BindingError(f"{where}.constants must map signal names to values")
    constants = {k: _num(v, f"{where}.constants.{k}") for k, v in constants_raw.items()}
    cycle = table.get("cycle_ms")
    cycle_ms = None if cycle is None else _num(cycle, f"{where}.cycle_ms")
    if cycle_ms is not None and cycle_ms <= 0:
        raise BindingError(f"{where}.cycle_ms must be > 0")
    return PartBinding(
        message=message,
        fields=fields,
        checksum=checksum,
        checksum_signal=checksum_signal,
        counter=counter,
        constants=constants,
        unused=_names(table.get("unused", []), f"{where}.unused"),
        cycle_ms=cycle_ms,
    )


def _role(role: str, raw: Any, where: str) -> RoleBinding:
    if role not in ROLES:
        raise BindingError(f"{where}: unknown role {role!r} (one of {', '.join(ROLES)})")
    tables = raw if isinstance(raw, list) else [raw]
    if not tables:
        raise BindingError(f"{where}: role {role} has no message")
    consts: dict[str, float] = {}
    parts = tuple(
        _part(t, f"{where}: roles.{role}" + (f"[{i}]" if len(tables) > 1 else ""), consts)
        for i, t in enumerate(tables)
    )
    rb = RoleBinding(role=role, parts=parts, consts=consts)
    seen = set(consts)
    for key in (k for part in parts for k in part.fields):
        if key in seen:
            raise BindingError(f"{where}: role {role}: field {key} is bound twice")
        seen.add(key)
    schema = ROLES[role]
    unknown = rb.bound() - set(schema)
    if unknown:
        raise BindingError(
            f"{where}: role {role}: unknown fields {sorted(unknown)} "
            f"(pacc's are {', '.join(schema)})"
        )
    missing = [k for k, spec in schema.items() if spec.required and k not in rb.bound()]
    if missing:
        raise BindingError(f"{where}: role {role}: required fields {missing} are not bound")
    return rb


def parse_binding(raw: dict[str, Any], where: str, path: Path | None = None) -> Binding:
    """A binding from a parsed TOML document; raise :class:`BindingError` if malformed."""
    unknown = set(raw) - {"version", "dbc", "roles", "vehicle", "source"}
    if unknown:
        raise BindingError(f"{where}: unknown keys {sorted(unknown)}")
    roles_raw = raw.get("roles")
    if not isinstance(roles_raw, dict) or not roles_raw:
        raise BindingError(f"{where}: no [roles.*] tables")
    roles = {name: _role(name, table, where) for name, table in roles_raw.items()}
    missing = [r for r in REQUIRED_ROLES if r not in roles]
    if missing:
        raise BindingError(
            f"{where}: missing roles {missing} (required: {', '.join(REQUIRED_ROLES)}; "
            f"optional: {', '.join(OPTIONAL_ROLES)})"
        )
    dbc = raw.get("dbc", "")
    if not isinstance(dbc, str):
        raise BindingError(f"{where}: dbc must be a file name")
    return Binding(dbc=dbc, roles=roles, path=path)


def binding_file(name: str | Path) -> Path:
    """The binding file ``name`` gives: a path, or else a packaged binding's name
    (``toyota_nodsu``: ``dbc/bindings/toyota_nodsu.binding.toml``)."""
    path = Path(name)
    packaged = DATA_DIR / "bindings" / f"{path.name}.binding.toml"
    if str(name) == path.name and not path.exists() and packaged.is_file():
        return packaged
    return path


def load_binding(path: str | Path) -> Binding:
    """Read a binding table from TOML; raise :class:`BindingError` with the reason."""
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise BindingError(f"cannot read binding {path}: {exc.strerror or exc}") from exc
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise BindingError(f"binding {path} is not valid TOML: {exc}") from exc
    except RecursionError:  # arrays or tables nested beyond the parser's stack
        raise BindingError(f"binding {path} is not valid TOML: nested too deep") from None
    return parse_binding(raw, str(path), path)


def check_against(binding: Binding, db: Any) -> None:
    """BindingError unless every message and signal ``binding`` names exists in cantools
    ``db`` and every signal of a bound message is named exactly once."""
    for role in binding.roles.values():
        for part in role.parts:
            try:
                message = db.get_message_by_name(part.message)
            except KeyError:
                raise BindingError(
                    f"role {role.role}: no message {part.message!r} in the DBC"
                ) from None
            names = {s.name for s in message.signals}
            named = part.signals()
            for signal in named:
                if signal not in names:
                    raise BindingError(f"role {role.role}: no signal {signal!r} in {part.message}")
            twice = sorted({s for s in named if named.count(s) > 1})
            if twice:
                raise BindingError(f"role {role.role}: {part.message}: {twice} named twice")
            unbound = names - set(named)
            if unbound:
                raise BindingError(
                    f"role {role.role}: signals {sorted(unbound)} of {part.message} unbound "
                    "(bind them, fix them in constants or list them in unused)"
                )
