"""pacc's logical interface: the roles and fields the ECU and the simulator exchange.

A binding (:mod:`dbc.binding`) maps these to a vehicle's messages and signals. A required
field must be bound (to a signal or a constant); an optional field the vehicle lacks takes
its default here when decoded and is left out when encoded. The ``status`` role is optional
as a whole: a network without it simply does not carry the ECU's status.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FieldSpec:
    """One logical field: required, or optional with the value a receiver assumes."""

    required: bool = True
    default: float = 0.0


_R = FieldSpec()


def _opt(default: float) -> FieldSpec:
    return FieldSpec(required=False, default=default)


#: role -> field -> spec (units are in the field names, see :mod:`dbc.units`)
ROLES: dict[str, dict[str, FieldSpec]] = {
    "ego": {"speed_mps": _R, "accel_mps2": _opt(0.0), "speed_valid": _opt(1)},
    "pedals": {
        "accel_pedal_pct": _R,
        "accel_pressed": _R,
        "brake_pressed": _R,
        "brake_pressure_bar": _opt(0.0),
    },
    "radar": {
        "lead_valid": _opt(1),
        "gap_m": _R,
        "rel_speed_mps": _R,
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
        "dgpt_version": _opt(0),
        "adaptation_count": _opt(0),
        "fault_code": _opt(0),
        "set_speed_mps": _opt(0.0),
    },
}

#: roles a binding must define
REQUIRED_ROLES: tuple[str, ...] = ("ego", "pedals", "radar", "hmi", "command")
#: roles a binding may leave out
OPTIONAL_ROLES: tuple[str, ...] = ("status",)

__all__ = ["OPTIONAL_ROLES", "REQUIRED_ROLES", "ROLES", "FieldSpec"]
