"""The built-in learners ``irl``, ``empirical`` and ``gp`` as implementations of the interface.

``gp``: a Gaussian process of the driver's steady-state gap over speed (numpy only).

Data: per speed bin the median steady-state gap ``y_i`` (m) and its seconds ``w_i``. Model
``g(v) = d0 + h·v + f(v)``: a weighted least-squares time-gap line plus a GP with the
squared-exponential kernel ``s² exp(−(v − v')²/(2 l²))`` and noise ``σ²/w_i`` (m²), ``s``, ``l``,
``σ`` maximising the log marginal likelihood on a small grid. The table is the posterior mean
where the posterior sd is below ``cover_ratio·s``, continued in time gap elsewhere.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np

from cloud_sync.errors import DemoError
from cloud_sync.irl import demos as dm
from cloud_sync.irl.config import IrlConfig
from cloud_sync.irl.extract import (
    continue_time_gap,
    empirical_baseline,
    outside_coverage,
    steady_state_gaps,
)
from cloud_sync.irl.trainer import learn_dgpt
from dbc.vocab.dgpt import Dgpt, SafetyBounds, clamp_to_bounds, speed_axis
from dbc.vocab.triplog import Trip


class IrlLearner:
    """Maximum causal entropy IRL (:func:`~cloud_sync.irl.trainer.learn_dgpt`); parameters:
    any field of :class:`~cloud_sync.irl.trainer.IrlConfig`."""

    def __init__(self, **fields: Any) -> None:
        self.config = IrlConfig(**fields)

    def learn(self, trips: Sequence[Trip], *, driver_id: str, seed: int) -> Dgpt:
        """The IRL table; meta ``covered`` = the bins the demonstrations set."""
        res = learn_dgpt(list(trips), driver_id=driver_id, seed=seed, config=self.config)
        meta = {**res.table.meta, "method": "irl", "covered": res.covered.tolist()}
        return dataclasses.replace(res.table, meta=meta)


class EmpiricalLearner:
    """The median steady-state gap per speed bin (:func:`~cloud_sync.irl.trainer.
    empirical_baseline`); parameters: any field of :class:`~cloud_sync.irl.trainer.IrlConfig`
    (``max_gap_m``, ``min_coverage_s``, ``bounds``, ...)."""

    def __init__(self, **fields: Any) -> None:
        self.config = IrlConfig(**fields)

    def learn(self, trips: Sequence[Trip], *, driver_id: str, seed: int) -> Dgpt:
        """The baseline table (``seed`` is unused: the baseline is deterministic)."""
        return empirical_baseline(trips, driver_id=driver_id, config=self.config)


#: the hyper-parameter grid: signal sd s (m), length scale l (m/s), noise sigma (m s^0.5)
SIGNAL_M = (1.0, 3.0, 6.0)
LENGTH_MPS = (2.0, 4.0, 8.0, 16.0)
NOISE_M = (1.0, 3.0, 6.0)


def _kernel(a: np.ndarray, b: np.ndarray, s: float, ell: float) -> np.ndarray:
    return np.asarray(s * s * np.exp(-0.5 * ((a[:, None] - b[None, :]) / ell) ** 2))


def linear_mean(v: np.ndarray, y: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """``(d0 m, h s)`` of the weighted least-squares line ``y ~ d0 + h v`` (``h >= 0``)."""
    x = np.column_stack([np.ones_like(v), v]) * np.sqrt(w)[:, None]
    coef, *_ = np.linalg.lstsq(x, y * np.sqrt(w), rcond=None)
    d0, h = float(coef[0]), float(coef[1])
    if h < 0.0 or v.size < 2:
        return float(np.average(y, weights=w)), 0.0
    return d0, h


def log_marginal(r: np.ndarray, k: np.ndarray) -> float:
    """Log marginal likelihood of residuals ``r`` (n,) under covariance ``k`` (n, n)."""
    try:
        chol = np.linalg.cholesky(k)
    except np.linalg.LinAlgError:
        return -np.inf
    alpha = np.linalg.solve(chol.T, np.linalg.solve(chol, r))
    return float(-0.5 * r @ alpha - np.log(np.diag(chol)).sum() - 0.5 * r.size * np.log(2 * np.pi))


class GpLearner:
    """The GP learner (module docstring). Parameters: ``max_gap_m`` (120 m, samples beyond
    are no following), ``min_coverage_s`` (2.5 s of steady samples make a bin an
    observation), ``cover_ratio`` (0.5), ``bounds`` (the table's :class:`SafetyBounds`)."""

    def __init__(
        self,
        max_gap_m: float = 120.0,
        min_coverage_s: float = 2.5,
        cover_ratio: float = 0.5,
        bounds: SafetyBounds | None = None,
        **_: Any,
    ) -> None:
        self.max_gap_m = max_gap_m
        self.min_coverage_s = min_coverage_s
        self.cover_ratio = cover_ratio
        self.bounds = bounds if bounds is not None else SafetyBounds()

    def learn(self, trips: Sequence[Trip], *, driver_id: str, seed: int) -> Dgpt:
        """The GP table; DemoError without enough steady-state following."""
        dm.check_demos(trips, max_gap_m=self.max_gap_m, min_total_s=1.0)
        s = dm.pooled_samples(trips, self.max_gap_m)
        axis = speed_axis()
        raw, count = steady_state_gaps(axis, s.v_mps, s.gap_m, s.dv_mps, s.a_mps2)
        dt = float(np.median(s.dt_s)) if s.dt_s.size else 0.1
        w = count * dt
        obs = np.isfinite(raw) & (w >= self.min_coverage_s)
        if obs.sum() < 2:
            raise DemoError("too little steady-state following for the GP learner")
        v, y, wo = axis[obs], raw[obs], w[obs]
        d0, h = linear_mean(v, y, wo)
        r = y - (d0 + h * v)
        best = max(
            itertools.product(SIGNAL_M, LENGTH_MPS, NOISE_M),
            key=lambda p: log_marginal(r, _kernel(v, v, p[0], p[1]) + np.diag(p[2] ** 2 / wo)),
        )
        sig, ell, noise = best
        k = _kernel(v, v, sig, ell) + np.diag(noise**2 / wo)
        ks = _kernel(axis, v, sig, ell)
        mean = d0 + h * axis + ks @ np.linalg.solve(k, r)
        var = sig * sig - np.einsum("ij,ji->i", ks, np.linalg.solve(k, ks.T))
        sd = np.sqrt(np.maximum(var, 0.0))
        near = (axis >= v.min() - 1.0) & (axis <= v.max() + 1.0)
        covered = near & (sd < self.cover_ratio * sig)
        gap = continue_time_gap(axis, mean, covered, self.bounds.standstill_m)
        gap = np.asarray(clamp_to_bounds(axis, gap, self.bounds))
        return Dgpt(
            speed_mps=axis,
            gap_m=gap,
            version=1,
            driver_id=driver_id,
            source="irl",
            meta={
                "method": "gp",
                "covered": covered.tolist(),
                "outside_coverage": outside_coverage(axis, covered),
                "gp": {"signal_m": sig, "length_mps": ell, "noise_m": noise, "d0_m": d0, "h_s": h},
                "training_digest": dm.digest(trips, [1.0] * len(trips)),
            },
        )
