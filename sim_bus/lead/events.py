"""Road scenarios beyond one always-present lead: cut-in, cut-out, lead loss, stop-and-go.

A road scenario is a :class:`~sim_bus.lead.profile.LeadProfile` (the flow's speed, 10 Hz) plus
:class:`~sim_bus.lead.profile.LeadEvent` s that change which vehicle the radar tracks
(:class:`sim_bus.world.World` plays them; the radar reports no lead for ``dropout_s``).
Parameters, sources and assumptions: docs/sim.md, "Road scenarios" (cut-in time gap
log-normal, median 0.9 s: Waymo Open Motion Dataset, Alhuraish et al. 2026; a revealed
vehicle never closer than a 2-m/s² stop needs; lead loss free for 25-45 s; stop-and-go
stands 1-20 s). Every builder is a pure function of its seed.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from sim_bus.errors import ScenarioError
from sim_bus.lead.profile import DT_S, LeadEvent, LeadProfile
from sim_bus.lead.scenarios import GeneratorConfig, bound_filter, random_speed_sequence, synthesize

#: the road scenarios of ``pacc drive --scenario`` (and "C", the study's mixed traffic)
ROAD_SCENARIOS: tuple[str, ...] = ("cutin", "cutout", "leadloss", "stopgo", "C")
#: the cut-in gap's floor, m, and the gap the cutter leaves to the old lead at least, m
CUT_IN_MIN_GAP_M = 3.0
CUT_IN_ROOM_M = 5.0
#: a revealed vehicle is never closer than a stop at this deceleration needs, m/s²
REVEAL_DESIGN_DECEL_MPS2 = 2.0


def cut_in_gap_m(event: LeadEvent, v_ego_mps: float, current_gap_m: float) -> float | None:
    """The gap (m) a cut-in takes ahead of an ego car at ``v_ego_mps`` following at
    ``current_gap_m`` (m), leaving ``CUT_IN_ROOM_M`` to the old lead; None if it does not fit."""
    gap = event.gap_m + event.gap_thw_s * max(v_ego_mps, 0.0)
    room = current_gap_m - CUT_IN_ROOM_M
    gap = min(gap, room)
    return gap if gap >= CUT_IN_MIN_GAP_M else None


def reveal_gap_m(event: LeadEvent, v_ego_mps: float, current_gap_m: float) -> float:
    """The gap (m) to the vehicle a cut-out reveals: ``gap_m`` beyond the old lead, never
    closer than matching its speed at ``REVEAL_DESIGN_DECEL_MPS2`` needs + 3 m."""
    closing = max(v_ego_mps - event.v_mps, 0.0)
    need = closing * closing / (2.0 * REVEAL_DESIGN_DECEL_MPS2) + 3.0
    return max(current_gap_m + event.gap_m, need)


def _with(profile: LeadProfile, events: list[LeadEvent], set_speed: float | None) -> LeadProfile:
    ordered = tuple(sorted(events, key=lambda e: e.t_s))
    return replace(profile, events=ordered, set_speed_mps=set_speed)


def _cut_in(rng: np.random.Generator, t_s: float) -> LeadEvent:
    thw = float(np.clip(0.9 * math.exp(0.35 * rng.standard_normal()), 0.4, 2.0))
    dv = float(np.clip(1.0 + 1.5 * rng.standard_normal(), -3.0, 4.0))
    return LeadEvent(
        t_s,
        "cut_in",
        gap_m=2.0,
        gap_thw_s=round(thw, 3),
        v_mps=round(dv, 3),
        v_relative=True,
        hold_s=float(rng.uniform(1.0, 4.0)),
        dropout_s=float(rng.uniform(0.1, 0.3)),
    )


def _cut_out(rng: np.random.Generator, t_s: float, flow_mps: float) -> LeadEvent:
    stopped = bool(rng.random() < 0.5)
    v = 0.0 if stopped else float(rng.uniform(0.3, 0.7)) * flow_mps
    return LeadEvent(
        t_s,
        "cut_out",
        gap_m=float(rng.uniform(15.0, 40.0)),
        v_mps=round(v, 3),
        hold_s=float(rng.uniform(8.0, 15.0)) if stopped else float(rng.uniform(5.0, 10.0)),
        dropout_s=float(rng.uniform(0.1, 0.3)),
    )


def _loss_and_appear(rng: np.random.Generator, t_s: float) -> list[LeadEvent]:
    return [
        LeadEvent(t_s, "lead_loss", dropout_s=0.0),
        LeadEvent(
            t_s + float(rng.uniform(25.0, 45.0)),  # a free road for 25-45 s
            "lead_appear",
            gap_m=float(rng.uniform(100.0, 150.0)),
            v_mps=float(rng.uniform(14.0, 20.0)),
            hold_s=float(rng.uniform(5.0, 15.0)),
            dropout_s=0.0,
        ),
    ]


def stop_and_go_profile(seed: int, duration_s: float = 180.0, name: str = "stopgo") -> LeadProfile:
    """A lead that cruises (8-14 m/s), brakes (1-2.5 m/s²) to a stand (1-20 s) and pulls away
    (1-1.8 m/s²), again and again; 10 Hz, bound-filtered like the generator's."""
    rng = np.random.default_rng([seed, 0x73746F70])
    n = int(round(duration_s / DT_S)) + 1
    v = np.empty(n)
    i, speed = 0, 0.0
    holds = [float(rng.uniform(1.0, 2.5)), float(rng.uniform(6.0, 20.0))]  # short, then long
    k = 0
    while i < n:
        cruise = float(rng.uniform(8.0, 14.0))
        up = float(rng.uniform(1.0, 1.8))
        down = float(rng.uniform(1.0, 2.5))
        hold = holds[k % 2] if k < 2 else float(rng.uniform(1.0, 20.0))
        k += 1
        # pull away and cruise, then brake and stand
        phases = [(cruise, up, float(rng.uniform(15.0, 30.0))), (0.0, down, hold)]
        for target, rate, dwell in phases:
            d = rate * DT_S
            while i < n and abs(speed - target) > 1e-9:
                speed = min(speed + d, target) if target > speed else max(speed - d, target)
                v[i] = speed
                i += 1
            for _ in range(int(round(dwell / DT_S))):
                if i >= n:
                    break
                v[i] = speed
                i += 1
    v[0] = 0.0
    cfg = GeneratorConfig(accel_max_mps2=2.0, decel_max_mps2=3.0, smooth_s=1.0)
    smooth = bound_filter(v, cfg)
    smooth[smooth < 0.05] = 0.0
    return LeadProfile(name, np.arange(n) * DT_S, smooth, (), v, set_speed_mps=20.0)


def road_profile(kind: str, seed: int, duration_s: float | None = None) -> LeadProfile:
    """The road scenario ``kind`` (:data:`ROAD_SCENARIOS`) drawn with ``seed``, ``duration_s``
    long (default 180 s; "C" 300 s); ScenarioError for an unknown kind."""
    if kind not in ROAD_SCENARIOS:
        raise ScenarioError(f"unknown road scenario {kind!r}: one of {ROAD_SCENARIOS}")
    if not seed >= 0:
        raise ScenarioError(f"a seed is an integer >= 0, got {seed}")
    rng = np.random.default_rng([seed, ROAD_SCENARIOS.index(kind), 0x726F6164])
    dur = duration_s if duration_s is not None else (300.0 if kind == "C" else 180.0)
    if kind == "stopgo":
        return stop_and_go_profile(seed, dur)
    flow_seed = int(rng.integers(2**31))
    if kind == "C":
        return _mixed(rng, flow_seed, dur)
    flow = float(rng.uniform(15.0, 27.0)) if kind != "cutout" else float(rng.uniform(12.0, 22.0))
    cfg = GeneratorConfig(duration_s=dur)  # a flow of real segments around one speed
    base = synthesize(np.full(cfg.n_segments, flow), flow_seed, kind, cfg)
    grid = np.arange(30.0, dur - 20.0, 45.0)
    times = grid + rng.uniform(-5.0, 5.0, len(grid))
    if kind == "cutin":
        events = [_cut_in(rng, float(t)) for t in times]
    elif kind == "cutout":
        events = [_cut_out(rng, float(t), flow) for t in times[::2]]
    else:  # leadloss
        events = _loss_and_appear(rng, float(times[0]))
        if dur >= 150.0:
            events += _loss_and_appear(rng, float(times[0]) + 80.0)
    return _with(base, events, 30.0 if kind == "leadloss" else None)


def _mixed(rng: np.random.Generator, flow_seed: int, duration_s: float) -> LeadProfile:
    """Scenario C: the paper's unseen-B kind of flow (5-30 m/s) with three cut-ins, a
    cut-out revealing a slower vehicle, and a lead loss followed by a new lead."""
    cfg = GeneratorConfig(duration_s=duration_s)
    seq = random_speed_sequence(5.0, 30.0, cfg.n_segments, rng, max_step_mps=6.0)
    base = synthesize(seq, flow_seed, "C", cfg)
    frac = duration_s / 300.0
    events = [_cut_in(rng, t * frac) for t in (40.0, 130.0, 250.0)]
    flow_at = float(np.interp(90.0 * frac, base.t_s, base.v_lead_mps))
    cut = _cut_out(rng, 90.0 * frac, flow_at)
    events.append(LeadEvent(cut.t_s, "cut_out", cut.gap_m, 0.0, 0.5 * flow_at, False, cut.hold_s))
    events += _loss_and_appear(rng, 180.0 * frac)
    return _with(base, events, 32.0)
