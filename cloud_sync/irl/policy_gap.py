"""The gap the learned policy keeps in steady following: the DGPT of a fitted reward.

The table is read from the soft-optimal policy, not the reward's argmax (which sat 3–6 m off
the steady gaps of the OpenACC followers; docs/irl.md). :func:`steady_drift`: ``E_π[a | v, g,
dv = 0]`` (m/s²) and the soft value on the grid's (v, g); :func:`steady_gaps`: per DGPT speed,
the gap (m) where that drift changes sign from braking to accelerating, the highest-value one
if several, else the demonstrated range's edge. Pure functions.
"""

from __future__ import annotations

import numpy as np

from cloud_sync.irl.mce_irl import CompiledMdp, reward_table, soft_value_iteration
from cloud_sync.irl.mdp import interp_weights

__all__ = ["steady_drift", "steady_gaps"]


def steady_drift(
    mdp: CompiledMdp, alpha: np.ndarray, horizon: int
) -> tuple[np.ndarray, np.ndarray]:
    """``(drift, value)``, each (n_v, n_gap) on ``mdp.grid``: the soft-optimal policy's
    expected acceleration (m/s²) with ``horizon`` steps to go at relative speed 0 (linearly
    interpolated on the dv axis), and the soft value of those states."""
    grid = mdp.grid
    n_v, n_g, n_dv = grid.shape
    V, pi = soft_value_iteration(mdp.P, reward_table(mdp, alpha), horizon)
    ea = (pi[horizon - 1] @ grid.accels_mps2).reshape(n_v, n_g, n_dv)
    value = V[horizon].reshape(n_v, n_g, n_dv)
    i0, i1, w1 = interp_weights(grid.dv_mps, np.zeros(1))
    w = float(w1[0])
    drift = (1.0 - w) * ea[:, :, int(i0[0])] + w * ea[:, :, int(i1[0])]
    val = (1.0 - w) * value[:, :, int(i0[0])] + w * value[:, :, int(i1[0])]
    return np.asarray(drift), np.asarray(val)


def _along_speed(table: np.ndarray, grid_v: np.ndarray, v: float) -> np.ndarray:
    """Row of ``table`` (n_v, m) linearly interpolated at speed ``v``: (m,)."""
    i0, i1, w1 = interp_weights(grid_v, np.asarray([v]))
    w = float(w1[0])
    return np.asarray((1.0 - w) * table[int(i0[0])] + w * table[int(i1[0])])


def steady_gaps(
    drift: np.ndarray,
    value: np.ndarray,
    grid_v_mps: np.ndarray,
    grid_gap_m: np.ndarray,
    axis_mps: np.ndarray,
    support: tuple[np.ndarray, np.ndarray],
) -> np.ndarray:
    """The steady-following gap (n,) at each speed of ``axis_mps``: ``drift``, ``value``
    (n_v, n_gap) on the grid axes, ``support`` (lo, hi) (n,) each; NaN where the support is NaN
    or the speed lies above the grid."""
    out = np.full(axis_mps.size, np.nan)
    g = grid_gap_m
    for k, v in enumerate(axis_mps.tolist()):
        lo, hi = float(support[0][k]), float(support[1][k])
        if not (np.isfinite(lo) and np.isfinite(hi)) or v > grid_v_mps[-1] + 1e-9:
            continue
        d = _along_speed(drift, grid_v_mps, v)
        val = _along_speed(value, grid_v_mps, v)
        up = np.flatnonzero((d[:-1] < 0.0) & (d[1:] >= 0.0))
        x = g[up] + (g[up + 1] - g[up]) * (-d[up]) / (d[up + 1] - d[up])
        inside = (x >= lo) & (x <= hi)
        if inside.any():
            cand = x[inside]
            out[k] = float(cand[np.argmax(np.interp(cand, g, val))])
        else:
            # no gap to return to inside the range: the policy drives the gap to an edge
            # (accelerating everywhere: the lower one; braking everywhere: the upper one;
            # pushed away from an unstable gap: the edge of higher soft value)
            d_lo, d_hi = np.interp([lo, hi], g, d)
            if d_lo >= 0.0 and d_hi >= 0.0:
                out[k] = lo
            elif d_lo < 0.0 and d_hi < 0.0:
                out[k] = hi
            else:
                v_lo, v_hi = np.interp([lo, hi], g, val)
                out[k] = lo if v_lo >= v_hi else hi
    return out
