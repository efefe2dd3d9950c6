"""Ego longitudinal dynamics: eq. 1-2 of the paper with the sign fix of docs/paper-notes.md.

    v[t+1] = v[t] + a[t]·Δt + σ_v·n_v
    g[t+1] = g[t] + (v_f[t] − v[t])·Δt + ½·(a_f[t] − a[t])·Δt² + σ_g·n_g

n ~ N(0, 1), σ per 0.1 s (the paper's step) whatever Δt; a first-order actuator lag
(``actuator_tau_s``); the speed stops at zero; a gap <= 0 is a recorded collision.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sim_bus.errors import DriveError

#: the paper's sample period, the reference of the noise standard deviations (s)
NOISE_REF_DT_S = 0.1


@dataclass(frozen=True)
class PlantConfig:
    """Ego dynamics parameters (units in the names)."""

    dt_s: float = 0.01
    actuator_tau_s: float = 0.4
    sigma_v_mps: float = 0.01
    sigma_g_m: float = 0.01
    accel_min_mps2: float = -8.0
    accel_max_mps2: float = 4.0

    def __post_init__(self) -> None:
        # comparisons written so that NaN fails them too
        if not (0 < self.dt_s < math.inf and 0 <= self.actuator_tau_s < math.inf):
            raise DriveError("dt_s must be > 0 and actuator_tau_s >= 0 (finite)")
        if not (0 <= self.sigma_v_mps < math.inf and 0 <= self.sigma_g_m < math.inf):
            raise DriveError("noise standard deviations must be finite and >= 0")
        if not -math.inf < self.accel_min_mps2 < 0 < self.accel_max_mps2 < math.inf:
            raise DriveError("need finite accel_min_mps2 < 0 < accel_max_mps2")


@dataclass(frozen=True)
class PlantState:
    """Ego state: speed (m/s), actual acceleration (m/s²), gap to the lead (m), position (m)."""

    v_mps: float
    a_mps2: float
    gap_m: float
    x_m: float = 0.0


def lag_factor(dt_s: float, tau_s: float) -> float:
    """Exact discrete factor of a first-order lag: a += k·(a_cmd − a), k = 1 − exp(−Δt/τ)."""
    return 1.0 if tau_s <= 0.0 else 1.0 - math.exp(-dt_s / tau_s)


def step(
    v: float,
    a: float,
    g: float,
    x: float,
    a_cmd: float,
    v_f: float,
    a_f: float,
    dt: float,
    k_lag: float,
    a_lo: float,
    a_hi: float,
    dv_noise: float,
    dg_noise: float,
) -> tuple[float, float, float, float]:
    """One plant step (pure, floats): speed m/s, acceleration m/s², gap m and position m
    after ``dt`` s under command ``a_cmd`` (clipped to [a_lo, a_hi], lagged by ``k_lag``), the
    lead at ``v_f``, ``a_f``, and the scaled noise increments."""
    a_cmd = a_lo if a_cmd < a_lo else a_hi if a_cmd > a_hi else a_cmd
    a = a + k_lag * (a_cmd - a)
    a_eff = a
    if v + a * dt < 0.0:  # stops within the step: travel v²/(2|a|), then stand still
        a_eff = -v / dt if dt > 0 else 0.0
    dx = v * dt + 0.5 * a_eff * dt * dt
    v_new = v + a_eff * dt + dv_noise
    v_new = 0.0 if v_new < 0.0 else v_new  # max(v_new, 0.0) without the builtin's call
    g_new = g + (v_f - v) * dt + 0.5 * (a_f - a_eff) * dt * dt + dg_noise
    if v_new == 0.0 and a < 0.0:
        a = 0.0  # held by the brakes at standstill
    return v_new, a, g_new, x + dx


class Plant:
    """Stateful :func:`step` for the hot loop: floats, noise drawn from ``rng`` in blocks
    (none with both sigmas zero)."""

    def __init__(self, cfg: PlantConfig, initial: PlantState, rng: np.random.Generator) -> None:
        self.cfg = cfg
        self.v_mps, self.a_mps2 = initial.v_mps, initial.a_mps2
        self.gap_m, self.x_m = initial.gap_m, initial.x_m
        self.collided = initial.gap_m <= 0.0
        self.collision_t_s: float | None = 0.0 if self.collided else None
        self.t_s = 0.0
        self._k = lag_factor(cfg.dt_s, cfg.actuator_tau_s)
        scale = math.sqrt(cfg.dt_s / NOISE_REF_DT_S)
        self._sv, self._sg = scale * cfg.sigma_v_mps, scale * cfg.sigma_g_m
        self._rng = rng
        self._quiet = self._sv == 0.0 and self._sg == 0.0
        #: a block of N(0, 1) draws, (speed, gap) pairs flattened into Python floats
        self._noise: list[float] = []
        self._i = 0

    def advance(self, a_cmd_mps2: float, v_lead_mps: float, a_lead_mps2: float) -> None:
        """Advance one step of ``cfg.dt_s`` with the given command and lead motion."""
        cfg = self.cfg
        if self._quiet:  # _next_noise, without the call
            nv = ng = 0.0
        else:
            i = self._i
            if i >= len(self._noise):
                # the next block: the draws of a (4096, 2) array, as Python floats
                self._noise, i = self._rng.standard_normal((4096, 2)).ravel().tolist(), 0
            noise = self._noise
            self._i = i + 2
            nv, ng = self._sv * noise[i], self._sg * noise[i + 1]
        if not math.isfinite(a_cmd_mps2):
            a_cmd_mps2 = 0.0
        self.v_mps, self.a_mps2, self.gap_m, self.x_m = step(
            self.v_mps,
            self.a_mps2,
            self.gap_m,
            self.x_m,
            a_cmd_mps2,
            v_lead_mps,
            a_lead_mps2,
            cfg.dt_s,
            self._k,
            cfg.accel_min_mps2,
            cfg.accel_max_mps2,
            nv,
            ng,
        )
        self.t_s += cfg.dt_s
        if self.gap_m <= 0.0 and not self.collided:
            self.collided, self.collision_t_s = True, self.t_s
