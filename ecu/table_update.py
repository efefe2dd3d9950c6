"""How one applied takeover changes the DGPT: the spread, the safety filter, the pedal.

The array mathematics of steps 3 and 4 of :mod:`ecu.adaptation`: the paper's triangular window
(:func:`spread_weights`), the time-gap mode's Gaussian spread over speed
(:func:`timegap_weights`, :func:`timegap_update`), the safety filter (:func:`safety_filter`)
and no bin moving against the pedal (:func:`with_pedal`). Gaps in m, speeds in m/s.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from dbc.vocab.dgpt import Dgpt, SafetyBounds, clamp_to_bounds


class TimegapStep(Protocol):
    """What a time-gap update reads of the adaptation's parameters
    (``ecu.adaptation.AdaptationParams`` has them)."""

    @property
    def min_speed_mps(self) -> float: ...
    @property
    def step_fraction(self) -> float: ...
    @property
    def spread_speed_mps(self) -> float: ...


def spread_weights(n_bins: int, centre: int, window_size: int) -> np.ndarray:
    """Triangular update weights, shape ``(n_bins,)``: 1 at ``centre``, 0 outside the window."""
    half = (window_size - 1) // 2
    idx = np.arange(n_bins)
    w = 1.0 - np.abs(idx - centre) / (half + 1)
    return np.clip(w, 0.0, 1.0)


def timegap_weights(speed_mps: np.ndarray, v_mps: float, spread_speed_mps: float) -> np.ndarray:
    """Gaussian update weights over speed, shape of ``speed_mps``: ``exp(-((v_i - v)/s)^2 / 2)``."""
    return np.exp(-0.5 * ((speed_mps - v_mps) / spread_speed_mps) ** 2)


def timegap_update(table: Dgpt, centre: int, g_desire_m: float, params: TimegapStep) -> np.ndarray:
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
