"""Online DGPT adaptation from one takeover: the paper's Algorithm 1 and a measured successor.

Two modes (``AdaptationParams.mode``; measurements in docs/ecu.md and bench/adaptation.py):

- ``"paper"``: Algorithm 1 as read in docs/paper-notes.md, unchanged (steps 1-4 below);
- ``"timegap"`` (default): the same filter (1), prediction (2) and safety filter (4), but,
  instead of step 3, the change is made in time-gap space and spread over a wide speed range
  (:func:`ecu.table_update.timegap_update`), because the measured error of a table is mostly
  a time-gap offset at every speed, and a local window of +-2 m/s leaves the rest of a
  5-30 m/s trip unlearned.

Both modes share three rules that the printed algorithm leaves open:

- **One safety bound.** Step 4 clips to the table's own :class:`~dbc.vocab.dgpt.SafetyBounds`
  (``2 m + 0.8 s·v`` … ``10 m + 5 s·v`` by default), the bound every loaded table is checked
  against. A separate, higher floor (the earlier ``4 m + 0.8 s·v``) lifted a close
  follower's table by up to 2 m at every speed whenever one accelerator press asked for
  less — the opposite of what the driver asked for.
- **The pedal's direction.** An accelerator takeover may only shorten the table, a brake
  takeover only lengthen it: an update whose centre would move the other way is skipped as
  ``against_pedal`` (e.g. an accelerator press during which the lead pulled away), and no
  bin of an applied update moves against the pedal (``min``/``max`` with the old table).
- **Short presses are evidence when repeated.** A takeover no longer than ``P_T`` is noise
  on its own, but ``short_press_count`` short presses (each longer than
  ``short_press_min_s``) of one pedal in a row, each within ``short_press_window_s`` of the
  previous, say the same thing as one long press: the last of them updates the table
  (:func:`count_short_press`, state :class:`ShortPresses` kept by the node). A driver who
  only ever presses briefly is no longer ignored.

Algorithm 1 runs once, at the moment a takeover ends (pedal released), with the ego speed
``v``, the lead speed ``v_f`` and the gap ``g`` at that moment and the takeover's duration ``p_t``:

1. Behaviour filter — update only when ``p_t > P_T`` (or the takeover completes a run of
   short presses, above) and ``(v_f - v) < V_D`` (the printed ``update_flag`` is the skip
   condition; short takeovers are noise, a lead pulling away fast is no steady state).
2. Steady-state prediction — ``v_f >= v``: the gap is not closing, ``g_desire = g``;
   otherwise the ego keeps closing after release: ``g_desire = g - K_T * (v - v_f)``.
3. Update and smooth — the change ``delta = g_desire - DGPT(v_bin)`` at the speed bin nearest
   ``v`` is spread over ``window_size`` bins centred there with triangular weights (1 at the
   centre, falling linearly, zero one bin past the window), so one takeover moves a region of
   the table and the centre bin lands exactly on ``g_desire``. The rest is left untouched
   (smoothing the whole table at every update would erode it).
4. Safety filter — every bin is clipped into the table's safety bounds
   ``[d0_min + Safe_TG_min * v_i, d0_max + Safe_TG_max * v_i]``
   (:class:`~dbc.vocab.dgpt.SafetyBounds`).

:func:`adapt` is pure: (table, takeover summary, params, bounds) -> (new table, decision). A
skipped update returns the same table object and a decision naming the reason. This module
decides (filter, prediction, the pedal's direction, short presses); how an update is written
into the table (steps 3 and 4: the window or time-gap spread, the safety filter, no bin
against the pedal) is :mod:`ecu.table_update`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Literal, get_args

from dbc.vocab.dgpt import Dgpt, SafetyBounds
from ecu import EcuError
from ecu.table_update import safety_filter, spread_weights, timegap_update, with_pedal

AdaptationMode = Literal["paper", "timegap"]
#: the selectable adaptation modes (``AdaptationParams.mode``)
ADAPTATION_MODES: tuple[str, ...] = get_args(AdaptationMode)


class AdaptationError(EcuError):
    """Invalid adaptation parameters."""


@dataclass(frozen=True)
class AdaptationParams:
    """Parameters of the adaptation (defaults justified in docs/ecu.md and the tests).

    The safety filter's band is not a parameter here: it is the table's own
    :class:`~dbc.vocab.dgpt.SafetyBounds` (``EcuConfig.bounds``), passed to :func:`adapt`.

    Attributes:
        min_takeover_s: P_T; a takeover this short or shorter is noise on its own (1.0 s: a
            tap on a pedal to feel the car or a reflex lasts well under a second).
        short_press_min_s: a takeover longer than this but not longer than P_T is a short
            press: evidence once repeated (0.25 s: shorter is a touch of the pedal, not an
            intention; the driver model presses at least 0.3 s).
        short_press_count: this many short presses of one pedal in a row update the table
            (2; 1 would make every short press an update, i.e. P_T = short_press_min_s).
        short_press_window_s: a short press continues the run only if it ends within this
            time of the previous one's end, s (30 s: about the patience of a driver who
            nudges the car several times towards the gap it wants).
        coast_down_s: K_T, seconds; closing speed times K_T is the gap still lost after
            release while the ACC matches the lead speed (about dv / (2 a) with a ~ 1 m/s^2
            comfortable deceleration and dv of a few m/s gives ~1 s).
        max_speed_diff_mps: V_D; a lead faster by V_D or more is pulling away: no steady
            state (5 m/s: a gap opening at 18 km/h changes by 5 m each second).
        window_size: bins moved by one update (odd, >= 1); 9 bins at 0.5 m/s cover +-2 m/s,
            the speed spread of a typical several-second takeover.
        mode: ``"timegap"`` (default: fewer interventions in the measured study) or
            ``"paper"`` (Algorithm 1's local window; ``window_size`` applies only here).
        spread_speed_mps: timegap mode: standard deviation of the Gaussian weight over speed
            of one update (15 m/s: picked on drawn drivers of population seed 1 among 6, 10,
            15, 25, 40 — docs/ecu.md; the earlier 25 m/s was picked on d1..d5; a takeover at
            10 m/s moves the time gap at 30 m/s by 41 % of the change).
        min_speed_mps: timegap mode: speeds below this count as this speed when converting
            gap to time gap (10 m/s: below it the standstill distance dominates the gap and a
            slow takeover would be magnified into metres at motorway speed).
        step_fraction: the share of the change made by one update, in (0, 1] (1: the centre
            bin lands on ``g_desire``, the paper's full step; 0.5 was worse on population
            seed 1, docs/ecu.md).
        switch_window_s: a takeover that starts within this time of a radar target switch
            (a cut-in) answers the new vehicle, not the preferred gap: skipped (5 s: the
            slowest drawn driver's reaction plus patience; set before any measurement).
    """

    min_takeover_s: float = 1.0
    short_press_min_s: float = 0.25
    short_press_count: int = 2
    short_press_window_s: float = 30.0
    coast_down_s: float = 1.0
    max_speed_diff_mps: float = 5.0
    window_size: int = 9
    mode: AdaptationMode = "timegap"
    spread_speed_mps: float = 15.0
    min_speed_mps: float = 10.0
    step_fraction: float = 1.0
    switch_window_s: float = 5.0

    def __post_init__(self) -> None:
        floats = (
            self.switch_window_s,
            self.min_takeover_s,
            self.short_press_min_s,
            self.short_press_window_s,
            self.coast_down_s,
            self.max_speed_diff_mps,
            self.spread_speed_mps,
            self.min_speed_mps,
        )
        if not all(math.isfinite(x) and x >= 0.0 for x in floats):
            raise AdaptationError(f"adaptation parameters must be finite and >= 0: {self}")
        if self.window_size < 1 or self.window_size % 2 == 0:
            raise AdaptationError(f"window_size must be odd and >= 1, got {self.window_size}")
        if not 0.0 < self.step_fraction <= 1.0:
            raise AdaptationError(f"step_fraction must be in (0, 1], got {self.step_fraction}")
        if self.short_press_count < 1:
            raise AdaptationError(f"short_press_count must be >= 1, got {self.short_press_count}")
        if self.short_press_min_s > self.min_takeover_s:
            raise AdaptationError("short_press_min_s exceeds min_takeover_s")
        if self.mode not in ADAPTATION_MODES:
            raise AdaptationError(f"mode must be one of {ADAPTATION_MODES}, got {self.mode!r}")
        if self.mode == "timegap" and not (self.spread_speed_mps > 0 and self.min_speed_mps > 0):
            raise AdaptationError("timegap mode needs spread_speed_mps > 0 and min_speed_mps > 0")


class Reason(StrEnum):
    """Why an adaptation was applied or skipped."""

    APPLIED = "applied"
    SHORT_TAKEOVER = "short_takeover"
    SPEED_DIFFERENCE = "speed_difference"
    AGAINST_PEDAL = "against_pedal"
    NO_LEAD = "no_lead"
    INVALID_INPUT = "invalid_input"
    TARGET_SWITCH = "target_switch"


@dataclass(frozen=True, slots=True)
class TakeoverSummary:
    """The state at the end of one takeover (pedal release).

    Attributes:
        duration_s: p_t, time from the first pedal press to the release, s.
        v_mps: ego speed at release, m/s.
        v_lead_mps: lead speed v_f at release, m/s (NaN without a lead).
        gap_m: bumper-to-bumper gap at release, m (NaN without a lead).
        lead_valid: the radar tracked a lead at release.
        pedal: the pedal that started the takeover: ``"accel"`` (the driver wanted a shorter
            gap), ``"brake"`` (a longer one), ``"both"`` or ``""`` (unknown: no direction).
    """

    duration_s: float
    v_mps: float
    v_lead_mps: float
    gap_m: float
    lead_valid: bool = True
    pedal: str = ""
    after_switch_s: float = math.inf  # from the last radar target switch to the press, s


@dataclass(frozen=True, slots=True)
class Decision:
    """Outcome of one adaptation.

    Attributes:
        applied: the table changed.
        reason: why (``Reason.APPLIED`` or the skip reason).
        bin_index: centre bin of the update (-1 when skipped).
        g_desire_m: predicted steady-state gap before the safety filter, m (NaN if skipped).
        delta_m: change of the centre bin after the safety filter, m (0 if skipped).
    """

    applied: bool
    reason: Reason
    bin_index: int = -1
    g_desire_m: float = math.nan
    delta_m: float = 0.0

    def __str__(self) -> str:
        if not self.applied:
            return f"adaptation skipped: {self.reason.value}"
        return (
            f"adaptation applied at bin {self.bin_index}: g_desire {self.g_desire_m:.2f} m "
            f"(centre moved {self.delta_m:+.2f} m)"
        )


@dataclass(frozen=True, slots=True)
class ShortPresses:
    """The run of short presses so far (state of :func:`count_short_press`).

    Attributes:
        pedal: the pedal of the run (``"accel"`` or ``"brake"``; ``""``: no run).
        count: short presses in the run.
        last_end_s: when the last of them ended, s (the node's clock).
    """

    pedal: str = ""
    count: int = 0
    last_end_s: float = -math.inf


def is_short(summary: TakeoverSummary, params: AdaptationParams) -> bool:
    """The takeover is a short press: ``short_press_min_s < p_t <= P_T``."""
    return params.short_press_min_s < summary.duration_s <= params.min_takeover_s


def count_short_press(
    state: ShortPresses, summary: TakeoverSummary, end_s: float, params: AdaptationParams
) -> tuple[ShortPresses, bool]:
    """Fold one finished takeover (ended at ``end_s``, s) into the run of short presses.

    Returns the new state and whether this takeover completes a run of
    ``short_press_count`` short presses of one pedal (then it may update the table and the
    run starts again). A long takeover, a touch (``<= short_press_min_s``) or a press
    without a single pedal (``"both"``, ``""``) ends the run; a short press of the other
    pedal, or one more than ``short_press_window_s`` after the last, starts a new run.
    """
    if not (is_short(summary, params) and summary.pedal in ("accel", "brake")):
        return ShortPresses(), False
    same = state.pedal == summary.pedal and end_s - state.last_end_s <= params.short_press_window_s
    count = state.count + 1 if same else 1
    if count >= params.short_press_count:
        return ShortPresses(), True
    return ShortPresses(summary.pedal, count, end_s), False


def behaviour_filter(
    summary: TakeoverSummary, params: AdaptationParams, *, short_run: bool = False
) -> Reason:
    """``Reason.APPLIED`` if the takeover may update the table, else the skip reason.

    ``short_run``: the takeover completes a run of short presses (:func:`count_short_press`),
    so a duration at or below P_T (but above ``short_press_min_s``) is accepted.
    """
    values = (summary.duration_s, summary.v_mps)
    if not all(math.isfinite(x) for x in values) or summary.v_mps < 0.0:
        return Reason.INVALID_INPUT
    if not summary.lead_valid:
        return Reason.NO_LEAD
    lead = (summary.v_lead_mps, summary.gap_m)
    if not all(math.isfinite(x) and x >= 0.0 for x in lead):
        return Reason.INVALID_INPUT
    if summary.duration_s <= params.min_takeover_s and not (
        short_run and summary.duration_s > params.short_press_min_s
    ):
        return Reason.SHORT_TAKEOVER
    if summary.v_lead_mps - summary.v_mps >= params.max_speed_diff_mps:
        return Reason.SPEED_DIFFERENCE
    return Reason.APPLIED


def predict_steady_gap(summary: TakeoverSummary, params: AdaptationParams) -> float:
    """Steady-state gap the driver aimed at, m: ``g`` if not closing, else ``g - K_T * dv``."""
    if summary.v_lead_mps >= summary.v_mps:
        return summary.gap_m
    return summary.gap_m - params.coast_down_s * (summary.v_mps - summary.v_lead_mps)


def against_pedal(pedal: str, change_m: float) -> bool:
    """The change (m) contradicts the pedal: the accelerator asks for a shorter gap, the
    brake for a longer one; ``"both"`` or ``""`` constrain nothing."""
    return (pedal == "accel" and change_m > 0.0) or (pedal == "brake" and change_m < 0.0)


def adapt(
    table: Dgpt,
    summary: TakeoverSummary,
    params: AdaptationParams,
    *,
    bounds: SafetyBounds | None = None,
    short_run: bool = False,
    created_utc: str | None = None,
) -> tuple[Dgpt, Decision]:
    """Apply the adaptation (``params.mode``) for one finished takeover; pure.

    ``bounds``: the table's safety bounds (default :class:`SafetyBounds`), the one band of
    the safety filter. ``short_run``: the takeover completes a run of short presses
    (:func:`count_short_press`). Returns the new table (``version + 1``, source
    ``adapted``) and the decision, or the same ``table`` object and a skip decision.
    """
    reason = behaviour_filter(summary, params, short_run=short_run)
    answers = reason in (Reason.APPLIED, Reason.SHORT_TAKEOVER, Reason.SPEED_DIFFERENCE)
    if answers and summary.after_switch_s < params.switch_window_s:
        reason = Reason.TARGET_SWITCH  # forced by a cut-in: no evidence of the preferred gap
    if reason is not Reason.APPLIED:
        return table, Decision(applied=False, reason=reason)
    g_desire = predict_steady_gap(summary, params)
    speed = table.speed_mps
    centre = int(round((summary.v_mps - float(speed[0])) / table.step_mps))
    centre = min(max(centre, 0), speed.size - 1)
    if against_pedal(summary.pedal, g_desire - float(table.gap_m[centre])):
        return table, Decision(applied=False, reason=Reason.AGAINST_PEDAL, g_desire_m=g_desire)
    if params.mode == "timegap":
        gap = timegap_update(table, centre, g_desire, params)
    else:
        delta = params.step_fraction * (g_desire - float(table.gap_m[centre]))
        gap = table.gap_m + delta * spread_weights(speed.size, centre, params.window_size)
    gap = safety_filter(speed, gap, bounds if bounds is not None else SafetyBounds())
    gap = with_pedal(table.gap_m, gap, summary.pedal)
    new = table.with_gaps(gap, "adapted", created_utc=created_utc)
    decision = Decision(
        applied=True,
        reason=Reason.APPLIED,
        bin_index=centre,
        g_desire_m=g_desire,
        delta_m=float(new.gap_m[centre] - table.gap_m[centre]),
    )
    return new, decision


__all__ = [
    "AdaptationError",
    "AdaptationParams",
    "Decision",
    "Reason",
    "ShortPresses",
    "TakeoverSummary",
    "ADAPTATION_MODES",
    "AdaptationMode",
    "adapt",
    "against_pedal",
    "behaviour_filter",
    "count_short_press",
    "is_short",
    "predict_steady_gap",
]
