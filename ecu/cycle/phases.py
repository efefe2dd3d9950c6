"""The phases of one control cycle, as pure functions; :class:`ecu.node.EcuNode` runs them.

In order: ``cycle_time`` -> ``check_inputs`` (validity, re-engagement hold, button edges) ->
``transition`` (:mod:`ecu.cycle.state`) -> ``enter_state`` -> takeover (in the node) ->
``plan`` (the DGPT's gap and slope at the current speed) -> ``control``
(:mod:`ecu.cycle.command`) -> ``sample_of`` -> ``outputs``. The takeover runs before the plan
so that a table adapted at a release is the one the same cycle plans with.
"""

from __future__ import annotations

import math

from dbc.vocab.acc_state import AccState, FaultCode
from dbc.vocab.dgpt import Dgpt
from ecu.config import MAX_DT_S, EcuConfig
from ecu.cycle.command import Command
from ecu.cycle.state import Events
from ecu.recorder import Sample
from ecu.signals import NodeInputs, NodeOutputs, Plan, cycle_value, input_fault

#: Margin of the re-engagement hold time against float round-off, s.
SETTLE_EPS_S = 1e-9
ENGAGED = (AccState.ACTIVE, AccState.OVERRIDE)
DISENGAGED = (AccState.STANDBY, AccState.FAULT)
#: the button levels of a stale HMI (set, resume, cancel): every button released
_RELEASED = (False, False, False)


def cycle_time(now_s: float, last_now_s: float | None, cycle_s: float) -> tuple[float, float]:
    """``(now_s, dt_s)`` of a cycle called at ``now_s`` after one at ``last_now_s`` (s)."""
    if not math.isfinite(now_s):
        now_s = last_now_s if last_now_s is not None else 0.0
    dt = cycle_s if last_now_s is None else now_s - last_now_s
    if math.isfinite(dt):  # min(max(dt, 0), MAX_DT_S), written out (ecu.controller)
        dt = 0.0 if dt < 0.0 else dt
        dt = MAX_DT_S if dt > MAX_DT_S else dt
    else:
        dt = 0.0
    return now_s, dt


@cycle_value
class InputCheck:
    """The checked inputs of one cycle: the first invalid safety-relevant input (``NONE``: all
    valid), since when the inputs have been valid (s; None: not now), the HMI button levels (set,
    resume, cancel) and the state machine's inputs."""

    fault: FaultCode
    valid_since_s: float | None
    buttons: tuple[bool, bool, bool]
    events: Events

    @property
    def valid(self) -> bool:
        """Every safety-relevant input is fresh, passed E2E and finite."""
        return self.fault is FaultCode.NONE


def check_inputs(
    inp: NodeInputs,
    now_s: float,
    *,
    state: AccState,
    buttons: tuple[bool, bool, bool],
    valid_since_s: float | None,
    settle_s: float,
    has_set_speed: bool,
) -> InputCheck:
    """Validity, the hold time before re-engagement (``settle_s``), rising button edges
    (``buttons``: last cycle's levels) and pedals, as the state machine's :class:`Events`."""
    fault = input_fault(inp)
    valid = fault is FaultCode.NONE
    since = (now_s if valid_since_s is None else valid_since_s) if valid else None
    settled = since is not None and now_s - since >= settle_s - SETTLE_EPS_S
    if inp.hmi_ok:
        levels = set_lv, resume_lv, cancel_lv = inp.set_button, inp.resume_button, inp.cancel_button
    else:
        levels = set_lv, resume_lv, cancel_lv = _RELEASED
    set_prev, resume_prev, cancel_prev = buttons
    # valid inputs include the pedals (input_fault): known without a second look
    pedals_known = valid or (
        inp.pedals_ok and math.isfinite(inp.accel_pedal) and math.isfinite(inp.brake_pedal)
    )
    # the cycle's values are built with positional fields (a class call with keywords builds
    # a dict: 2.4x the cost); each field named in a comment, in declaration order
    events = Events(
        inp.main_switch if inp.hmi_ok else state is not AccState.OFF,  # main_on
        set_lv and not set_prev,  # set_edge
        resume_lv and not resume_prev,  # resume_edge
        cancel_lv and not cancel_prev,  # cancel_edge
        inp.accel_pressed if pedals_known else False,  # accel_pressed
        inp.brake_pressed if pedals_known else False,  # brake_pressed
        valid,  # inputs_valid
        settled,  # inputs_settled
        has_set_speed,  # has_set_speed
    )
    return InputCheck(fault, since, levels, events)


@cycle_value
class Engagement:
    """What the node remembers about engagement across cycles: the last FAULT's code (``NONE``
    once re-engaged), the set speed (m/s; 0: none), whether the request ramps to zero in FAULT."""

    fault_code: FaultCode = FaultCode.NONE
    set_speed_mps: float = 0.0
    fault_ramp: bool = False


def enter_state(
    old: AccState,
    new: AccState,
    mem: Engagement,
    *,
    fault: FaultCode,
    set_edge: bool,
    v_mps: float,
    config: EcuConfig,
) -> tuple[Engagement, bool]:
    """The engagement memory after the change ``old -> new`` (``new is not old``), and
    whether the controller starts afresh (its integral reset)."""
    if new is AccState.FAULT:
        mem = Engagement(fault_code=fault, set_speed_mps=0.0, fault_ramp=old is AccState.ACTIVE)
    if new in ENGAGED and old in DISENGAGED:
        speed = mem.set_speed_mps
        if set_edge or speed <= 0.0:
            fixed = config.set_speed_mps
            speed = min(v_mps, config.max_set_speed_mps) if fixed is None else fixed
        return Engagement(fault_code=FaultCode.NONE, set_speed_mps=speed, fault_ramp=False), True
    return mem, False


def takeover_pedal(accel: bool, brake: bool) -> str:
    """The pedal of a takeover: ``"accel"``, ``"brake"`` or ``"both"``."""
    return "both" if accel and brake else ("accel" if accel else "brake")


def plan(table: Dgpt, v_mps: float) -> Plan:
    """Look the desired gap up at ``v_mps`` (a non-finite speed counts as 0 m/s)."""
    v = v_mps if math.isfinite(v_mps) else 0.0
    return Plan(v, table.lookup(v), table.slope(v))  # v_mps, desired gap, its slope


def sample_of(inp: NodeInputs, now_s: float, state: AccState) -> Sample:
    """The takeover recorder's sample of this cycle (gap and lead speed NaN without a lead)."""
    return Sample(
        t_s=now_s,
        v_mps=inp.v_mps,
        gap_m=inp.gap_m if inp.lead_valid else math.nan,
        v_lead_mps=inp.v_mps + inp.rel_speed_mps if inp.lead_valid else math.nan,
        a_mps2=inp.a_mps2,
        accel_pedal=inp.accel_pedal,
        brake_pedal=inp.brake_pedal,
        acc_state=int(state),
    )


def reported_fault(fault_code: FaultCode, profile_fault: bool) -> FaultCode:
    """The FaultCode on the status: the last input fault, else PROFILE if a profile was
    refused, else NONE."""
    if profile_fault and fault_code is FaultCode.NONE:
        return FaultCode.PROFILE
    return fault_code


def outputs(
    state: AccState,
    command: Command,
    p: Plan,
    *,
    table: Dgpt,
    adaptation_count: int,
    fault_code: FaultCode,
    set_speed_mps: float,
    events: tuple[str, ...],
) -> NodeOutputs:
    """The node's outputs of this cycle (a non-finite desired gap is reported as 0 m)."""
    gap = p.desired_gap_m
    return NodeOutputs(  # positional fields, as in check_inputs
        command.accel_mps2,  # accel_request_mps2
        command.active,  # request_active
        state,  # acc_state
        state is AccState.FAULT or command.beyond_limit,  # takeover_request
        gap if math.isfinite(gap) else 0.0,  # desired_gap_m
        table.version,  # dgpt_version
        adaptation_count,  # adaptation_count
        fault_code,  # fault_code
        set_speed_mps,  # set_speed_mps
        command.emergency,  # emergency
        events,  # events
    )
