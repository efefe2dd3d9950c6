"""The binding table: pacc's logical roles and fields → DBC messages and signals.

A binding is data (``dbc/pacc.binding.toml``), so that driving another vehicle's network
means writing a new DBC and a new table, not new code. Loading validates the table
against the DBC: every message and signal must exist, every signal of a bound message
must be bound, and the CRC must be a byte-aligned 8-bit signal.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dbc.errors import DbcError

#: Roles the ECU and the simulator use; a binding must define all of them.
REQUIRED_ROLES: tuple[str, ...] = ("ego", "pedals", "radar", "hmi", "command", "status")


@dataclass(frozen=True)
class RoleBinding:
    """One role: its DBC message, its E2E signals and its logical field → signal map."""

    role: str
    message: str
    fields: dict[str, str]
    crc: str | None = None
    counter: str | None = None

    @property
    def protected(self) -> bool:
        """True when the message carries a CRC and an alive counter."""
        return self.crc is not None and self.counter is not None


@dataclass(frozen=True)
class Binding:
    """A whole vehicle binding: the DBC it belongs to and its roles."""

    dbc: str
    roles: dict[str, RoleBinding]


def _role_from_table(role: str, table: Any, where: str) -> RoleBinding:
    if not isinstance(table, dict):
        raise DbcError(f"{where}: [roles.{role}] must be a table")
    message = table.get("message")
    fields = table.get("fields")
    if not isinstance(message, str) or not message:
        raise DbcError(f"{where}: roles.{role}.message must be a message name")
    if not isinstance(fields, dict) or not all(
        isinstance(k, str) and isinstance(v, str) for k, v in fields.items()
    ):
        raise DbcError(f"{where}: roles.{role}.fields must map field names to signal names")
    crc, counter = table.get("crc"), table.get("counter")
    if (crc is None) != (counter is None):
        raise DbcError(f"{where}: roles.{role}: give both crc and counter, or neither")
    for key in ("crc", "counter"):
        value = table.get(key)
        if value is not None and not isinstance(value, str):
            raise DbcError(f"{where}: roles.{role}.{key} must be a signal name")
    unknown = set(table) - {"message", "fields", "crc", "counter"}
    if unknown:
        raise DbcError(f"{where}: roles.{role}: unknown keys {sorted(unknown)}")
    return RoleBinding(role=role, message=message, fields=dict(fields), crc=crc, counter=counter)


def load_binding(path: str | Path) -> Binding:
    """Read a binding table from TOML; raise :class:`DbcError` with the reason if malformed."""
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise DbcError(f"cannot read binding {path}: {exc.strerror or exc}") from exc
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise DbcError(f"binding {path} is not valid TOML: {exc}") from exc
    roles_raw = raw.get("roles")
    if not isinstance(roles_raw, dict) or not roles_raw:
        raise DbcError(f"{path}: no [roles.*] tables")
    roles = {name: _role_from_table(name, table, str(path)) for name, table in roles_raw.items()}
    missing = [r for r in REQUIRED_ROLES if r not in roles]
    if missing:
        raise DbcError(f"{path}: missing roles {missing}")
    return Binding(dbc=str(raw.get("dbc", "")), roles=roles)


def check_against(binding: Binding, db: Any) -> None:
    """Validate ``binding`` against a cantools Database ``db``; raise :class:`DbcError`."""
    for role in binding.roles.values():
        try:
            message = db.get_message_by_name(role.message)
        except KeyError:
            raise DbcError(f"role {role.role}: no message {role.message!r} in the DBC") from None
        names = {s.name for s in message.signals}
        bound = list(role.fields.values()) + [s for s in (role.crc, role.counter) if s]
        for signal in bound:
            if signal not in names:
                raise DbcError(f"role {role.role}: no signal {signal!r} in {role.message}")
        unbound = names - set(bound)
        if unbound:
            raise DbcError(f"role {role.role}: signals {sorted(unbound)} of {role.message} unbound")
        if role.crc is not None:
            crc = message.get_signal_by_name(role.crc)
            if crc.length != 8 or crc.start % 8 != (0 if crc.byte_order == "little_endian" else 7):
                raise DbcError(f"role {role.role}: CRC {role.crc} must be one whole byte")
        if role.counter is not None:
            counter = message.get_signal_by_name(role.counter)
            if counter.length != 4 or counter.is_signed:
                raise DbcError(f"role {role.role}: counter {role.counter} must be 4-bit unsigned")
