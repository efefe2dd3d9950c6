"""Drive metrics (pure functions on 1-D arrays (n,) at a uniform step ``t_s``).

PoI: % of ACC-ON time with a pedal pressed; NIM: press onsets per minute of ACC-ON time;
min gap (m), min TTC (s; inf: never closing), RMS jerk (m/s³), gap error against the
preference (m; none without a lead, gap >= ``NO_LEAD_GAP_M``). ACC-ON: Active, Override, and
Standby after the first engagement (a cancelling brake press still counts).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from dbc.vocab.acc_state import AccState

#: a gap beyond this is no lead at all (a road scenario's free road, sim_bus.world), m
NO_LEAD_GAP_M = 500.0


@dataclass(frozen=True)
class DriveMetrics:
    """The figures of one drive (units in the names)."""

    poi_pct: float
    nim_per_min: float
    acc_on_s: float
    press_onsets: int
    min_gap_m: float
    min_ttc_s: float
    rms_jerk_mps3: float
    gap_error_mean_m: float
    gap_error_rms_m: float

    def as_dict(self) -> dict[str, float]:
        """The figures as a plain dict (JSON-ready; inf kept as float)."""
        return {k: float(v) for k, v in asdict(self).items()}


#: a drive's metrics, in the columns of drives.csv (also a hil session's records)
METRIC_FIELDS = (
    "poi_pct",
    "nim_per_min",
    "press_onsets",
    "acc_on_s",
    "min_gap_m",
    "min_ttc_s",
    "rms_jerk_mps3",
    "gap_error_rms_m",
)


def acc_on_mask(acc_state: np.ndarray) -> np.ndarray:
    """Boolean (n,): ACC-ON samples (Active/Override, and Standby after the first engagement)."""
    s = np.asarray(acc_state)
    engaged = (s == AccState.ACTIVE) | (s == AccState.OVERRIDE)
    after_first = np.cumsum(engaged) > 0
    on: np.ndarray = engaged | ((s == AccState.STANDBY) & after_first)
    return on


def press_onsets(pressed: np.ndarray) -> np.ndarray:
    """Boolean (n,): True where a press starts (pressed now, not pressed one sample before)."""
    p = np.asarray(pressed, dtype=bool)
    prev = np.concatenate([[False], p[:-1]])
    onsets: np.ndarray = p & ~prev
    return onsets


def poi_nim(
    t_s: np.ndarray, acc_state: np.ndarray, accel_pressed: np.ndarray, brake_pressed: np.ndarray
) -> tuple[float, float, float, int]:
    """(PoI %, NIM per min, ACC-ON seconds, onsets) of one drive; NaN figures if never ON."""
    dt = float(np.median(np.diff(np.asarray(t_s, dtype=np.float64)))) if len(t_s) > 1 else 0.0
    on = acc_on_mask(acc_state)
    a = np.asarray(accel_pressed, dtype=bool)
    b = np.asarray(brake_pressed, dtype=bool)
    pressed = a | b
    # an onset is a change from no pedal to a pedal, or from one pedal to the other
    onsets_mask = (press_onsets(a) | press_onsets(b)) & on
    on_s = float(on.sum()) * dt
    n_on = int(onsets_mask.sum())
    if on_s <= 0.0:
        return math.nan, math.nan, 0.0, n_on
    poi = 100.0 * float((pressed & on).sum()) * dt / on_s
    return poi, n_on / (on_s / 60.0), on_s, n_on


def ttc_s(gap_m: np.ndarray, v_mps: np.ndarray, v_lead_mps: np.ndarray) -> np.ndarray:
    """Time to collision (n,), s: gap / closing speed where closing (v > v_lead), else inf."""
    gap = np.asarray(gap_m, dtype=np.float64)
    closing = np.asarray(v_mps, dtype=np.float64) - np.asarray(v_lead_mps, dtype=np.float64)
    ttc = np.full(len(gap), math.inf)
    m = closing > 1e-3
    ttc[m] = np.maximum(gap[m], 0.0) / closing[m]
    return ttc


def rms_jerk(t_s: np.ndarray, a_mps2: np.ndarray) -> float:
    """Root mean square of the finite-difference jerk (m/s³); 0 for fewer than 2 samples."""
    if len(a_mps2) < 2:
        return 0.0
    j = np.diff(np.asarray(a_mps2, dtype=np.float64)) / np.diff(np.asarray(t_s, dtype=np.float64))
    return float(np.sqrt(np.mean(j * j)))


@dataclass(frozen=True)
class SafetyFigures:
    """Time-to-collision exposure of one drive (units in the names). ``*_own`` figures leave
    out what the driver's own accelerator closed (``below_override_s``) and what a cut-in set
    (``below_cut_in_s``: no controller raises at once a TTC the cutter set)."""

    min_ttc_s: float
    min_gap_m: float
    below_s: float
    min_ttc_own_s: float
    below_own_s: float
    below_override_s: float
    below_cut_in_s: float = 0.0


#: a cut-in leaving less than the threshold plus this TTC sets what follows (track
#: confirmation, request build-up and actuator lag take about that long), s
CUT_IN_REACTION_S = 1.0


def pressed_episodes(below: np.ndarray, pressed: np.ndarray) -> np.ndarray:
    """``pressed`` (bool mask) widened over each run of ``below`` from its start if pressed
    there, else from two pressed samples in a row: what the driver's accelerator closed."""
    prev_below, prev_pressed = np.r_[False, below[:-1]], np.r_[False, pressed[:-1]]
    first = below & pressed & (~prev_below | prev_pressed)  # where a run becomes the driver's
    seen = np.cumsum(first)
    before = np.maximum.accumulate(np.where(below & ~prev_below, seen - first, 0))
    out: np.ndarray = pressed | (below & (seen > before))
    return out


def inherited_mask(
    ttc_s: np.ndarray, t_s: np.ndarray, cut_in_t_s: Sequence[float], threshold_s: float
) -> np.ndarray:
    """The samples (bool mask) a cut-in at ``cut_in_t_s`` (s) set: from it while the TTC
    stays below ``threshold_s + CUT_IN_REACTION_S``."""
    mask = np.zeros(len(ttc_s), dtype=bool)
    limit = threshold_s + CUT_IN_REACTION_S
    for t_c in cut_in_t_s:
        k = int(np.searchsorted(t_s, t_c - 1e-9))
        while k < len(ttc_s) and ttc_s[k] < limit:
            mask[k] = True
            k += 1
    return mask
