"""The frame codec shared by the ECU and the simulator: a DBC (cantools, loaded once) bound
to pacc's roles and fields by the binding table (:mod:`dbc.binding`), one compiled
:class:`~dbc.message.MessageCodec` per bound message. Values are keyed by logical field names
(``speed_mps``, ``gap_m``), never by signal names.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

from dbc import BINDING_PATH, DBC_PATH
from dbc.binding import Binding, check_against, load_binding
from dbc.binding import binding_file as packaged_binding
from dbc.errors import BindingError, DbcError
from dbc.message import MessageCodec, Value
from dbc.schema import ROLES, check_ranges


class RoleCodec:
    """One role: its message codecs (``parts``), the ``defaults`` receivers assume for fields
    held constant or left out, and every field it gives a value (``fields``)."""

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


class Codec:
    """All bound messages of one network: ``by_role`` (each role's first message), ``roles``
    (whole roles), ``by_id`` (every message by frame id, role by role)."""

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
        check_ranges(self.roles)


def _load_db(dbc_path: Path) -> Any:
    import cantools  # noqa: PLC0415 - ~0.3 s of start-up, only when a DBC is loaded

    # not strict: real networks overlap signals pacc does not use; the bound ones are checked
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
    """The (DBC, binding) files the command line gives: neither, the packaged network; a
    binding alone, the DBC it names beside it; both, the binding must name that DBC (else,
    and for a DBC alone, BindingError)."""
    if binding_path is None:
        if dbc_path is not None:
            raise BindingError(
                f"--dbc {dbc_path} needs --binding FILE: the table that maps pacc's roles to "
                "that network's messages (docs/vehicles.md)"
            )
        return DBC_PATH, BINDING_PATH
    binding_file = packaged_binding(binding_path).resolve()
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
    """The codec of a DBC and binding (default: the packaged ones; a binding alone brings
    its DBC; a DBC alone takes the packaged binding), loaded once; DbcError if unusable."""
    if binding_path is not None and dbc_path is None:
        return _load_codec(*network_paths(None, binding_path))
    dbc = Path(dbc_path).resolve() if dbc_path else DBC_PATH
    binding = Path(binding_path).resolve() if binding_path else BINDING_PATH
    return _load_codec(dbc, binding)
