"""Car-following models checked against real trajectories: fit on the first part, replay the rest.

Per real follower, each model is calibrated on the first part by minimising the spacing NRMSE
(``rms(s_sim − s) / rms(s)``) of a closed-loop replay of the real lead, then scored from the
real state at the split on the held-out rest (Punzo, Zheng & Montanino, Transportation
Research C 128, 2021). Models (parameters in ``MODELS`` order): ``driver`` IDM+ (Schakel et
al., 2010; :func:`sim_bus.idm.idm_plus_accel`) around a time headway over speed (linear from
10 to 30 m/s, held outside, as the drivers' own table) seeing the lead ``reaction_s`` late; ``idm``
(Treiber, Hennecke & Helbing, 2000); ``ctg`` ``a = k1·(s − s0 − T·v) + k2·(v_l − v)``
(Milanés & Shladover, Transportation Research C 48, 2014); ``gipps`` (Gipps, 1981).
Simulations are vectorised over parameter sets (P, k) for scipy's differential evolution.
Units: m, m/s, s.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import differential_evolution

from sim_bus.dataset import HumanPair
from sim_bus.idm import DECEL_LIMIT_MPS2

Bounds = tuple[tuple[float, float], ...]
#: parameter bounds per model: driver (a_max, b, T₁₀, s0, v0, reaction, T₃₀; T₁₀ and T₃₀ the
#: headways at 10 and 30 m/s), idm (a, b, T, s0, v0), ctg (k1, k2, T, s0), gipps (a, b, b̂, τ,
#: s0, V); ranges of the field's calibrations
MODELS: dict[str, Bounds] = {
    "driver": (
        (0.3, 4.0),
        (0.5, 5.0),
        (0.3, 3.5),
        (0.5, 8.0),
        (20.0, 50.0),
        (0.0, 1.5),
        (0.3, 3.5),
    ),
    "idm": ((0.3, 4.0), (0.5, 5.0), (0.3, 3.5), (0.5, 8.0), (20.0, 50.0)),
    "ctg": ((0.01, 1.0), (0.01, 2.0), (0.3, 3.5), (0.5, 8.0)),
    "gipps": ((0.3, 4.0), (0.5, 5.0), (0.5, 6.0), (0.1, 1.5), (0.5, 8.0), (20.0, 50.0)),
}
#: the calibrated share of each trajectory; the rest is held out
CALIBRATION_SHARE = 0.5
#: spacing error given to a parameter set that collides in the replay
COLLISION_NRMSE = 10.0


def _delayed(hist: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """``hist[rows[j], j]`` per column ``j`` (rows clamped at 0); hist (n, P)."""
    return np.asarray(hist[np.maximum(rows, 0), np.arange(hist.shape[1])])


def _accel(model: str, x: np.ndarray, v: np.ndarray, vl: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Acceleration (m/s²) of ``model`` (``driver``, ``idm`` or ``ctg``); x (P, k)."""
    if model == "ctg":
        return np.asarray(x[:, 0] * (s - x[:, 3] - x[:, 2] * v) + x[:, 1] * (vl - v))
    a, b, t, s0, v0 = x[:, 0], x[:, 1], x[:, 2], x[:, 3], x[:, 4]
    if model == "driver":
        t = t + (x[:, 6] - t) * np.clip((v - 10.0) / 20.0, 0.0, 1.0)
    s_star = s0 + t * v + v * (v - vl) / (2.0 * np.sqrt(a * b))
    s_eff = np.maximum(s, 0.1)
    free = 1.0 - (v / v0) ** 4
    if model == "idm":
        return np.asarray(a * (free - (np.maximum(s_star, 0.0) / s_eff) ** 2))
    follow = 1.0 - (np.maximum(s_star, 0.5 * s0) / s_eff) ** 2
    return np.asarray(a * np.minimum(free, follow))


def _gipps_speed(x: np.ndarray, v: np.ndarray, vl: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Gipps' speed τ later (m/s) from the state (v, v_l, s) now; x (P, 6)."""
    a, b, bh, tau, s0, vmax = (x[:, i] for i in range(6))
    v_acc = v + 2.5 * a * tau * (1.0 - v / vmax) * np.sqrt(0.025 + np.maximum(v, 0.0) / vmax)
    root = (b * tau) ** 2 + b * (2.0 * (s - s0) - v * tau + vl * vl / bh)
    v_dec = -b * tau + np.sqrt(np.maximum(root, 0.0))
    return np.asarray(np.maximum(np.minimum(v_acc, v_dec), 0.0))


def simulate(
    model: str, x: np.ndarray, pair: HumanPair, start: int, stop: int
) -> tuple[np.ndarray, np.ndarray]:
    """Replay ``pair``'s real lead from sample ``start`` (the real state, the real history
    before it) to ``stop`` with parameter sets ``x`` (P, k): gap, speed (stop − start, P)."""
    x = np.atleast_2d(np.asarray(x, dtype=np.float64))
    dt = pair.dt_s
    n_sets = x.shape[0]
    v_real, g_real, vl = pair.v_follower_mps, pair.gap_m, pair.v_leader_mps
    # the lead's position in the follower's frame: real follower distance + real gap
    x_f = np.concatenate(([0.0], np.cumsum(0.5 * (v_real[1:] + v_real[:-1]) * dt)))
    x_l = (x_f + g_real)[:stop]
    gap = np.repeat(g_real[:stop, None], n_sets, axis=1)
    vel = np.repeat(v_real[:stop, None], n_sets, axis=1)
    vl_hist = np.repeat(vl[:stop, None], n_sets, axis=1)
    pos = np.full(n_sets, x_f[start])
    if model == "gipps":
        lag = np.maximum(np.rint(x[:, 3] / dt).astype(np.int64), 1)
    elif model == "driver":
        lag = np.rint(x[:, 5] / dt).astype(np.int64)
    else:
        lag = np.zeros(n_sets, dtype=np.int64)
    for k in range(start, stop - 1):
        v = vel[k]
        if model == "gipps":
            j = k + 1 - lag
            v_new = _gipps_speed(x, _delayed(vel, j), _delayed(vl_hist, j), _delayed(gap, j))
        else:
            a = _accel(model, x, v, _delayed(vl_hist, k - lag), _delayed(gap, k - lag))
            a = np.clip(a, -DECEL_LIMIT_MPS2, 4.0)
            v_new = np.maximum(v + a * dt, 0.0)
        pos = pos + 0.5 * (v + v_new) * dt
        vel[k + 1] = v_new
        gap[k + 1] = x_l[k + 1] - pos
    return gap[start:], vel[start:]


def nrmse(sim: np.ndarray, real: np.ndarray) -> np.ndarray:
    """``rms(sim − real) / rms(real)`` per column of ``sim`` (n, P); real (n,)."""
    err = np.sqrt(np.mean((sim - real[:, None]) ** 2, axis=0))
    return np.asarray(err / np.sqrt(np.mean(real**2)))


@dataclass(frozen=True)
class Fit:
    """One model fitted to one real follower: its parameters and its errors (NRMSE)."""

    pair_id: str
    model: str
    params: tuple[float, ...]
    fit_spacing: float  # on the calibration part
    spacing: float  # held out
    speed: float  # held out


def _objective(
    model: str, pair: HumanPair, start: int, stop: int
) -> Callable[[np.ndarray], np.ndarray]:
    def f(xt: np.ndarray) -> np.ndarray:
        gap, _ = simulate(model, xt.T, pair, start, stop)
        err = nrmse(gap, pair.gap_m[start:stop])
        return np.where(np.min(gap, axis=0) <= 0.0, COLLISION_NRMSE, err)

    return f


def fit_pair(
    model: str,
    pair: HumanPair,
    *,
    seed: int = 0,
    maxiter: int = 40,
    popsize: int = 10,
    reverse: bool = False,
) -> Fit:
    """Calibrate ``model`` on the first :data:`CALIBRATION_SHARE` of ``pair``; score the rest
    (``reverse``: calibrate on the rest, score the first part, from the real state at its
    start)."""
    n = len(pair.gap_m)
    split = int(n * CALIBRATION_SHARE)
    fit_part, test_part = ((split, n), (0, split)) if reverse else ((0, split), (split, n))
    res = differential_evolution(
        _objective(model, pair, *fit_part),
        MODELS[model],
        seed=seed,
        maxiter=maxiter,
        popsize=popsize,
        tol=1e-4,
        polish=False,
        vectorized=True,
        updating="deferred",
    )
    gap, vel = simulate(model, res.x, pair, *test_part)
    a, b = test_part
    return Fit(
        pair.pair_id,
        model,
        tuple(round(float(p), 4) for p in res.x),
        float(res.fun),
        float(nrmse(gap, pair.gap_m[a:b])[0]),
        float(nrmse(vel, pair.v_follower_mps[a:b])[0]),
    )


#: the driver model's dynamics parameters that make the population's prior, by index
PRIOR_PARAMS = {"accel_max_mps2": 0, "decel_comfort_mps2": 1, "reaction_s": 5}


def dynamics_prior(fits: list[Fit]) -> dict[str, tuple[float, float]]:
    """(median, sd of the log) over the real followers of each :data:`PRIOR_PARAMS` entry of
    the ``driver`` fits: the population's prior (``sim_bus.population.FOLLOWING_PRIOR``)."""
    mine = np.array([f.params for f in fits if f.model == "driver"])
    out = {}
    for name, i in PRIOR_PARAMS.items():
        x = np.maximum(mine[:, i], 1e-3)
        out[name] = (float(np.median(x)), float(np.std(np.log(x), ddof=1)))
    return out
