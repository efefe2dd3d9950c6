"""pacc's logical interface: the roles and fields the ECU and the simulator exchange.

A binding (:mod:`dbc.binding`) maps these to a vehicle's messages and signals. A required
field must be bound (to a signal or a constant); an optional field the vehicle lacks takes
its default here when decoded and is left out when encoded. The ``status`` role is optional
as a whole: a network without it simply does not carry the ECU's status. A field with a
documented ``range`` must be bound to a signal that can hold it (:func:`check_ranges`): a
vehicle speed signal of [0, 1] m/s would clamp the car's speed on the bus.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from dbc.errors import BindingError


@dataclass(frozen=True)
class FieldSpec:
    """One logical field: required, or optional with the value a receiver assumes; ``range``
    is the [min, max] (the field's unit) a signal bound to it must hold (None: any)."""

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

#: the values a sender of the input roles starts from (every field of each role): the car at
#: standstill with its speed valid, no pedal, a valid lead at 0 m not accelerating (with a
#: valid lead acceleration), the ACC main switch on, no button, gap setting 2, profile 0
_RESTING: dict[str, dict[str, float]] = {
    "ego": {"speed_mps": 0.0, "accel_mps2": 0.0, "speed_valid": 1},
    "pedals": {
        "accel_pedal_pct": 0.0,
        "accel_pressed": 0,
        "brake_pressed": 0,
        "brake_pressure_bar": 0.0,
    },
    "radar": {
        "lead_valid": 1,
        "gap_m": 0.0,
        "rel_speed_mps": 0.0,
        "lead_accel_mps2": 0.0,
        "lead_accel_valid": 1,
    },
    "hmi": {
        "main_switch": 1,
        "set": 0,
        "resume": 0,
        "cancel": 0,
        "gap_setting": 2,
        "profile_id": 0,
    },
}


def check_ranges(roles: Mapping[str, Any]) -> None:
    """Refuse a network (``roles``: role -> :class:`dbc.codec.RoleCodec`) where a signal bound
    to a field with a documented ``range`` cannot hold that range (a field held constant is
    not checked: the vehicle does not carry it).

    Raises:
        BindingError: naming the message, the field, its range and the one it must hold.
    """
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
    """A fresh copy of the input roles' resting values (the simulator's and the test peers'
    starting frames), each role's fields updated from ``roles[role]`` where given."""
    return {role: {**fields, **roles.get(role, {})} for role, fields in _RESTING.items()}


__all__ = [
    "OPTIONAL_ROLES",
    "REQUIRED_ROLES",
    "ROLES",
    "FieldSpec",
    "check_ranges",
    "resting_values",
]
