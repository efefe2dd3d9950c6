"""Longitudinal controller: PID on the gap error, cruise at the set speed, output envelope.

The gap law is eq. (5)-(6) of the paper with the signs of docs/paper-notes.md::

    e     = g - DGPT(v)                       (m, positive when the gap is too large)
    e_dot = (v_f - v) - DGPT'(v) * a          (m/s; DGPT' in s, a the measured ego accel)
    a_gap = Kp(v) * e + Ki(v) * I + Kd(v) * e_dot + K_lead * a_f

where ``v_f - v`` is the radar's relative speed (the relative-speed term) and ``a_f`` the
lead acceleration when the radar reports one. Without a valid lead the car cruises:
``a_cruise = K_cruise * (v_set - v)``; with a lead the command is ``min(a_gap, a_cruise)`` so
the set speed is never exceeded. Gains are (breakpoint, value) tables over ego speed.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass, field

from ecu import EcuError, finite_fields


class ControllerError(EcuError):
    """Invalid controller parameters."""


Table = tuple[tuple[float, ...], tuple[float, ...]]

#: Production ACC acceleration limits (ISO 15622), m/s^2: the envelope may only narrow them.
ACCEL_MIN_MPS2 = -3.5
ACCEL_MAX_MPS2 = 2.0
#: smallest gap margin (m) above the floor reckoned with by :func:`closing_limit_mps2`
MIN_MARGIN_M = 0.5

# The control cycle writes ``max(a, b)`` out as ``b if a < b else a`` (``min`` likewise): the
# builtins' results, NaN and signed zeros included, at a sixth of the cost of the call.


def interp(x: float, table: Table) -> float:
    """Piecewise-linear lookup in a (breakpoints, values) table, ends held (scalar, fast)."""
    bp, val = table
    if x <= bp[0]:
        return val[0]
    if not x < bp[-1]:  # beyond the last breakpoint, or NaN
        return val[-1]
    i = bisect_right(bp, x)  # the first breakpoint above x
    b0, v0 = bp[i - 1], val[i - 1]
    f = (x - b0) / (bp[i] - b0)
    return v0 + f * (val[i] - v0)


def _check_table(name: str, table: Table) -> None:
    bp, val = table
    if len(bp) == 0 or len(bp) != len(val):
        raise ControllerError(f"{name}: breakpoints and values must be non-empty, same length")
    if any(b2 <= b1 for b1, b2 in zip(bp, bp[1:], strict=False)):
        raise ControllerError(f"{name}: breakpoints must increase strictly")
    if not all(math.isfinite(x) and x >= 0.0 for x in (*bp, *val)):
        raise ControllerError(f"{name}: values must be finite and >= 0")


@dataclass(frozen=True)
class RoadParams:
    """Target switches, lead loss and standstill (units in the names)."""

    #: a gap change this much beyond what the relative speed explains in a cycle: a new target
    switch_jump_m: float = 3.0
    reacquire_s: float = 1.0  # a lead valid again after this long without one is new
    lead_loss_hold_s: float = 1.0  # this long after the lead is lost the request does not rise
    standstill_mps: float = 0.1  # below this speed the car stands
    hold_accel_mps2: float = -1.0  # the request that holds a standing car (< 0)
    auto_resume_s: float = 3.0  # a stop shorter than this resumes when the lead departs
    depart_rel_mps: float = 0.5  # the lead departs when it pulls away faster than this
    stop_lead_mps: float = 3.0  # behind a lead slower than this: stop at the standstill gap
    lead_stop_horizon_s: float = 4.0  # a braking lead standing within this time: stop behind

    def __post_init__(self) -> None:
        names = "switch_jump_m reacquire_s lead_loss_hold_s standstill_mps auto_resume_s"
        if not finite_fields(self, names + " depart_rel_mps stop_lead_mps lead_stop_horizon_s"):
            raise ControllerError(f"road parameters must be finite and >= 0: {self}")
        if not ACCEL_MIN_MPS2 <= self.hold_accel_mps2 < 0.0:
            raise ControllerError("hold_accel_mps2 must lie in [-3.5, 0)")


@dataclass(frozen=True)
class ControllerParams:
    """Gains as (breakpoints m/s, values) tables and the output envelope (units in the names;
    the envelope within -3.5 ... +2.0 m/s^2)."""

    kp: Table = ((0.0, 10.0, 20.0, 30.0), (0.25, 0.2, 0.15, 0.12))  # on the gap error, 1/s^2
    ki: Table = ((0.0, 30.0), (0.01, 0.01))  # on its integral, 1/s^3
    kd: Table = ((0.0, 10.0, 30.0), (0.8, 0.75, 0.7))  # on its rate (relative speed), 1/s
    k_lead_accel: float = 0.5  # feed-forward of the lead acceleration
    k_cruise_per_s: float = 0.3  # speed-error gain of the cruise law
    integral_limit_m_s: float = 20.0  # clamp of the gap-error integral
    accel_min_mps2: float = -3.5
    accel_max_mps2: float = 2.0
    jerk_max_mps3: float = 2.5  # rate limit of the request in normal operation
    emergency_ttc_s: float = 3.0  # time-to-collision below which the emergency exception applies
    emergency_jerk_mps3: float = 10.0  # rate limit of a *decreasing* request in an emergency
    road: RoadParams = field(default_factory=RoadParams)

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "kd"):
            _check_table(name, getattr(self, name))
        names = "k_lead_accel k_cruise_per_s integral_limit_m_s jerk_max_mps3 emergency_ttc_s"
        if not finite_fields(self, names + " emergency_jerk_mps3"):
            raise ControllerError(f"controller parameters must be finite and >= 0: {self}")
        if not self.accel_min_mps2 < 0.0 < self.accel_max_mps2:
            raise ControllerError("need accel_min_mps2 < 0 < accel_max_mps2")
        if self.accel_min_mps2 < ACCEL_MIN_MPS2 or self.accel_max_mps2 > ACCEL_MAX_MPS2:
            raise ControllerError(
                f"acceleration envelope [{self.accel_min_mps2:g}, {self.accel_max_mps2:g}] "
                f"m/s^2 exceeds the production limits [{ACCEL_MIN_MPS2:g}, {ACCEL_MAX_MPS2:g}]"
            )
        if self.emergency_jerk_mps3 < self.jerk_max_mps3:
            raise ControllerError("emergency_jerk_mps3 must be >= jerk_max_mps3")


@dataclass(frozen=True, slots=True)
class ControlInput:
    """What the controller sees in one cycle (all finite; units in the names; ``gap_m``
    ignored without a lead; ``rel_speed_mps`` lead minus ego; ``desired_gap_slope_s`` dDGPT/dv)."""

    v_mps: float
    a_mps2: float
    set_speed_mps: float
    lead_valid: bool
    gap_m: float
    rel_speed_mps: float
    lead_accel_mps2: float
    desired_gap_m: float
    desired_gap_slope_s: float


def time_to_collision_s(lead_valid: bool, gap_m: float, rel_speed_mps: float) -> float:
    """Gap over closing speed, s; ``inf`` without a lead or when not closing."""
    if not lead_valid or rel_speed_mps >= 0.0:
        return math.inf
    return (0.0 if gap_m < 0.0 else gap_m) / -rel_speed_mps


def closing_limit_mps2(
    gap_m: float, rel_speed_mps: float, lead_accel_mps2: float, floor_gap_m: float
) -> float:
    """The constant acceleration (m/s^2) that matches the lead's speed just as the gap shrinks
    to ``floor_gap_m``: ``a_f - dv^2 / (2 (g - g_floor))`` with ``dv`` the closing speed
    (the deceleration rate to avoid a crash, measured against the floor instead of contact).
    ``inf`` when not closing; the margin ``g - g_floor`` counts as at least ``MIN_MARGIN_M``."""
    if rel_speed_mps >= 0.0:
        return math.inf
    margin = gap_m - floor_gap_m
    margin = MIN_MARGIN_M if margin < MIN_MARGIN_M else margin
    return lead_accel_mps2 - rel_speed_mps * rel_speed_mps / (2.0 * margin)


def stopping_limit_mps2(
    v_mps: float, gap_m: float, v_lead_mps: float, lead_accel_mps2: float, stop_gap_m: float
) -> float:
    """The constant acceleration (m/s^2) that stops the car ``stop_gap_m`` behind the point
    where a braking lead (``lead_accel_mps2`` < 0) comes to rest: ``-v^2 / (2 d)`` with
    ``d = g + v_f^2 / (2 |a_f|) - stop_gap`` (at least ``MIN_MARGIN_M``); ``inf`` when the
    lead is not braking or the car stands."""
    if lead_accel_mps2 >= -0.1 or v_mps <= 0.0:
        return math.inf
    lead_stop = (0.0 if v_lead_mps < 0.0 else v_lead_mps) ** 2 / (2.0 * -lead_accel_mps2)
    room = gap_m + lead_stop - stop_gap_m
    room = MIN_MARGIN_M if room < MIN_MARGIN_M else room
    return -(v_mps * v_mps) / (2.0 * room)


def desired_accel(
    params: ControllerParams,
    obs: ControlInput,
    integral_m_s: float,
    dt_s: float,
    *,
    integrate: bool,
) -> tuple[float, float]:
    """The unlimited acceleration request and the next integral: ``(accel_mps2, integral_m_s)``."""
    v = obs.v_mps
    a_cruise = params.k_cruise_per_s * (obs.set_speed_mps - v)
    if not obs.lead_valid:
        return a_cruise, integral_m_s
    e = obs.gap_m - obs.desired_gap_m
    e_dot = obs.rel_speed_mps - obs.desired_gap_slope_s * obs.a_mps2
    kp = interp(v, params.kp)
    ki = interp(v, params.ki)
    kd = interp(v, params.kd)
    a_gap = kp * e + ki * integral_m_s + kd * e_dot + params.k_lead_accel * obs.lead_accel_mps2
    following = a_gap <= a_cruise
    at_upper = a_gap >= params.accel_max_mps2 and e > 0.0
    at_lower = a_gap <= params.accel_min_mps2 and e < 0.0
    if integrate and following and not (at_upper or at_lower):
        lim = params.integral_limit_m_s
        integral_m_s = integral_m_s + e * dt_s
        integral_m_s = -lim if integral_m_s < -lim else integral_m_s
        integral_m_s = lim if integral_m_s > lim else integral_m_s
    return (a_cruise if a_gap > a_cruise else a_gap), integral_m_s


def limit_command(
    params: ControllerParams, prev_mps2: float, target_mps2: float, dt_s: float, *, emergency: bool
) -> float:
    """Clip ``target_mps2`` into the envelope and rate-limit it from ``prev_mps2``."""
    if not math.isfinite(target_mps2):
        target_mps2 = 0.0
    lo, hi = params.accel_min_mps2, params.accel_max_mps2
    target = lo if target_mps2 < lo else target_mps2
    target = hi if target > hi else target
    dt = 0.0 if dt_s < 0.0 else dt_s
    up = params.jerk_max_mps3 * dt
    down = (params.emergency_jerk_mps3 if emergency else params.jerk_max_mps3) * dt
    fall, rise = prev_mps2 - down, prev_mps2 + up
    out = fall if target < fall else target
    out = rise if out > rise else out
    out = lo if out < lo else out
    return hi if out > hi else out
