"""IDM+ car following (Schakel et al., 2010): a synthetic driver's manual following law.

``a = a_max·min(1 − (v/v0)⁴, 1 − (s*/s)²)`` with ``s* = g*(v) + v·(v − v_f)/(2√(a_max·b))``
around the driver's own preferred gap g*(v); its equilibrium gap in car following is exactly
g*(v). :class:`sim_bus.behaviour.DriverAgent` calls :func:`idm_plus_accel` every step, by hand
and while it presses a pedal under the ACC, and looks its time headway up with
:func:`interp_float` (``np.interp`` for one float, without numpy's per-call cost).
Speeds in m/s, gaps in m, accelerations in m/s².
"""

from __future__ import annotations

import math
from bisect import bisect_right

from sim_bus.drivers import DriverParams

#: the hardest deceleration a driver asks for (IDM+'s lower limit; a full brake), m/s²
DECEL_LIMIT_MPS2 = 8.0


def interp_float(x: float, xp: tuple[float, ...], fp: tuple[float, ...]) -> float:
    """``float(np.interp(x, xp, fp))`` for one float, in numpy's own arithmetic (NaN
    fallbacks, ends held), without its per-call table conversion (1.5 us a call)."""
    if len(xp) == 1:
        return fp[0]
    if math.isnan(x):
        return x
    if x < xp[0]:
        return fp[0]
    if x > xp[-1]:
        return fp[-1]
    j = bisect_right(xp, x) - 1
    if j == len(xp) - 1 or xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    out = slope * (x - xp[j]) + fp[j]
    if math.isnan(out):  # numpy retries from the segment's other end
        out = slope * (x - xp[j + 1]) + fp[j + 1]
        if math.isnan(out) and fp[j] == fp[j + 1]:
            out = fp[j]
    return out


def idm_plus_accel(
    v_mps: float, v_lead_mps: float, gap_m: float, pref_gap_m: float, p: DriverParams
) -> float:
    """IDM+ acceleration (m/s²) around the preferred gap, limited to [−8, a_max] (min and
    max written out: the builtins' results, NaN included, at a sixth of a call's cost)."""
    s_star = pref_gap_m + v_mps * (v_mps - v_lead_mps) / (
        2.0 * math.sqrt(p.accel_max_mps2 * p.decel_comfort_mps2)
    )
    half = p.standstill_m * 0.5
    s_star = half if s_star < half else s_star
    s = 0.1 if gap_m < 0.1 else gap_m
    free = 1.0 - (v_mps / p.desired_speed_mps) ** 4
    follow = 1.0 - (s_star / s) ** 2
    a = p.accel_max_mps2 * (follow if free > follow else free)
    a = -DECEL_LIMIT_MPS2 if a < -DECEL_LIMIT_MPS2 else a
    return p.accel_max_mps2 if a > p.accel_max_mps2 else a
