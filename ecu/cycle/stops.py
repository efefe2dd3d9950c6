"""Stopping behind a lead, as pure functions: the request's bound when a lead stops or stands
(stop-and-go); :func:`ecu.cycle.command.control` applies it while ACTIVE.
"""

from __future__ import annotations

import math

from ecu.config import EcuConfig
from ecu.controller import closing_limit_mps2, stopping_limit_mps2
from ecu.signals import NodeInputs, Plan

#: a stop that needs more than this deceleration builds its braking at the emergency jerk
#: (a cut-out revealing a stopped vehicle: 1.4 s at 2.5 m/s^3 to reach -3.5 is too late), m/s^2
URGENT_STOP_MPS2 = -2.0
#: a lead slower than this stands; behind it, slower than CREEP_MPS and within 3 m of the
#: standstill gap, the car brakes to a stop instead of creeping on, m/s
STANDING_LEAD_MPS = 0.3
#: seconds of closing speed a stop behind a standing lead keeps to spare: TTC >= s + sqrt(2 g0 / a)
#: (0 s: 1.69 s; 0.5 s: 1.99 s on population seed 690274; 1.0 s keeps 2 s to g0 = 2 m at 3.5)
STOP_SPARE_S = 1.0
CREEP_MPS = 1.5
#: the time the ACC's braking takes to build (jerk ramp, powertrain lag), s: on population seed
#: 854026 (driver 6, cut-out) -3.5 m/s^2 built over 0.6 s and TTC fell from 2.2 s to 1.72 s
BRAKE_BUILD_S = 0.5


def _standstill_gap_m(config: EcuConfig, p: Plan) -> float:
    """The table's standstill gap: its line at the current speed extended to 0 m/s, never
    below the safety floor, m."""
    # max and min written out (as in ecu.controller: the same results, NaN included)
    line = p.desired_gap_m - p.desired_gap_slope_s * p.v_mps
    floor = config.bounds.lower_m(0.0)
    return floor if line < floor else line


def lead_stop_need_mps2(
    config: EcuConfig, inp: NodeInputs, p: Plan, lead_accel_mps2: float
) -> float:
    """The constant acceleration (m/s^2) that stops the car at the table's standstill gap, with
    ``STOP_SPARE_S`` of the closing speed to spare, behind where a braking lead would come to
    rest (``inf`` when the lead is not braking)."""
    v_lead = p.v_mps + inp.rel_speed_mps
    v_lead = 0.0 if v_lead < 0.0 else v_lead
    closing = p.v_mps - v_lead
    spare = STOP_SPARE_S * (0.0 if closing < 0.0 else closing)  # front-loaded: TTC above 2 s
    standstill = _standstill_gap_m(config, p)
    return stopping_limit_mps2(p.v_mps, inp.gap_m - spare, v_lead, lead_accel_mps2, standstill)


def closing_needs_mps2(
    config: EcuConfig, inp: NodeInputs, p: Plan, lead_accel_mps2: float
) -> tuple[float, float]:
    """What closing on the lead needs, m/s^2: the closing limit with the lead's acceleration
    taken as 0 and with it, against the table's lower bound at the lead's speed; ``(inf, inf)``
    without a lead or when not closing."""
    if not inp.lead_valid or inp.rel_speed_mps >= 0.0:
        return math.inf, math.inf
    v_lead = p.v_mps + inp.rel_speed_mps
    floor = config.bounds.lower_m(0.0 if v_lead < 0.0 else v_lead)
    alone = closing_limit_mps2(inp.gap_m, inp.rel_speed_mps, 0.0, floor)
    return alone, closing_limit_mps2(inp.gap_m, inp.rel_speed_mps, lead_accel_mps2, floor)


def beyond_authority(config: EcuConfig, inp: NodeInputs, p: Plan, lead_accel_mps2: float) -> bool:
    """True when the braking needed to keep the safety bound's standstill gap after
    ``BRAKE_BUILD_S`` (matching the lead's speed, or stopping behind a braking lead) exceeds the
    envelope's ``accel_min_mps2``: a takeover request, as a production ACC gives at its limit."""
    if not inp.lead_valid or not inp.rel_speed_mps < 0.0:
        return False
    v_lead = p.v_mps + inp.rel_speed_mps
    gap = inp.gap_m + inp.rel_speed_mps * BRAKE_BUILD_S
    keep = config.bounds.lower_m(0.0)
    match = closing_limit_mps2(gap, inp.rel_speed_mps, 0.0, keep)
    stop = stopping_limit_mps2(p.v_mps, gap, v_lead, lead_accel_mps2, keep)
    lo = config.controller.accel_min_mps2
    return match < lo or stop < lo


def stop_limit(
    config: EcuConfig, inp: NodeInputs, p: Plan, lead_accel_mps2: float, need_mps2: float
) -> float:
    """The request's bound behind a lead that stops (m/s^2): stop at the table's standstill gap
    behind where a braking lead standing within ``lead_stop_horizon_s`` comes to rest
    (``need_mps2``); behind a lead slower than ``stop_lead_mps`` also match its speed."""
    road = config.controller.road
    standstill = _standstill_gap_m(config, p)
    v_lead = p.v_mps + inp.rel_speed_mps
    v_lead = 0.0 if v_lead < 0.0 else v_lead
    closing = p.v_mps - v_lead
    closing = 0.0 if closing < 0.0 else closing
    spare = STOP_SPARE_S * closing  # front-loaded: TTC stays above 2 s
    limit = need_mps2
    braking = -lead_accel_mps2
    if v_lead > road.lead_stop_horizon_s * (0.0 if braking < 0.0 else braking):
        limit = math.inf  # the lead will not be standing soon: the gap law's business
    if v_lead < STANDING_LEAD_MPS and p.v_mps < CREEP_MPS and inp.gap_m < standstill + 3.0:
        hold = road.hold_accel_mps2  # close to a standing lead: stop, no creep
        limit = hold if limit > hold else limit
    if v_lead < road.stop_lead_mps:
        at_lead = p.desired_gap_m - p.desired_gap_slope_s * closing
        floor = config.bounds.lower_m(v_lead)
        floor = floor if at_lead < floor else at_lead
        match = closing_limit_mps2(inp.gap_m - spare, inp.rel_speed_mps, lead_accel_mps2, floor)
        limit = match if limit > match else limit
    return limit
