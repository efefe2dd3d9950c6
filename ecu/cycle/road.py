"""The road rules of the control law: target switches, lead loss, standstill.

A radar gap jump the relative speed cannot explain is a *target switch* (cut-in, cut-out, new
lead): the old target's integral is dropped and its time kept (the adaptation skips a takeover
right after one). A lead lost for less than ``lead_loss_hold_s`` does not make the car speed
up. At a standstill the request holds the car (``hold_accel_mps2``); it pulls away on its own
only when the lead departs within ``auto_resume_s``, else on RESUME or the accelerator
(ISO 15622 full-speed-range ACC).
"""

from __future__ import annotations

import math

from ecu.controller import RoadParams
from ecu.signals import cycle_value


@cycle_value
class RoadMemory:
    """What the control law remembers about the road between cycles: the last valid radar gap
    (m) and relative speed (m/s); times since a lead was valid and since the last target switch
    (s, inf: never); time standing while ACTIVE (s, < 0: moving); ``go``: pull away now allowed."""

    last_gap_m: float = math.nan
    last_rel_mps: float = 0.0
    no_lead_s: float = math.inf
    since_switch_s: float = math.inf
    standstill_s: float = -1.0
    go: bool = False


def road_update(
    params: RoadParams,
    mem: RoadMemory,
    *,
    lead_valid: bool,
    gap_m: float,
    rel_speed_mps: float,
    v_mps: float,
    dt_s: float,
    active: bool,
    resume: bool,
) -> tuple[RoadMemory, bool]:
    """The road memory after one cycle of ``dt_s`` and whether the target switched (pure)."""
    switched = False
    if lead_valid:
        if mem.no_lead_s >= params.reacquire_s and mem.no_lead_s < math.inf:
            switched = True  # a lead after a free road (or a long loss) is a new target
        elif mem.no_lead_s < math.inf and math.isfinite(mem.last_gap_m):
            expected = mem.last_gap_m + mem.last_rel_mps * (mem.no_lead_s + dt_s)
            switched = abs(gap_m - expected) > params.switch_jump_m
        no_lead, last_gap, last_rel = 0.0, gap_m, rel_speed_mps
    else:
        no_lead = mem.no_lead_s + dt_s
        last_gap, last_rel = mem.last_gap_m, mem.last_rel_mps
    since = 0.0 if switched else mem.since_switch_s + dt_s
    standing = active and v_mps < params.standstill_mps
    still = mem.standstill_s + dt_s if standing and mem.standstill_s >= 0.0 else 0.0
    still = still if standing else -1.0
    go = standing and (mem.go or resume)
    if standing and not go and still <= params.auto_resume_s:
        go = lead_valid and rel_speed_mps > params.depart_rel_mps
    new = RoadMemory(last_gap, last_rel, no_lead, since, still, go)
    return new, switched


def road_limit(
    params: RoadParams, mem: RoadMemory, target_mps2: float, prev_mps2: float, lead_valid: bool
) -> float:
    """The request after the road rules (pure): at most ``prev_mps2`` while a lead lost less
    than ``lead_loss_hold_s`` ago is missing; at most ``hold_accel_mps2`` while standing
    without a go (``mem`` is this cycle's, from :func:`road_update`)."""
    target = target_mps2
    if not lead_valid and mem.no_lead_s < params.lead_loss_hold_s:
        target = prev_mps2 if target > prev_mps2 else target  # coast through the dropout
    if mem.standstill_s >= 0.0 and not mem.go:
        hold = params.hold_accel_mps2
        target = hold if target > hold else target
    return target
