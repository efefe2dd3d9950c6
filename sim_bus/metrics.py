"""Drive metrics, shared by ``pacc drive`` and the experiment (pure functions on arrays).

All inputs are 1-D arrays of one length ``n`` sampled at a uniform step (``t_s``):

- PoI: percentage of ACC-ON time with either pedal pressed;
- NIM: pedal-press onsets (released -> accelerator or brake pressed) per minute of ACC-ON time;
- min gap (m), min time-to-collision (s; inf when never closing), RMS jerk (m/s³) of the
  actual acceleration, gap error against the driver's preference (mean, RMS; m; samples
  without a lead in sight, gap >= ``NO_LEAD_GAP_M``, have no gap error).

ACC-ON time: samples in Active or Override, plus Standby samples after the first engagement
(a brake press that cancels the ACC is still an intervention of an ACC-ON drive); Off and
Fault samples are not ACC-ON.
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
    t = np.asarray(t_s, dtype=np.float64)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    on = acc_on_mask(acc_state)
    pressed = np.asarray(accel_pressed, dtype=bool) | np.asarray(brake_pressed, dtype=bool)
    # an onset is a change from no pedal to a pedal, or from one pedal to the other
    a = np.asarray(accel_pressed, dtype=bool)
    b = np.asarray(brake_pressed, dtype=bool)
    onsets_mask = (press_onsets(a) | press_onsets(b)) & on
    on_s = float(on.sum()) * dt
    n_on = int(onsets_mask.sum())
    if on_s <= 0.0:
        return math.nan, math.nan, 0.0, n_on
    poi = 100.0 * float((pressed & on).sum()) * dt / on_s
    return poi, n_on / (on_s / 60.0), on_s, n_on


def min_ttc_s(gap_m: np.ndarray, v_mps: np.ndarray, v_lead_mps: np.ndarray) -> float:
    """Smallest gap / closing speed over samples that close (v > v_lead); inf if none."""
    closing = np.asarray(v_mps) - np.asarray(v_lead_mps)
    m = closing > 1e-3
    if not np.any(m):
        return math.inf
    return float(np.min(np.maximum(np.asarray(gap_m)[m], 0.0) / closing[m]))


def rms_jerk(t_s: np.ndarray, a_mps2: np.ndarray) -> float:
    """Root mean square of the finite-difference jerk (m/s³); 0 for fewer than 2 samples."""
    if len(a_mps2) < 2:
        return 0.0
    j = np.diff(np.asarray(a_mps2, dtype=np.float64)) / np.diff(np.asarray(t_s, dtype=np.float64))
    return float(np.sqrt(np.mean(j * j)))


def drive_metrics(
    t_s: np.ndarray,
    v_mps: np.ndarray,
    gap_m: np.ndarray,
    v_lead_mps: np.ndarray,
    a_mps2: np.ndarray,
    acc_state: np.ndarray,
    accel_pressed: np.ndarray,
    brake_pressed: np.ndarray,
    pref_gap_m: np.ndarray,
) -> DriveMetrics:
    """All figures of one drive; the gap error uses ACC-ON samples without a pedal pressed."""
    poi, nim, on_s, n_on = poi_nim(t_s, acc_state, accel_pressed, brake_pressed)
    on = acc_on_mask(acc_state) & ~(
        np.asarray(accel_pressed, bool) | np.asarray(brake_pressed, bool)
    )
    on &= np.asarray(gap_m) < NO_LEAD_GAP_M  # a free road has no gap to err about
    err = (np.asarray(gap_m) - np.asarray(pref_gap_m))[on]
    return DriveMetrics(
        poi_pct=poi,
        nim_per_min=nim,
        acc_on_s=on_s,
        press_onsets=n_on,
        min_gap_m=float(np.min(gap_m)) if len(gap_m) else math.nan,
        min_ttc_s=min_ttc_s(gap_m, v_mps, v_lead_mps),
        rms_jerk_mps3=rms_jerk(t_s, a_mps2),
        gap_error_mean_m=float(err.mean()) if err.size else math.nan,
        gap_error_rms_m=float(np.sqrt(np.mean(err * err))) if err.size else math.nan,
    )


@dataclass(frozen=True)
class SafetyFigures:
    """Time-to-collision exposure of one drive (units in the names).

    ``*_own`` figures leave out the samples where the driver's own accelerator press
    overrides the ACC, and the rest of a time below the threshold that began during one
    (reported separately: then the driver, not the ECU, closed the gap), and
    the samples of a cut-in that began below the threshold plus ``CUT_IN_REACTION_S``,
    until the TTC is above that again (``below_cut_in_s``: no controller raises at once a TTC
    the cutter set; whether the ECU then avoided the collision is in ``min_gap_m`` and the
    drive's collision flag).
    """

    min_ttc_s: float
    min_gap_m: float
    below_s: float
    min_ttc_own_s: float
    below_own_s: float
    below_override_s: float
    below_cut_in_s: float = 0.0


#: a cut-in that leaves less than the threshold plus this much TTC when it happens sets the TTC
#: of what follows: the radar confirms the new track (up to 0.3 s without a lead), the request
#: builds up (0.35 s to -3.5 m/s^2 at 10 m/s^3) and the actuator follows (0.4-s lag), while
#: the TTC falls by 1 s per s, faster if the car was accelerating (traced: 2.31 s at the cut-in,
#: 1.83 s 0.6 s later; 2.63 s, 1.80 s 0.8 s later, the car at +0.7 m/s^2 when it came), s
CUT_IN_REACTION_S = 1.0


def pressed_episodes(below: np.ndarray, pressed: np.ndarray) -> np.ndarray:
    """``pressed`` (bool mask) widened to every episode of ``below`` (a run of samples below
    the threshold) that began while pressed: a gap the driver's own accelerator closed stays
    the driver's until the TTC is above the threshold again (traced: a press held through a
    cut-in's first 0.7 s, then the driver's brake, below 2 s for 0.45 s after the press)."""
    out = pressed.copy()
    k, n = 0, len(below)
    while k < n:
        if below[k] and pressed[k] and (k == 0 or not below[k - 1] or out[k - 1]):
            while k < n and below[k]:
                out[k] = True
                k += 1
        else:
            k += 1
    return out


def inherited_mask(
    ttc_s: np.ndarray, t_s: np.ndarray, cut_in_t_s: Sequence[float], threshold_s: float
) -> np.ndarray:
    """The samples (bool mask) a cut-in set: for every cut-in at a time of ``cut_in_t_s`` (s)
    whose first sample at or after it is below ``threshold_s + CUT_IN_REACTION_S`` of TTC,
    the samples from there while the TTC stays below that."""
    mask = np.zeros(len(ttc_s), dtype=bool)
    limit = threshold_s + CUT_IN_REACTION_S
    for t_c in cut_in_t_s:
        k = int(np.searchsorted(t_s, t_c - 1e-9))
        while k < len(ttc_s) and ttc_s[k] < limit:
            mask[k] = True
            k += 1
    return mask


def safety_figures(
    t_s: np.ndarray,
    gap_m: np.ndarray,
    v_mps: np.ndarray,
    v_lead_mps: np.ndarray,
    accel_pressed: np.ndarray,
    threshold_s: float = 2.0,
    cut_in_t_s: Sequence[float] = (),
) -> SafetyFigures:
    """Min TTC (s), min gap (m) and the time (s) spent below ``threshold_s`` of TTC, over
    the whole drive and without the samples of an accelerator press (the driver's own) or
    of a cut-in (at the times ``cut_in_t_s``, s) that began below ``threshold_s`` plus
    ``CUT_IN_REACTION_S`` (:func:`inherited_mask`)."""
    t = np.asarray(t_s, dtype=np.float64)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    gap = np.asarray(gap_m, dtype=np.float64)
    closing = np.asarray(v_mps, dtype=np.float64) - np.asarray(v_lead_mps, dtype=np.float64)
    ttc = np.full(len(gap), math.inf)
    m = closing > 1e-3
    ttc[m] = np.maximum(gap[m], 0.0) / closing[m]
    below = ttc < threshold_s
    press = pressed_episodes(below, np.asarray(accel_pressed, dtype=bool))
    cut = inherited_mask(ttc, t, cut_in_t_s, threshold_s) & ~press
    own = ~press & ~cut
    return SafetyFigures(
        min_ttc_s=float(ttc.min()) if len(ttc) else math.inf,
        min_gap_m=float(gap.min()) if len(gap) else math.nan,
        below_s=float(below.sum()) * dt,
        min_ttc_own_s=float(ttc[own].min()) if own.any() else math.inf,
        below_own_s=float((below & own).sum()) * dt,
        below_override_s=float((below & press).sum()) * dt,
        below_cut_in_s=float((below & cut).sum()) * dt,
    )
