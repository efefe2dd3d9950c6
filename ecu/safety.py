"""An independent check of every ACC command frame before it leaves the ECU.

As opendbc's safety layer, it shares no code with :mod:`ecu.controller` (the vehicle's limits
are written down again here on purpose). On each command's values, in order: a non-finite
request goes out as 0 m/s^2, inactive; a request is active only in ACTIVE (in FAULT only
while ramping toward zero); the envelope [-3.5, +2.0] m/s^2 (ISO 15622); jerk at most
+2.5 / -10 m/s^3. Interventions are counted by rule (:attr:`CommandSafety.stopped`); an
output it does not change passes as the same object (frames bit-identical without it).
"""

from __future__ import annotations

import logging
import math
from collections import Counter
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from ecu.signals import cycle_value

if TYPE_CHECKING:
    from ecu.signals import NodeOutputs

log = logging.getLogger(__name__)

#: the frame's ``acc_state`` codes this module relies on (the DBC's AccState values)
STATE_ACTIVE = 2
STATE_FAULT = 4

#: rule names, as counted in :attr:`CommandSafety.stopped`
NON_FINITE, NOT_ENGAGED, ENVELOPE, JERK = "non_finite", "not_engaged", "envelope", "jerk"
RULES = (NON_FINITE, NOT_ENGAGED, ENVELOPE, JERK)


@dataclass(frozen=True, slots=True)
class SafetyLimits:
    """What may leave the ECU: the acceleration envelope (m/s^2), the fastest rise and fall of an
    active request (m/s^3), the slack on every comparison (m/s^2, float rounding)."""

    accel_min_mps2: float = -3.5
    accel_max_mps2: float = 2.0
    jerk_rise_mps3: float = 2.5
    jerk_fall_mps3: float = 10.0
    tolerance_mps2: float = 1e-6


@cycle_value
class Verdict:
    """The vetted request and the rules that changed it (empty: passed as it came)."""

    accel_mps2: float
    active: bool
    broken: tuple[str, ...]


def vet(
    limits: SafetyLimits,
    accel_mps2: float,
    active: bool,
    acc_state: int,
    prev_mps2: float,
    dt_s: float,
) -> Verdict:
    """Vet one command: ``accel_mps2`` (m/s^2), ``active``, the frame's ``acc_state`` code,
    the last request sent ``prev_mps2`` (m/s^2, finite) and the time since it ``dt_s`` (s,
    >= 0). Pure; see the module docstring for the rules."""
    broken: list[str] = []
    tol = limits.tolerance_mps2
    if not math.isfinite(accel_mps2):
        broken.append(NON_FINITE)
        accel_mps2, active = 0.0, False
    if active and acc_state != STATE_ACTIVE:
        lo, hi = min(prev_mps2, 0.0), max(prev_mps2, 0.0)
        if acc_state != STATE_FAULT:
            broken.append(NOT_ENGAGED)
            active = False
        elif not lo - tol <= accel_mps2 <= hi + tol:
            broken.append(NOT_ENGAGED)
            accel_mps2 = min(max(accel_mps2, lo), hi)
    if not limits.accel_min_mps2 - tol <= accel_mps2 <= limits.accel_max_mps2 + tol:
        broken.append(ENVELOPE)
        accel_mps2 = min(max(accel_mps2, limits.accel_min_mps2), limits.accel_max_mps2)
    if active:
        lo = prev_mps2 - limits.jerk_fall_mps3 * dt_s
        hi = prev_mps2 + limits.jerk_rise_mps3 * dt_s
        if not lo - tol <= accel_mps2 <= hi + tol:
            broken.append(JERK)
            accel_mps2 = min(max(accel_mps2, lo), hi)
    return Verdict(accel_mps2, active, tuple(broken))


class CommandSafety:
    """The check on one ECU's command frames, with its memory (the last request sent)."""

    def __init__(self, limits: SafetyLimits | None = None) -> None:
        self.limits = limits if limits is not None else SafetyLimits()
        #: frames changed, by rule broken (a frame may break several)
        self.stopped: Counter[str] = Counter()
        self._prev_mps2 = 0.0
        self._prev_t_s: float | None = None

    def check(self, out: NodeOutputs, t_s: float) -> NodeOutputs:
        """The outputs whose command frame goes on the bus at ``t_s`` (s): ``out`` itself when
        every rule holds, else a copy with the request corrected (counted in :attr:`stopped`)."""
        dt = 0.0 if self._prev_t_s is None else t_s - self._prev_t_s
        dt = dt if math.isfinite(dt) and dt > 0.0 else 0.0
        accel, active = float(out.accel_request_mps2), bool(out.request_active)
        verdict = vet(self.limits, accel, active, int(out.acc_state), self._prev_mps2, dt)
        self._prev_mps2, self._prev_t_s = verdict.accel_mps2, t_s
        if not verdict.broken:
            return out
        self.stopped.update(verdict.broken)
        log.warning(
            "t=%.2f safety: %s; request %r active %s -> %.3f active %s",
            t_s,
            ", ".join(verdict.broken),
            accel,
            active,
            verdict.accel_mps2,
            verdict.active,
        )
        return replace(out, accel_request_mps2=verdict.accel_mps2, request_active=verdict.active)
