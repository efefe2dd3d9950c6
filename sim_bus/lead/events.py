"""Road scenarios beyond one always-present lead: cut-in, cut-out, lead loss, stop-and-go.

A road scenario is a :class:`~sim_bus.lead.scenarios.LeadProfile` (the traffic flow's speed, 10 Hz)
plus :class:`LeadEvent` s that change *which* vehicle the radar tracks. :class:`sim_bus.world.World`
plays them: until the first event the lead drives the profile exactly (so a profile without
events is the paper's car following, unchanged); after an event the new lead starts at a gap
and speed set relative to the ego car at that instant, holds its speed for ``hold_s`` and then
rejoins the flow (tracks the profile's speed with a 2-s lag, accelerations within
-3..+1.5 m/s²). The radar shows a target switch as a real sensor does: ``LeadValid = 0`` for
``dropout_s`` (the new track is confirmed), then the new target's gap, relative speed and
acceleration; with no vehicle in sight ``LeadValid`` stays 0.

Parameters (docs/sim.md, "Road scenarios", gives the sources; where the literature is thin
the value is an assumption and says so):

- cut-in gap: time gap to the ego car log-normal, median 0.9 s (Waymo Open Motion Dataset,
  human-driven targets: median accepted gap 9.6 m at 37.7 km/h, Alhuraish et al. 2026),
  sd 0.35 in log, clipped 0.4-2.0 s, plus 2 m; relative speed of the cutter N(+1, 1.5) m/s
  clipped -3..+4 (thin: a cutter usually merges at or above the lane's speed, the slower ones
  are the hard case);
- cut-out: the revealed vehicle is stopped (half the cut-outs) or at 30-70 % of the flow's
  speed, 15-40 m beyond the old lead and never closer than a 2-m/s² stop needs (ISO 15622
  does not require an ACC to react to stationary objects: one revealed closer is the
  driver's and AEB's);
- lead loss: the lead leaves (an exit), the road is free for 25-45 s (cruise at the set
  speed), then a slower vehicle (14-20 m/s) appears 100-150 m ahead;
- stop-and-go: cruise at 8-14 m/s, brake at 1-2.5 m/s² to a standstill, stand 1-20 s (short
  stops resume on their own in a full-speed-range ACC, long ones need the driver's RESUME),
  pull away at 1-1.8 m/s² (assumptions: the shipped OpenACC traces stop only at their ends).

Every builder is a pure function of its seed.
"""

from __future__ import annotations

import math

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
    """The gap (m) a cut-in takes in front of an ego car at ``v_ego_mps`` following at
    ``current_gap_m``: the drawn gap, at most what leaves ``CUT_IN_ROOM_M`` to the old lead,
    at least ``CUT_IN_MIN_GAP_M``; None when the cutter does not fit."""
    gap = event.gap_m + event.gap_thw_s * max(v_ego_mps, 0.0)
    room = current_gap_m - CUT_IN_ROOM_M
    gap = min(gap, room)
    return gap if gap >= CUT_IN_MIN_GAP_M else None


def reveal_gap_m(event: LeadEvent, v_ego_mps: float, current_gap_m: float) -> float:
    """The gap (m) to the vehicle a cut-out reveals: ``gap_m`` beyond the old lead, and never
    closer than stopping (matching its speed) at ``REVEAL_DESIGN_DECEL_MPS2`` needs + 3 m."""
    closing = max(v_ego_mps - event.v_mps, 0.0)
    need = closing * closing / (2.0 * REVEAL_DESIGN_DECEL_MPS2) + 3.0
    return max(current_gap_m + event.gap_m, need)


# -- builders -------------------------------------------------------------------------------


def _flow(speed_mps: float, duration_s: float, seed: int, name: str) -> LeadProfile:
    """A flow of real leader segments around one average speed (the paper's generator)."""
    cfg = GeneratorConfig(duration_s=duration_s)
    n_seg = int(math.ceil(duration_s / cfg.segment_s)) + 1
    return synthesize(np.full(n_seg, speed_mps), seed, name, cfg)


def _with(profile: LeadProfile, events: list[LeadEvent], set_speed: float | None) -> LeadProfile:
    return LeadProfile(
        profile.name,
        profile.t_s,
        profile.v_lead_mps,
        profile.segments,
        profile.raw_v_mps,
        events=tuple(sorted(events, key=lambda e: e.t_s)),
        set_speed_mps=set_speed,
    )


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
    free = float(rng.uniform(25.0, 45.0))
    return [
        LeadEvent(t_s, "lead_loss", dropout_s=0.0),
        LeadEvent(
            t_s + free,
            "lead_appear",
            gap_m=float(rng.uniform(100.0, 150.0)),
            v_mps=float(rng.uniform(14.0, 20.0)),
            hold_s=float(rng.uniform(5.0, 15.0)),
            dropout_s=0.0,
        ),
    ]


def stop_and_go_profile(seed: int, duration_s: float = 180.0, name: str = "stopgo") -> LeadProfile:
    """A lead that cruises, brakes to a standstill, stands and pulls away, again and again
    (parameters in the module docstring); 10 Hz, bound-filtered like the generator's."""
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
        phases = [
            (cruise, up, float(rng.uniform(15.0, 30.0))),  # pull away and cruise
            (0.0, down, hold),  # brake and stand
        ]
        for target, rate, dwell in phases:
            while i < n and abs(speed - target) > 1e-9:
                speed = (
                    min(speed + rate * DT_S, target)
                    if target > speed
                    else max(speed - rate * DT_S, target)
                )
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
    """The road scenario ``kind`` (one of :data:`ROAD_SCENARIOS`) drawn with ``seed``.

    ``duration_s``: length (default 180 s; "C": 300 s, the study's length). Pure function of
    (kind, seed, duration, shipped data); ScenarioError for an unknown kind.
    """
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
    base = _flow(flow, dur, flow_seed, kind)
    times = np.arange(30.0, dur - 20.0, 45.0) + rng.uniform(
        -5.0, 5.0, len(np.arange(30.0, dur - 20.0, 45.0))
    )
    events: list[LeadEvent] = []
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
    n_seg = int(math.ceil(duration_s / cfg.segment_s)) + 1
    seq = random_speed_sequence(5.0, 30.0, n_seg, rng, max_step_mps=6.0)
    base = synthesize(seq, flow_seed, "C", cfg)
    frac = duration_s / 300.0
    events = [_cut_in(rng, t * frac) for t in (40.0, 130.0, 250.0)]
    flow_at = float(np.interp(90.0 * frac, base.t_s, base.v_lead_mps))
    cut = _cut_out(rng, 90.0 * frac, flow_at)
    events.append(LeadEvent(cut.t_s, "cut_out", cut.gap_m, 0.0, 0.5 * flow_at, False, cut.hold_s))
    events += _loss_and_appear(rng, 180.0 * frac)
    return _with(base, events, 32.0)


__all__ = [
    "ROAD_SCENARIOS",
    "cut_in_gap_m",
    "reveal_gap_m",
    "road_profile",
    "stop_and_go_profile",
]
