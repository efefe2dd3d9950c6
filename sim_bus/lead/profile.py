"""A lead speed profile and the events that change which vehicle the radar tracks.

- :class:`LeadProfile` — the tracked vehicle's speed over a drive, 10 Hz
  (:mod:`sim_bus.lead.scenarios` builds them from the shipped OpenACC data);
- :class:`LeadEvent` — one change of the tracked vehicle (:mod:`sim_bus.lead.events` builds
  the road scenarios from them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np

from sim_bus.errors import ScenarioError

EventKind = Literal["cut_in", "cut_out", "lead_loss", "lead_appear"]
EVENT_KINDS: tuple[str, ...] = get_args(EventKind)
DT_S = 0.1


@dataclass(frozen=True)
class SegmentRef:
    """Where one piece of a profile comes from: ``scale·source[start:start+length]``."""

    source: str
    start: int
    length: int
    scale: float = 1.0


@dataclass(frozen=True)
class LeadProfile:
    """A lead speed profile: ``t_s``, ``v_lead_mps`` float64 arrays of shape (n,), 10 Hz.

    ``events``: changes of the tracked vehicle (:mod:`sim_bus.lead.events`; none: the lead drives
    the profile throughout, the paper's car following). ``set_speed_mps``: the ACC set speed
    the road calls for (None: the study's, above every lead speed).
    """

    name: str
    t_s: np.ndarray
    v_lead_mps: np.ndarray
    segments: tuple[SegmentRef, ...] = ()
    raw_v_mps: np.ndarray | None = field(default=None, repr=False)
    events: tuple[LeadEvent, ...] = ()
    set_speed_mps: float | None = None

    @property
    def duration_s(self) -> float:
        """Duration of the profile (s)."""
        return float(self.t_s[-1] - self.t_s[0]) if len(self.t_s) else 0.0

    def resample(self, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
        """Lead speed and acceleration on a grid of step ``dt_s`` from 0 to the end, shape (m,).

        The speed is interpolated linearly; the acceleration is the slope of the interpolant,
        so integrating it reproduces the interpolated speed exactly.
        """
        n = int(round(self.duration_s / dt_s)) + 1
        t = np.arange(n) * dt_s + self.t_s[0]
        v = np.interp(t, self.t_s, self.v_lead_mps)
        slopes = np.diff(self.v_lead_mps) / np.diff(self.t_s)
        idx = np.clip(np.searchsorted(self.t_s, t, side="right") - 1, 0, len(slopes) - 1)
        return v, slopes[idx]


@dataclass(frozen=True)
class LeadEvent:
    """One change of the tracked vehicle at ``t_s`` (s from the profile's start).

    Attributes:
        kind: ``cut_in`` (a vehicle enters between the ego car and its lead), ``cut_out``
            (the lead leaves and reveals the vehicle ahead of it), ``lead_loss`` (the lead
            leaves; free road), ``lead_appear`` (a vehicle comes into sight).
        gap_m, gap_thw_s: the new lead's gap at ``t_s`` is ``gap_m + gap_thw_s·v_ego`` (cut-in,
            appear); for a cut-out ``gap_m`` is its distance beyond the old lead, m.
        v_mps: the new lead's speed at ``t_s``, m/s; relative to the ego car's when
            ``v_relative`` (cut-in), else absolute.
        hold_s: the new lead keeps that speed this long, then rejoins the flow, s.
        dropout_s: the radar reports no lead this long while it confirms the new track, s.
    """

    t_s: float
    kind: EventKind
    gap_m: float = 0.0
    gap_thw_s: float = 0.0
    v_mps: float = 0.0
    v_relative: bool = False
    hold_s: float = 0.0
    dropout_s: float = 0.2

    def __post_init__(self) -> None:
        if self.kind not in EVENT_KINDS:
            raise ScenarioError(f"unknown event kind {self.kind!r}: one of {EVENT_KINDS}")
        values = (self.t_s, self.gap_m, self.gap_thw_s, self.v_mps, self.hold_s, self.dropout_s)
        if not all(math.isfinite(x) for x in values):
            raise ScenarioError(f"event values must be finite: {self}")
        if self.t_s < 0 or self.gap_m < 0 or self.gap_thw_s < 0 or self.hold_s < 0:
            raise ScenarioError(f"event times and gaps must be >= 0: {self}")
        if not 0 <= self.dropout_s <= 0.45:  # below the ECU's 500-ms radar timeout
            raise ScenarioError(f"dropout_s must lie in 0..0.45 s: {self}")
        if not self.v_relative and self.v_mps < 0:
            raise ScenarioError(f"an absolute speed must be >= 0: {self}")
