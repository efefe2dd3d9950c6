"""The control phase of one cycle: the acceleration request and the controller's memory.

While ACTIVE: the PID gap law of :mod:`ecu.controller` (or a plug-in :data:`GapLaw`) capped by
cruise, bounded by the closing and stopping limits (:mod:`ecu.cycle.stops`) and the road rules
(:mod:`ecu.cycle.road`), then the envelope and jerk limits; otherwise the request ramps toward
zero (in OVERRIDE it follows the braking the ACC would take over with). Pure; m/s^2 and s.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from dbc.vocab.acc_state import AccState
from ecu.config import EcuConfig
from ecu.controller import ControlInput, desired_accel, limit_command, time_to_collision_s
from ecu.cycle.road import RoadMemory, road_limit, road_update
from ecu.cycle.stops import (
    URGENT_STOP_MPS2,
    beyond_authority,
    closing_needs_mps2,
    lead_stop_need_mps2,
    stop_limit,
)
from ecu.signals import NodeInputs, Plan, cycle_value

#: a gap law through the plug-in interface: ``(obs, memory, dt_s) -> (accel_mps2, memory)``
#: (:class:`ecu.methods.guard.GuardedController`); None: the built-in PID called directly
GapLaw = Callable[[ControlInput, float, float], tuple[float, float]]


@cycle_value
class ControlMemory:
    """The controller's state across cycles: gap-error integral (m*s), last request (m/s^2),
    the road (target switches, lead loss, standstill; :class:`ecu.cycle.road.RoadMemory`)."""

    integral_m_s: float = 0.0
    prev_accel_mps2: float = 0.0
    road: RoadMemory = RoadMemory()


@cycle_value
class Command:
    """The request of one cycle: acceleration (m/s^2, in the envelope, rate-limited), whether
    the powertrain executes it, the emergency jerk exception, the FAULT ramp done, and the
    braking needed beyond the ACC's authority (:func:`ecu.cycle.stops.beyond_authority`)."""

    accel_mps2: float
    active: bool
    emergency: bool = False
    ramp_done: bool = False
    beyond_limit: bool = False


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
    """The request of this cycle and the controller's next memory."""
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
    lead_a = inp.lead_accel_mps2 if inp.lead_accel_valid else 0.0
    engaged = active or state is AccState.OVERRIDE
    beyond = engaged and beyond_authority(config, inp, p, lead_a)
    if active:
        obs = ControlInput(  # positional fields in declaration order
            p.v_mps,
            inp.a_mps2,
            set_speed_mps,
            inp.lead_valid,
            inp.gap_m,
            inp.rel_speed_mps,
            lead_a,
            p.desired_gap_m,
            p.desired_gap_slope_s,
        )
        if law is None:
            target, integral = desired_accel(ctl, obs, integral0, dt_s, integrate=True)
        else:
            target, integral = law(obs, integral0, dt_s)
        ttc = time_to_collision_s(inp.lead_valid, inp.gap_m, inp.rel_speed_mps)
        urgent = False
        # brake as hard as the closing speed needs below 3 s TTC, and at any TTC when it alone
        # needs more than 2 m/s^2 (a cut-out revealing a much slower car)
        alone, limit = closing_needs_mps2(config, inp, p, lead_a)
        if ttc < ctl.emergency_ttc_s or alone < URGENT_STOP_MPS2:
            urgent = alone < URGENT_STOP_MPS2 and limit < prev
            target = limit if target > limit else target
        if inp.lead_valid:  # a lead stopping or stopped: stop at the table's standstill gap
            need = lead_stop_need_mps2(config, inp, p, lead_a)
            stop = stop_limit(config, inp, p, lead_a, need)
            # a lead braking so hard that stopping behind it needs more than 2 m/s^2: brake
            # now, at the emergency jerk, not from 3 s TTC on
            stop = need if need < URGENT_STOP_MPS2 and stop > need else stop
            urgent = urgent or (stop < URGENT_STOP_MPS2 and stop < prev)
            target = stop if target > stop else target
        target = road_limit(ctl.road, road, target, prev, inp.lead_valid)
        emergency = (ttc < ctl.emergency_ttc_s or urgent) and target < prev
        accel = limit_command(ctl, prev, target, dt_s, emergency=emergency)
        # accel_mps2, active, emergency, ramp_done, beyond_limit
        command = Command(accel, True, emergency, False, beyond)
        return command, ControlMemory(integral, accel, road)
    rest = 0.0
    ttc = time_to_collision_s(inp.lead_valid, inp.gap_m, inp.rel_speed_mps)
    prepare = math.inf  # what the ACC would ask for behind a hard-braking or fast-closed lead
    if state is AccState.OVERRIDE and inp.lead_valid:
        alone, limit = closing_needs_mps2(config, inp, p, lead_a)
        prepare = lead_stop_need_mps2(config, inp, p, lead_a)
        prepare = limit if alone < URGENT_STOP_MPS2 and prepare > limit else prepare
    if (
        state is AccState.OVERRIDE
        and (ttc < ctl.emergency_ttc_s or prepare < URGENT_STOP_MPS2)
        and math.isfinite(inp.a_mps2)
    ):
        # the driver brakes toward a closing lead: the inactive request follows the car's
        # deceleration (or prepares the braking the ACC would ask for), so that the ACC takes
        # over at the release from there, not from 0
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
    # accel_mps2, active, emergency, ramp_done, beyond_limit
    command = Command(accel, active, urgent, ramping and not active, beyond)
    return command, ControlMemory(integral0, accel, road)
