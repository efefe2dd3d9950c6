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
    slotted dataclass at run time."""
    return dataclass(slots=True, unsafe_hash=True)(cls)


@dataclass(slots=True)
class NodeInputs:
    """Checked inputs of one cycle. ``*_ok`` = fresh and passed E2E (set by the runtime)."""

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
    """Everything the node emits in one cycle (the runtime packs it into frames): the request
    (m/s^2, within the envelope), ``takeover_request`` (FAULT, or braking beyond authority), the
    DGPT at the current speed (m), the last FaultCode, whether the emergency jerk exception held."""

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
    events: tuple[str, ...] = ()  # this cycle's state changes, faults, adaptations


def input_fault(inp: NodeInputs) -> FaultCode:
    """The first invalid safety-relevant input of ``inp`` (speed, pedals, radar, buttons)."""
    finite = math.isfinite
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
