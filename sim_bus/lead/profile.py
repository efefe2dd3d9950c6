"""A lead speed profile (:class:`LeadProfile`, 10 Hz) and the events that change which vehicle
the radar tracks (:class:`LeadEvent`)."""

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
    """A lead speed profile: ``t_s`` (s), ``v_lead_mps`` (m/s) float64 (n,), 10 Hz; ``events``
    (none: the paper's car following); ``set_speed_mps`` the road's ACC set speed (None: the
    study's)."""

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
        """Lead speed (m/s, linear) and acceleration (m/s², the interpolant's slope) on a grid
        of step ``dt_s`` (s), arrays (m,)."""
        n = int(round(self.duration_s / dt_s)) + 1
        t = np.arange(n) * dt_s + self.t_s[0]
        v = np.interp(t, self.t_s, self.v_lead_mps)
        slopes = np.diff(self.v_lead_mps) / np.diff(self.t_s)
        idx = np.clip(np.searchsorted(self.t_s, t, side="right") - 1, 0, len(slopes) - 1)
        return v, slopes[idx]


@dataclass(frozen=True)
class LeadEvent:
    """One change of the tracked vehicle at ``t_s`` (s): ``kind`` (cut_in, cut_out revealing
    the vehicle ahead, lead_loss, lead_appear); the new gap ``gap_m + gap_thw_s·v_ego`` (m;
    a cut-out's ``gap_m`` is beyond the old lead); ``v_mps`` (m/s, relative to the ego's when
    ``v_relative``), held ``hold_s``; the radar blind ``dropout_s`` (s)."""

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
