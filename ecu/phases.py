"""The phases of one control cycle, as pure functions; :class:`ecu.node.EcuNode` runs them.

One cycle, in order (the openpilot split: read -> transition -> plan -> control -> outputs)::

    cycle_time      the cycle's time and integration step (a host clock fault: time stands still)
    check_inputs    input validity, the re-engagement hold, button edges -> state-machine Events
    transition      (ecu.state) the next AccState
    enter_state     what entering that state does: fault code, set speed, controller reset
    takeover        (stateful, in the node) press -> takeover; release -> adaptation, recording
    plan            the DGPT's desired gap and its slope at the current speed
    control         PID and envelope while ACTIVE; the FAULT ramp toward zero otherwise
    sample_of       the recorder's sample of this cycle
    outputs         NodeOutputs

The takeover phase runs before the plan on purpose: an adaptation applied at a pedal release
is the table the same cycle plans with.

Every function here is pure: values in, values out; no clock, no bus, no logging.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from ecu.config import MAX_DT_S, EcuConfig
from ecu.controller import ControlInput, desired_accel, limit_command, time_to_collision_s
from ecu.recorder import Sample
from ecu.road import RoadMemory, road_limit, road_update
from ecu.signals import NodeInputs, NodeOutputs, cycle_value, input_fault
from ecu.state import Events
from ecu.stops import URGENT_STOP_MPS2, closing_needs_mps2, lead_stop_need_mps2, stop_limit
from pacc.vocab.acc_state import AccState, FaultCode
from pacc.vocab.dgpt import Dgpt

#: Margin of the re-engagement hold time against float round-off, s.
SETTLE_EPS_S = 1e-9
ENGAGED = (AccState.ACTIVE, AccState.OVERRIDE)
#: a gap law through the plug-in interface: ``(obs, memory, dt_s) -> (accel_mps2, memory)``
#: (:class:`ecu.methods.guard.GuardedController`); None: the built-in PID called directly
GapLaw = Callable[[ControlInput, float, float], tuple[float, float]]
DISENGAGED = (AccState.STANDBY, AccState.FAULT)
#: the button levels of a stale HMI (set, resume, cancel): every button released
_RELEASED = (False, False, False)


# -- 1. clock ---------------------------------------------------------------------------------


def cycle_time(now_s: float, last_now_s: float | None, cycle_s: float) -> tuple[float, float]:
    """``(now_s, dt_s)`` of a cycle called at ``now_s`` after one at ``last_now_s`` (s).

    A non-finite ``now_s`` (a host clock fault) is taken as no time passing; the first cycle
    integrates over one period; ``dt_s`` is clipped to ``[0, MAX_DT_S]``.
    """
    if not math.isfinite(now_s):
        now_s = last_now_s if last_now_s is not None else 0.0
    dt = cycle_s if last_now_s is None else now_s - last_now_s
    if math.isfinite(dt):  # min(max(dt, 0), MAX_DT_S), written out (ecu.controller)
        dt = 0.0 if dt < 0.0 else dt
        dt = MAX_DT_S if dt > MAX_DT_S else dt
    else:
        dt = 0.0
    return now_s, dt


# -- 2. inputs ---------------------------------------------------------------------------------


@cycle_value
class InputCheck:
    """The checked inputs of one cycle.

    Attributes:
        fault: the first invalid safety-relevant input (``FaultCode.NONE``: all valid).
        valid_since_s: since when the inputs have been valid without a break, s (None: not
            valid now).
        buttons: the HMI button levels (set, resume, cancel) of this cycle.
        events: the state machine's inputs.
    """

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
    (``buttons``: last cycle's levels) and pedals, as the state machine's :class:`Events`.

    A stale HMI counts as every button released and the main switch unchanged; unknown
    pedals (stale, failed E2E or non-finite) count as released.
    """
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
    # a dict: 2.4x the cost, issue 23); each field named in a comment, in declaration order
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


# -- 3. state entry -----------------------------------------------------------------------------


@cycle_value
class Engagement:
    """What the node remembers about engagement across cycles.

    Attributes:
        fault_code: reason of the last FAULT (``NONE`` once re-engaged).
        set_speed_mps: cruise set speed, m/s (0: none; RESUME has nothing to resume).
        fault_ramp: an executed request is ramping to zero in FAULT.
    """

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
    whether the controller starts afresh (its integral reset).

    - FAULT records the fault, ramps only a request that was being executed (after an
      override it stays off) and forgets the set speed: only SET re-engages afterwards;
    - engaging from STANDBY or FAULT clears the fault; SET (or engaging without a set speed)
      takes ``config.set_speed_mps``, else the current speed up to ``config.max_set_speed_mps``.
    """
    if new is AccState.FAULT:
        mem = Engagement(fault_code=fault, set_speed_mps=0.0, fault_ramp=old is AccState.ACTIVE)
    if new in ENGAGED and old in DISENGAGED:
        speed = mem.set_speed_mps
        if set_edge or speed <= 0.0:
            fixed = config.set_speed_mps
            speed = min(v_mps, config.max_set_speed_mps) if fixed is None else fixed
        return Engagement(fault_code=FaultCode.NONE, set_speed_mps=speed, fault_ramp=False), True
    return mem, False


# -- 4. takeover -------------------------------------------------------------------------------


def takeover_pedal(accel: bool, brake: bool) -> str:
    """The pedal of a takeover: ``"accel"``, ``"brake"`` or ``"both"``."""
    if accel and brake:
        return "both"
    return "accel" if accel else "brake"


# -- 5. plan -----------------------------------------------------------------------------------


@cycle_value
class Plan:
    """The DGPT at the current speed: desired gap, m, and its slope d(gap)/d(speed), s."""

    v_mps: float
    desired_gap_m: float
    desired_gap_slope_s: float


def plan(table: Dgpt, v_mps: float) -> Plan:
    """Look the desired gap up at ``v_mps`` (a non-finite speed counts as 0 m/s)."""
    v = v_mps if math.isfinite(v_mps) else 0.0
    return Plan(v, table.lookup(v), table.slope(v))  # v_mps, desired gap, its slope


# -- 6. control --------------------------------------------------------------------------------


@cycle_value
class ControlMemory:
    """The controller's state across cycles: gap-error integral (m*s), last request (m/s^2),
    the road (target switches, lead loss, standstill; :class:`ecu.road.RoadMemory`)."""

    integral_m_s: float = 0.0
    prev_accel_mps2: float = 0.0
    road: RoadMemory = RoadMemory()


@cycle_value
class Command:
    """The request of one cycle.

    Attributes:
        accel_mps2: requested acceleration, m/s^2 (inside the envelope, rate-limited).
        active: the powertrain shall execute it.
        emergency: the emergency jerk exception was in force.
        ramp_done: the FAULT ramp reached zero this cycle (the request goes inactive).
    """

    accel_mps2: float
    active: bool
    emergency: bool = False
    ramp_done: bool = False


def control(
    config: EcuConfig,
    state: AccState,
    inp: NodeInputs,
    p: Plan,
    *,
    set_speed_mps: float,
    fault_ramp: bool,
    mem: ControlMemory,
    dt_s: float,
    law: GapLaw | None = None,
    resume: bool = False,
) -> tuple[Command, ControlMemory]:
    """The request of this cycle and the controller's next memory.

    ACTIVE: the PID gap law capped by cruise, then the envelope (emergency exception when a
    closing lead is within ``emergency_ttc_s`` and the request decreases; there the request
    is also at most the closing limit against the table's lower safety bound at the lead's
    speed; behind a braking lead whose stop, were it to brake to a standstill, would need
    more than 2 m/s^2, the request is at most that need, with the emergency build-up, at any
    TTC; while the driver overrides there, the inactive request prepares it). Otherwise the
    request ramps toward zero at the jerk limit; it stays active only in FAULT while an
    executed request is still ramping (``fault_ramp``). ``law``: a plug-in
    gap law in place of the PID (the envelope and the closing limit stay the ECU's). The road
    rules (:func:`ecu.road.road_update`): a target switch drops the integral, a brief
    lead loss does not raise the request, a standstill holds until the lead departs soon
    after the stop or the driver asks to go (``resume``: RESUME or the accelerator this cycle).
    """
    ctl = config.controller
    prev = mem.prev_accel_mps2
    active = state is AccState.ACTIVE
    road, switched = road_update(
        ctl.road,
        mem.road,
        lead_valid=inp.lead_valid,
        gap_m=inp.gap_m,
        rel_speed_mps=inp.rel_speed_mps,
        v_mps=p.v_mps,
        dt_s=dt_s,
        active=active,
        resume=resume,
    )
    integral0 = 0.0 if switched else mem.integral_m_s
    if active:
        lead_a = inp.lead_accel_mps2 if inp.lead_accel_valid else 0.0
        obs = ControlInput(  # positional fields, as in check_inputs
            p.v_mps,  # v_mps
            inp.a_mps2,  # a_mps2
            set_speed_mps,  # set_speed_mps
            inp.lead_valid,  # lead_valid
            inp.gap_m,  # gap_m
            inp.rel_speed_mps,  # rel_speed_mps
            lead_a,  # lead_accel_mps2
            p.desired_gap_m,  # desired_gap_m
            p.desired_gap_slope_s,  # desired_gap_slope_s
        )
        if law is None:
            target, integral = desired_accel(ctl, obs, integral0, dt_s, integrate=True)
        else:
            target, integral = law(obs, integral0, dt_s)
        ttc = time_to_collision_s(inp.lead_valid, inp.gap_m, inp.rel_speed_mps)
        urgent = False
        # brake at least as hard as the closing speed needs below 3 s TTC, and at any TTC when
        # the closing speed alone needs more than 2 m/s^2 (a cut-out revealing a car 15 m/s
        # slower 58 m ahead: 3.9 s TTC, 2.5 m/s^2; issue 21)
        alone, limit = closing_needs_mps2(config, inp, p, lead_a)
        if ttc < ctl.emergency_ttc_s or alone < URGENT_STOP_MPS2:
            urgent = alone < URGENT_STOP_MPS2 and limit < prev
            target = limit if target > limit else target
        if inp.lead_valid:  # a lead stopping or stopped: stop at the table's standstill gap
            need = lead_stop_need_mps2(config, inp, p, lead_a)
            stop = stop_limit(config, inp, p, lead_a, need)
            # behind a lead braking so hard that stopping behind it, were it to brake to a
            # standstill, needs more than 2 m/s^2: that braking now, at the emergency jerk,
            # not from 3 s TTC on (issue 21: the comfort jerk left 1.6 s TTC, and 0.36 m,
            # behind leads braking at 3 m/s^2 beyond the stop law's 4-s horizon)
            stop = need if need < URGENT_STOP_MPS2 and stop > need else stop
            urgent = urgent or (stop < URGENT_STOP_MPS2 and stop < prev)
            target = stop if target > stop else target
        target = road_limit(ctl.road, road, target, prev, inp.lead_valid)
        emergency = (ttc < ctl.emergency_ttc_s or urgent) and target < prev
        accel = limit_command(ctl, prev, target, dt_s, emergency=emergency)
        command = Command(accel, True, emergency)  # accel_mps2, active, emergency
        return command, ControlMemory(integral, accel, road)
    rest = 0.0
    ttc = time_to_collision_s(inp.lead_valid, inp.gap_m, inp.rel_speed_mps)
    prepare = math.inf  # what the ACC would ask for behind a hard-braking or fast-closed lead
    if state is AccState.OVERRIDE and inp.lead_valid:
        a_f = inp.lead_accel_mps2 if inp.lead_accel_valid else 0.0
        alone, limit = closing_needs_mps2(config, inp, p, a_f)
        prepare = lead_stop_need_mps2(config, inp, p, a_f)
        prepare = limit if alone < URGENT_STOP_MPS2 and prepare > limit else prepare
    if (
        state is AccState.OVERRIDE
        and (ttc < ctl.emergency_ttc_s or prepare < URGENT_STOP_MPS2)
        and math.isfinite(inp.a_mps2)
    ):
        # the driver brakes toward a closing lead: the inactive request follows the car's
        # deceleration, so that the ACC takes over at the release from there, not from 0
        # (issue 21: a brake released at 2.4 s TTC let the braking sag to 1.5 m/s^2); behind
        # a hard-braking lead, or closing fast, it prepares the braking the ACC would then
        # ask for (a gentle brake released at 4.6 s TTC behind a lead braking at 3 m/s^2 left
        # 1.99 s TTC; an accelerator tap as a cut-out revealed a stopped car, 1.29 s)
        lo = ctl.accel_min_mps2
        rest = lo if inp.a_mps2 < lo else inp.a_mps2  # min(max(a, lo), 0), written out
        rest = 0.0 if rest > 0.0 else rest
        if prepare < URGENT_STOP_MPS2:
            floor = lo if prepare < lo else prepare
            rest = floor if rest > floor else rest
    urgent = state is AccState.OVERRIDE and prepare < URGENT_STOP_MPS2 and rest < prev
    accel = limit_command(ctl, prev, rest, dt_s, emergency=urgent)
    ramping = state is AccState.FAULT and fault_ramp
    active = ramping and accel != 0.0
    # accel_mps2, active, emergency, ramp_done
    command = Command(accel, active, urgent, ramping and not active)
    return command, ControlMemory(integral0, accel, road)


# -- 7. recording and 8. outputs ---------------------------------------------------------------


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
        state is AccState.FAULT,  # takeover_request
        gap if math.isfinite(gap) else 0.0,  # desired_gap_m
        table.version,  # dgpt_version
        adaptation_count,  # adaptation_count
        fault_code,  # fault_code
        set_speed_mps,  # set_speed_mps
        command.emergency,  # emergency
        events,  # events
    )


__all__ = [
    "Command",
    "ControlMemory",
    "Engagement",
    "GapLaw",
    "InputCheck",
    "Plan",
    "check_inputs",
    "control",
    "cycle_time",
    "enter_state",
    "outputs",
    "plan",
    "reported_fault",
    "sample_of",
    "takeover_pedal",
]
