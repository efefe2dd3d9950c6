"""Online DGPT adaptation from one takeover: the paper's Algorithm 1 and a measured successor.

At pedal release, with ego speed ``v``, lead speed ``v_f``, gap ``g`` (m, m/s) and takeover
duration ``p_t`` (s): (1) behaviour filter ``p_t > P_T`` (or a run of short presses) and
``v_f - v < V_D``; (2) steady-state prediction ``g_desire = g`` if ``v_f >= v`` else
``g - K_T (v - v_f)``; (3) the change spread over speed bins (mode ``"paper"``: a triangular
window; ``"timegap"``, the default: in time-gap space over a wide speed range); (4) every bin
clipped into the table's :class:`~dbc.vocab.dgpt.SafetyBounds`. An accelerator takeover only
shortens the table, a brake takeover only lengthens it (else ``against_pedal``).
:func:`adapt` is pure; gaps in m, speeds in m/s.
Rationale and measurements: docs/ecu.md, docs/paper-notes.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import Literal, get_args

import numpy as np

from dbc.vocab.dgpt import Dgpt, SafetyBounds, clamp_to_bounds
from ecu import EcuError, finite_fields

AdaptationMode = Literal["paper", "timegap"]
#: the selectable adaptation modes (``AdaptationParams.mode``)
ADAPTATION_MODES: tuple[str, ...] = get_args(AdaptationMode)


class AdaptationError(EcuError):
    """Invalid adaptation parameters."""


@dataclass(frozen=True)
class AdaptationParams:
    """Parameters of the adaptation, units in the names (defaults justified in docs/ecu.md)."""

    min_takeover_s: float = 1.0  # P_T: a takeover this short or shorter is noise on its own
    short_press_min_s: float = 0.25  # longer than this, up to P_T: a short press
    short_press_count: int = 2  # this many short presses of one pedal in a row update the table
    short_press_window_s: float = 30.0  # a short press continues the run within this of the last
    coast_down_s: float = 1.0  # K_T: closing speed times K_T is the gap still lost after release
    max_speed_diff_mps: float = 5.0  # V_D: a lead faster by V_D or more is pulling away
    window_size: int = 9  # bins moved by one update in "paper" mode (odd, >= 1)
    mode: AdaptationMode = "timegap"  # or "paper" (Algorithm 1's local window)
    spread_speed_mps: float = 15.0  # timegap: standard deviation of the weight over speed
    min_speed_mps: float = 10.0  # timegap: slower speeds count as this one in time-gap space
    step_fraction: float = 1.0  # the share of the change made by one update, in (0, 1]
    switch_window_s: float = 5.0  # a takeover this soon after a target switch is skipped

    def __post_init__(self) -> None:
        names = "switch_window_s min_takeover_s short_press_min_s short_press_window_s"
        names += " coast_down_s max_speed_diff_mps spread_speed_mps min_speed_mps"
        if not finite_fields(self, names):
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
    """The state at the end of one takeover (pedal release): ``duration_s`` p_t (s), ego and lead
    speed (m/s), the gap (m; NaN without a lead), and the pedal that started it (``"accel"``: the
    driver wants a shorter gap, ``"brake"`` a longer one, ``"both"`` or ``""``: no direction)."""

    duration_s: float
    v_mps: float
    v_lead_mps: float
    gap_m: float
    lead_valid: bool = True
    pedal: str = ""
    after_switch_s: float = math.inf  # from the last radar target switch to the press, s


@dataclass(frozen=True, slots=True)
class Decision:
    """Outcome of one adaptation: the reason, the centre bin (-1 when skipped), the predicted
    steady-state gap before the safety filter (m, NaN if skipped), the centre's change (m)."""

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
    """The run of short presses so far (state of :func:`count_short_press`): its pedal
    (``""``: no run), its length, when the last one ended (s, the node's clock)."""

    pedal: str = ""
    count: int = 0
    last_end_s: float = -math.inf


def is_short(summary: TakeoverSummary, params: AdaptationParams) -> bool:
    """The takeover is a short press: ``short_press_min_s < p_t <= P_T``."""
    return params.short_press_min_s < summary.duration_s <= params.min_takeover_s


def count_short_press(
    state: ShortPresses, summary: TakeoverSummary, end_s: float, params: AdaptationParams
) -> tuple[ShortPresses, bool]:
    """Fold one finished takeover (ended at ``end_s``, s) into the run of short presses."""
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
    """``Reason.APPLIED`` if the takeover may update the table, else the skip reason (a press
    that began within ``switch_window_s`` of a radar target switch: forced by a cut-in, no
    evidence of the preferred gap)."""
    own = (summary.duration_s, summary.v_mps)
    lead = (summary.v_lead_mps, summary.gap_m)
    if (
        not all(math.isfinite(x) for x in own)
        or summary.v_mps < 0.0
        or (summary.lead_valid and not all(math.isfinite(x) and x >= 0.0 for x in lead))
    ):
        return Reason.INVALID_INPUT
    if not summary.lead_valid:
        return Reason.NO_LEAD
    if summary.after_switch_s < params.switch_window_s:
        return Reason.TARGET_SWITCH
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


def centre_bin(table: Dgpt, v_mps: float) -> int:
    """The speed bin of ``table`` nearest ``v_mps`` (m/s), clipped to the axis."""
    centre = int(round((v_mps - float(table.speed_mps[0])) / table.step_mps))
    return min(max(centre, 0), table.speed_mps.size - 1)


def spread_weights(n_bins: int, centre: int, window_size: int) -> np.ndarray:
    """Triangular update weights, shape ``(n_bins,)``: 1 at ``centre``, 0 outside the window."""
    half = (window_size - 1) // 2
    idx = np.arange(n_bins)
    w = 1.0 - np.abs(idx - centre) / (half + 1)
    return np.clip(w, 0.0, 1.0)


def timegap_weights(speed_mps: np.ndarray, v_mps: float, spread_speed_mps: float) -> np.ndarray:
    """Gaussian update weights over speed, shape of ``speed_mps``: ``exp(-((v_i - v)/s)^2 / 2)``."""
    return np.exp(-0.5 * ((speed_mps - v_mps) / spread_speed_mps) ** 2)


def timegap_update(
    table: Dgpt, centre: int, g_desire_m: float, params: AdaptationParams
) -> np.ndarray:
    """New gaps, shape ``(n,)``: the time-gap change at bin ``centre`` spread over speed."""
    vmin = params.min_speed_mps
    speed = table.speed_mps
    v_c = float(speed[centre])
    dh = params.step_fraction * (g_desire_m - float(table.gap_m[centre])) / max(v_c, vmin)
    w = timegap_weights(speed, v_c, params.spread_speed_mps)
    return np.asarray(table.gap_m + w * dh * np.maximum(speed, vmin))


def safety_filter(speed_mps: np.ndarray, gap_m: np.ndarray, bounds: SafetyBounds) -> np.ndarray:
    """``gap_m`` (``(n,)``) clipped into the table's safety ``bounds`` at ``speed_mps``."""
    return np.asarray(clamp_to_bounds(speed_mps, gap_m, bounds))


def with_pedal(old_m: np.ndarray, new_m: np.ndarray, pedal: str) -> np.ndarray:
    """``new_m`` with no bin moved against the pedal (``(n,)`` each): after the accelerator
    no bin is longer than before, after the brake none is shorter."""
    if pedal == "accel":
        return np.asarray(np.minimum(new_m, old_m))
    if pedal == "brake":
        return np.asarray(np.maximum(new_m, old_m))
    return new_m


def applied(table: Dgpt, new: Dgpt, centre: int, g_desire_m: float) -> Decision:
    """The decision of updating ``table`` to ``new`` at bin ``centre`` (``g_desire_m`` in m)."""
    delta = float(new.gap_m[centre] - table.gap_m[centre])
    return Decision(True, Reason.APPLIED, centre, g_desire_m, delta)


def adapt(
    table: Dgpt,
    summary: TakeoverSummary,
    params: AdaptationParams,
    *,
    bounds: SafetyBounds | None = None,
    short_run: bool = False,
    created_utc: str | None = None,
) -> tuple[Dgpt, Decision]:
    """Apply the adaptation (``params.mode``) for one finished takeover; pure."""
    reason = behaviour_filter(summary, params, short_run=short_run)
    if reason is not Reason.APPLIED:
        return table, Decision(applied=False, reason=reason)
    g_desire = predict_steady_gap(summary, params)
    speed = table.speed_mps
    centre = centre_bin(table, summary.v_mps)
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
    return new, applied(table, new, centre, g_desire)
