"""pacc test plug-ins: the smallest methods that do something, one of each interface.

- ``test-timegap`` controller: ``a = k_gap (g - g_des) + k_rel dv``, capped by cruise;
- ``test-halfstep`` adaptation: at a brake or accelerator release with a lead, every bin's
  time gap moves half way toward the release's time gap;
- ``test-timegap`` learner: one time gap for all speeds, the median of the steady samples.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from dbc.vocab.dgpt import Dgpt, SafetyBounds, predefined
from dbc.vocab.triplog import Trip
from ecu.adaptation import Decision, Reason, TakeoverSummary
from ecu.controller import ControlInput


class TimeGapController:
    """A PD law on the gap error (no integral; ``memory`` passes through untouched)."""

    def __init__(self, k_gap: float = 0.2, k_rel: float = 0.7, k_cruise: float = 0.3) -> None:
        self.k_gap, self.k_rel, self.k_cruise = k_gap, k_rel, k_cruise

    def desired_accel(self, obs: ControlInput, memory: float, dt_s: float) -> tuple[float, float]:
        cruise = self.k_cruise * (obs.set_speed_mps - obs.v_mps)
        if not obs.lead_valid:
            return cruise, memory
        gap_law = self.k_gap * (obs.gap_m - obs.desired_gap_m) + self.k_rel * obs.rel_speed_mps
        return min(gap_law, cruise), memory


class HalfStepAdaptation:
    """Half way toward the release time gap at every speed."""

    def __init__(self, fraction: float = 0.5, min_takeover_s: float = 1.0) -> None:
        self.fraction, self.min_takeover_s = fraction, min_takeover_s

    def update(
        self,
        table: Dgpt,
        takeover: TakeoverSummary,
        *,
        bounds: SafetyBounds,
        short_run: bool,
        created_utc: str,
    ) -> tuple[Dgpt | None, Decision]:
        if not takeover.lead_valid or not np.isfinite(takeover.gap_m):
            return None, Decision(applied=False, reason=Reason.NO_LEAD)
        if takeover.duration_s <= self.min_takeover_s:
            return None, Decision(applied=False, reason=Reason.SHORT_TAKEOVER)
        v = max(takeover.v_mps, 5.0)
        d0 = bounds.standstill_m
        h_obs = (takeover.gap_m - d0) / v
        speed = table.speed_mps
        h_tab = (table.gap_m - d0) / np.maximum(speed, 5.0)
        h_new = h_tab + self.fraction * (h_obs - h_tab)
        gap = d0 + h_new * np.maximum(speed, 5.0)
        new = table.with_gaps(gap, "adapted", created_utc=created_utc)
        centre = int(np.argmin(np.abs(speed - takeover.v_mps)))
        return new, Decision(
            applied=True,
            reason=Reason.APPLIED,
            bin_index=centre,
            g_desire_m=takeover.gap_m,
            delta_m=float(new.gap_m[centre] - table.gap_m[centre]),
        )


class TimeGapLearner:
    """One time gap: the median of ``(g - d0) / v`` over steady samples above 5 m/s."""

    def __init__(self, standstill_m: float = 4.0, **_: Any) -> None:
        self.standstill_m = standstill_m

    def learn(self, trips: Sequence[Trip], *, driver_id: str, seed: int) -> Dgpt:
        h = []
        for t in trips:
            steady = (
                np.isfinite(t.gap_m)
                & (np.abs(t.v_lead_mps - t.v_mps) < 0.5)
                & (np.abs(t.a_mps2) < 0.3)
                & (t.v_mps > 5.0)
            )
            h.append((t.gap_m[steady] - self.standstill_m) / t.v_mps[steady])
        pooled = np.concatenate(h) if h else np.zeros(0)
        headway = float(np.median(pooled)) if pooled.size else 1.5
        table = predefined(
            min(max(headway, 0.8), 3.0),
            standstill_m=self.standstill_m,
            driver_id=driver_id,
            created_utc="2000-01-01T00:00:00Z",
        )
        return Dgpt(
            speed_mps=table.speed_mps,
            gap_m=table.gap_m,
            version=1,
            driver_id=driver_id,
            source="irl",
            created_utc=table.created_utc,
            meta={
                "method": "test-timegap",
                "covered": [True] * table.speed_mps.size,
                "headway_s": headway,
            },
        )
