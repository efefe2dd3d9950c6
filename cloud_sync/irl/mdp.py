"""The car-following MDP of the paper, discretised: grid, sparse transitions, reward features.

State ``s = (v, g, dv)``: ego speed (m/s), gap (m), lead minus ego speed (m/s); action: ego
acceleration (m/s²) from a fixed set; one decision every ``dt_s`` s:
``v' = v + a·dt + ε_v`` (eq. 1), ``dv' = dv + (a_f − a)·dt − ε_v``, ``g' = g + dv·dt +
½·(a_f − a)·dt²`` (eq. 2, sign corrected). Lead acceleration and speed noise are three-point
{−h, 0, +h} distributions; next states are spread by multilinear interpolation, clipped to the
grid. Index: ``s = (iv·n_gap + ig)·n_dv + idv``; state-action row ``s·n_actions + a``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from cloud_sync.errors import TrainingError


@dataclass(frozen=True)
class GridConfig:
    """Discretisation and noise of the MDP (units in names; defaults: 1 s decisions, 1 m/s
    and 2 m steps, ten accelerations within −3.0…+2.0 m/s², ±6 m/s relative speed)."""

    dt_s: float = 1.0
    v_step_mps: float = 1.0
    gap_step_m: float = 2.0
    dv_step_mps: float = 1.0
    dv_max_mps: float = 6.0
    accels_mps2: tuple[float, ...] = (-3.0, -2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0)
    lead_accel_sigma_mps2: float = 0.5
    speed_noise_sigma_mps: float = 0.2
    v_margin_mps: float = 3.0
    gap_margin_m: float = 10.0
    gap_cap_m: float = 150.0

    def __post_init__(self) -> None:
        positive = ("dt_s", "v_step_mps", "gap_step_m", "dv_step_mps", "dv_max_mps")
        for name in positive:
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise TrainingError(f"GridConfig.{name} must be finite and > 0, got {value}")
        if len(self.accels_mps2) < 2 or sorted(self.accels_mps2) != list(self.accels_mps2):
            raise TrainingError("GridConfig.accels_mps2 needs >= 2 increasing accelerations")
        if self.lead_accel_sigma_mps2 * self.dt_s > self.dv_step_mps:
            raise TrainingError("lead_accel_sigma_mps2·dt_s must not exceed dv_step_mps")
        if self.speed_noise_sigma_mps > self.v_step_mps:
            raise TrainingError("speed_noise_sigma_mps must not exceed v_step_mps")


@dataclass(frozen=True)
class Grid:
    """The axes of a discretised MDP, each a 1-D float array (units in names)."""

    v_mps: np.ndarray
    gap_m: np.ndarray
    dv_mps: np.ndarray
    accels_mps2: np.ndarray
    dt_s: float

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(n_v, n_gap, n_dv)``."""
        return (self.v_mps.size, self.gap_m.size, self.dv_mps.size)

    @property
    def n_states(self) -> int:
        """Number of states ``n_v·n_gap·n_dv``."""
        return int(np.prod(self.shape))

    @property
    def n_actions(self) -> int:
        """Number of actions."""
        return int(self.accels_mps2.size)

    def spec(self) -> dict[str, float | int | list[float]]:
        """A JSON-serialisable description from which :func:`grid_from_spec` rebuilds it."""
        return {
            "v_min_mps": float(self.v_mps[0]),
            "v_step_mps": float(self.v_mps[1] - self.v_mps[0]),
            "n_v": int(self.v_mps.size),
            "gap_min_m": float(self.gap_m[0]),
            "gap_step_m": float(self.gap_m[1] - self.gap_m[0]),
            "n_gap": int(self.gap_m.size),
            "dv_min_mps": float(self.dv_mps[0]),
            "dv_step_mps": float(self.dv_mps[1] - self.dv_mps[0]),
            "n_dv": int(self.dv_mps.size),
            "accels_mps2": [float(a) for a in self.accels_mps2],
            "dt_s": float(self.dt_s),
        }


#: the spec's axes: (name, unit)
_AXES = (("v", "mps"), ("gap", "m"), ("dv", "mps"))


def _axis(lo: float, step: float, n: int) -> np.ndarray:
    return lo + step * np.arange(n, dtype=np.float64)


def grid_from_spec(spec: dict[str, object]) -> Grid:
    """Rebuild a :class:`Grid` from :meth:`Grid.spec` (raises :class:`TrainingError`)."""
    float_keys = [f"{k}_{part}_{u}" for k, u in _AXES for part in ("min", "step")] + ["dt_s"]
    try:
        f = {k: float(spec[k]) for k in float_keys}  # type: ignore[arg-type]
        n = {f"n_{k}": int(spec[f"n_{k}"]) for k, _ in _AXES}  # type: ignore[call-overload]
        accels = np.asarray(spec["accels_mps2"], dtype=np.float64)
    except (KeyError, TypeError, ValueError) as exc:
        raise TrainingError(f"invalid grid spec: {exc}") from exc
    if min(n.values()) < 2:
        raise TrainingError("invalid grid spec: every axis needs >= 2 points")
    v, gap, dv = (_axis(f[f"{k}_min_{u}"], f[f"{k}_step_{u}"], n[f"n_{k}"]) for k, u in _AXES)
    return Grid(v, gap, dv, accels, f["dt_s"])


def make_grid(config: GridConfig, v_max_mps: float, gap_max_m: float) -> Grid:
    """A grid covering speeds 0…``v_max_mps`` + margin and gaps 0…``gap_max_m`` + margin."""
    if not (math.isfinite(v_max_mps) and math.isfinite(gap_max_m)):
        raise TrainingError("grid ranges must be finite")
    v_top = max(v_max_mps, 0.0) + config.v_margin_mps
    n_v = int(math.ceil(v_top / config.v_step_mps)) + 1
    g_top = min(max(gap_max_m, 0.0) + config.gap_margin_m, config.gap_cap_m)
    n_g = int(math.ceil(g_top / config.gap_step_m)) + 1
    n_dv_half = int(math.ceil(config.dv_max_mps / config.dv_step_mps))
    v, gap = _axis(0.0, config.v_step_mps, max(n_v, 2)), _axis(0.0, config.gap_step_m, max(n_g, 2))
    dv = _axis(-n_dv_half * config.dv_step_mps, config.dv_step_mps, 2 * n_dv_half + 1)
    return Grid(v, gap, dv, np.asarray(config.accels_mps2, dtype=np.float64), config.dt_s)


def interp_weights(axis: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Linear interpolation of ``x`` (any shape) on a uniform ``axis`` (n,), clipped:
    ``(i0, i1, w1)`` shaped as ``x``, the neighbours and the weight of ``i1``."""
    step = axis[1] - axis[0]
    pos = np.clip((x - axis[0]) / step, 0.0, axis.size - 1)
    i0 = np.minimum(np.floor(pos).astype(np.int64), axis.size - 2)
    w1 = pos - i0
    return i0, i0 + 1, w1


def _three_point(sigma: float, h: float) -> list[tuple[float, float]]:
    """Offsets and probabilities of a zero-mean 3-point law with variance ``sigma²``."""
    if sigma <= 0.0:
        return [(0.0, 1.0)]
    p = min((sigma / h) ** 2, 1.0)
    return [(-h, p / 2.0), (0.0, 1.0 - p), (h, p / 2.0)]


def build_transitions(grid: Grid, config: GridConfig) -> sp.csr_matrix:
    """The transitions ``P`` (n_states·n_actions, n_states), CSR, rows sum to 1:
    ``P[s·n_actions + a, s']`` is the probability of ``s'`` after action ``a`` in ``s``."""
    _, n_g, n_dv = grid.shape
    axes = (grid.v_mps, grid.gap_m, grid.dv_mps, grid.accels_mps2)
    v, g, dv, a = (x.ravel() for x in np.meshgrid(*axes, indexing="ij"))  # row by row
    dt = grid.dt_s
    lead = _three_point(config.lead_accel_sigma_mps2, (grid.dv_mps[1] - grid.dv_mps[0]) / dt)
    noise = _three_point(config.speed_noise_sigma_mps, grid.v_mps[1] - grid.v_mps[0])
    # the candidates (lead·noise·8 corners, rows), in the order of the loops
    n_cand = len(lead) * len(noise) * 8
    cols = np.empty((n_cand, v.size), dtype=np.int32)
    vals = np.empty((n_cand, v.size))
    k = 0
    for a_f, p_f in lead:
        for e_v, p_v in noise:
            v1 = v + a * dt + e_v
            dv1 = dv + (a_f - a) * dt - e_v
            g1 = g + dv * dt + 0.5 * (a_f - a) * dt * dt
            v0i, v1i, wv = interp_weights(grid.v_mps, v1)
            g0i, g1i, wg = interp_weights(grid.gap_m, g1)
            d0i, d1i, wd = interp_weights(grid.dv_mps, dv1)
            for vi, vw in ((v0i, 1.0 - wv), (v1i, wv)):
                for gi, gw in ((g0i, 1.0 - wg), (g1i, wg)):
                    for di, dw in ((d0i, 1.0 - wd), (d1i, wd)):
                        vals[k] = p_f * p_v * vw * gw * dw
                        cols[k] = (vi * n_g + gi) * n_dv + di
                        k += 1
    keep = vals.T > 1e-12  # row by row, each row's candidates in loop order
    indptr = np.concatenate([[0], np.cumsum(keep.sum(axis=1))]).astype(np.int32)
    shape = (grid.n_states * grid.n_actions, grid.n_states)
    P = sp.csr_matrix((vals.T[keep], cols.T[keep], indptr), shape=shape)
    P.sum_duplicates()
    # renormalise rows against round-off of dropped tiny weights
    row_sum = np.asarray(P.sum(axis=1)).ravel()
    P = sp.diags(1.0 / row_sum) @ P
    return P.tocsr()
