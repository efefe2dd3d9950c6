"""The node's boundary values: checked inputs of one cycle, the plan (the DGPT at the current
speed), outputs of one cycle; the
:func:`cycle_value` decorator of the values the control cycle builds.

No signal names or CAN ids here: the runtime turns frames into :class:`NodeInputs` and
:class:`NodeOutputs` into frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypeVar, dataclass_transform

from dbc.vocab.acc_state import AccState, FaultCode

_T = TypeVar("_T")


@dataclass_transform(frozen_default=True)
def cycle_value(cls: type[_T]) -> type[_T]:
    """A value the control cycle builds every 20 ms: immutable to the type checker, a plain
    slotted dataclass at run time.

    The type checker (mypy strict) treats the class as ``@dataclass(frozen=True)``: an
    assignment to a field is an error, ``dataclasses.replace`` makes changed copies. At run
    time it is ``@dataclass(slots=True, unsafe_hash=True)``: the same fields, ``__eq__``,
    ``__repr__`` and the same field-wise ``__hash__`` as a frozen dataclass, but an
    assignment is not refused at run time. The trade-off, measured: a frozen
    dataclass's ``__init__`` stores each field through ``object.__setattr__`` (about 0.1 us
    per field, 1.3 us for nine fields against 0.5 us plain); the node builds about ten such
    values per cycle. Immutability is therefore a checked contract (``make lint`` runs mypy
    strict on every module), not a run-time guard: code outside the type checker's reach must
    not assign to these values, so none is handed to a plug-in (``ControlInput``, which gap
    controllers get, stays a frozen dataclass).
    """
    return dataclass(slots=True, unsafe_hash=True)(cls)


@dataclass(slots=True)
class NodeInputs:
    """Checked inputs of one cycle. ``*_ok`` = fresh and passed E2E (set by the runtime).

    Units: speeds m/s, accelerations m/s^2, gap m, pedals 0..1. ``rel_speed_mps`` is lead
    speed minus ego speed. Button fields are levels (pressed = True).
    """

    v_mps: float = 0.0
    a_mps2: float = 0.0
    speed_ok: bool = True
    accel_pedal: float = 0.0
    brake_pedal: float = 0.0
    accel_pressed: bool = False
    brake_pressed: bool = False
    pedals_ok: bool = True
    lead_valid: bool = False
    gap_m: float = 0.0
    rel_speed_mps: float = 0.0
    lead_accel_mps2: float = 0.0
    lead_accel_valid: bool = False
    radar_ok: bool = True
    main_switch: bool = False
    set_button: bool = False
    resume_button: bool = False
    cancel_button: bool = False
    hmi_ok: bool = True


@cycle_value
class NodeOutputs:
    """Everything the node emits in one cycle (the runtime packs it into frames).

    Attributes:
        accel_request_mps2: requested acceleration, m/s^2 (always within the envelope).
        request_active: the powertrain shall execute the request.
        acc_state: AccState code.
        takeover_request: the driver must take over (FAULT, or engaged with the braking
            needed beyond what the ACC may command).
        desired_gap_m: DGPT at the current speed, m.
        dgpt_version: version of the table in use.
        adaptation_count: adaptations applied so far.
        fault_code: FaultCode of the last fault (0 none).
        set_speed_mps: cruise set speed, m/s.
        emergency: the emergency jerk exception was in force this cycle.
        events: human-readable events of this cycle (state changes, faults, adaptations).
    """

    accel_request_mps2: float
    request_active: bool
    acc_state: AccState
    takeover_request: bool
    desired_gap_m: float
    dgpt_version: int
    adaptation_count: int
    fault_code: FaultCode
    set_speed_mps: float
    emergency: bool
    events: tuple[str, ...] = ()


def all_finite(*xs: float) -> bool:
    """True when every one of ``xs`` is finite (the cycle itself calls ``math.isfinite``
    directly: a call of this function costs more than the checks)."""
    return all(map(math.isfinite, xs))


def input_fault(inp: NodeInputs) -> FaultCode:
    """The first invalid safety-relevant input of ``inp`` (speed, pedals, radar, buttons)."""
    finite = math.isfinite  # all_finite written out: this runs every cycle
    if not (inp.speed_ok and finite(inp.v_mps) and finite(inp.a_mps2) and inp.v_mps >= 0.0):
        return FaultCode.SPEED_INPUT
    if not (inp.pedals_ok and finite(inp.accel_pedal) and finite(inp.brake_pedal)):
        return FaultCode.PEDAL_INPUT
    if not inp.radar_ok or (
        inp.lead_valid
        and not (finite(inp.gap_m) and finite(inp.rel_speed_mps) and finite(inp.lead_accel_mps2))
    ):
        return FaultCode.RADAR_INPUT
    if not inp.hmi_ok:
        return FaultCode.HMI_INPUT
    return FaultCode.NONE


@cycle_value
class Plan:
    """The DGPT at the current speed: desired gap, m, and its slope d(gap)/d(speed), s."""

    v_mps: float
    desired_gap_m: float
    desired_gap_slope_s: float


__all__ = ["NodeInputs", "NodeOutputs", "Plan", "all_finite", "cycle_value", "input_fault"]
