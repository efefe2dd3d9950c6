"""The frame codec shared by the ECU and the simulator.

The DBC is loaded once (cantools) and bound to logical roles and fields by
the binding table (:mod:`dbc.binding`). For every message, an encoder and a decoder are
compiled once into straight-line Python (shifts and masks on one integer, an unrolled
table CRC), which is what makes them several times faster than cantools' generic
``Message.encode``/``decode``. Encoding fills the alive counter and the E2E CRC; decoding
checks length, CRC and ranges and raises a :class:`~dbc.errors.DecodeError` subclass
(:mod:`dbc.message` compiles them).

Values are keyed by logical field names (``speed_mps``, ``gap_m`` …), never by signal
names: code above the codec knows roles and fields only.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path
from typing import Any

from dbc import BINDING_PATH, DBC_PATH
from dbc.binding import Binding, check_against, load_binding
from dbc.binding import binding_file as packaged_binding
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
from dbc.message import Decoded, MessageCodec, Value
from dbc.schema import ROLES, check_ranges

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
        check_ranges(self.roles)

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
