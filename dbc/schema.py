"""pacc's logical interface: the roles and fields the ECU and the simulator exchange.

A binding (:mod:`dbc.binding`) maps them to a vehicle's signals: a required field must be
bound (to a signal or a constant), an optional one the vehicle lacks takes its default; the
``status`` role is optional. A field's ``range`` must fit its signal (:func:`check_ranges`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from dbc.errors import BindingError


@dataclass(frozen=True)
class FieldSpec:
    """One field: required, or optional with the value a receiver assumes; ``range`` the
    [min, max] (its unit) its signal must hold (None: any)."""

    required: bool = True
    default: float = 0.0
    range: tuple[float, float] | None = None


_R = FieldSpec()


def _opt(default: float, range: tuple[float, float] | None = None) -> FieldSpec:  # noqa: A002
    return FieldSpec(required=False, default=default, range=range)


#: the DGPT's speed axis, m/s (0..40: dbc.vocab.dgpt)
_SPEED = (0.0, 40.0)
#: the longest gap the paper's headways ask at 40 m/s (4 s x 40 m/s + 4 m = 164 m), rounded up
_GAP = (0.0, 200.0)


#: role -> field -> spec (units are in the field names, see :mod:`dbc.units`)
ROLES: dict[str, dict[str, FieldSpec]] = {
    "ego": {"speed_mps": FieldSpec(range=_SPEED), "accel_mps2": _opt(0.0), "speed_valid": _opt(1)},
    "pedals": {
        "accel_pedal_pct": _R,
        "accel_pressed": _R,
        "brake_pressed": _R,
        "brake_pressure_bar": _opt(0.0),
    },
    "radar": {
        "lead_valid": _opt(1),
        "gap_m": FieldSpec(range=_GAP),
        "rel_speed_mps": FieldSpec(range=(-_SPEED[1], _SPEED[1])),
        "lead_accel_mps2": _opt(0.0),
        "lead_accel_valid": _opt(0),
    },
    "hmi": {
        "main_switch": _R,
        "set": _R,
        "resume": _R,
        "cancel": _R,
        "gap_setting": _opt(2),
        "profile_id": _opt(0),
    },
    "command": {
        "accel_request_mps2": _R,
        "request_active": _R,
        "acc_state": _R,
        "takeover_request": _opt(0),
    },
    "status": {
        "desired_gap_m": _opt(0.0),
        "dgpt_version": _opt(0, (0, 0xFFFF)),  # every DGPT version (dbc.vocab.dgpt.MAX_VERSION)
        "adaptation_count": _opt(0),
        "fault_code": _opt(0),
        "set_speed_mps": _opt(0.0),
    },
}

#: roles a binding must define
REQUIRED_ROLES: tuple[str, ...] = ("ego", "pedals", "radar", "hmi", "command")
#: roles a binding may leave out
OPTIONAL_ROLES: tuple[str, ...] = ("status",)

#: the values the input roles' senders start from: each field's default, but a valid lead
#: acceleration and the ACC main switch on (standstill, no pedal, a lead at 0 m, no button)
_RESTING: dict[str, dict[str, float]] = {
    role: {k: spec.default for k, spec in ROLES[role].items()}
    | {"radar": {"lead_accel_valid": 1}, "hmi": {"main_switch": 1}}.get(role, {})
    for role in ("ego", "pedals", "radar", "hmi")
}


def check_ranges(roles: Mapping[str, Any]) -> None:
    """BindingError where a signal bound to a field with a ``range`` cannot hold it
    (``roles``: role -> :class:`dbc.codec.RoleCodec`; constants are not checked)."""
    for role, fields in ROLES.items():
        rc = roles.get(role)
        for key, spec in fields.items():
            mc = None if rc is None or spec.range is None else rc.part_of(key)
            if mc is None or spec.range is None:
                continue
            (lo, hi), (need_lo, need_hi) = mc.bounds(key), spec.range
            if lo > need_lo + 1e-9 or hi < need_hi - 1e-9:
                raise BindingError(
                    f"role {role}: {mc.name}: {key} range [{lo:g}, {hi:g}] cannot hold "
                    f"[{need_lo:g}, {need_hi:g}] (docs/vehicles.md)"
                )


def resting_values(**roles: dict[str, float]) -> dict[str, dict[str, float]]:
    """A fresh copy of the input roles' resting values, updated from ``roles[role]``."""
    return {role: {**fields, **roles.get(role, {})} for role, fields in _RESTING.items()}
