"""``bayes``: an online adaptation that keeps an uncertainty per speed bin (a Kalman filter).

A Gaussian belief over the table in time-gap space, prior
``P_ij = (sigma_h u_i)(sigma_h u_j) exp(-(v_i - v_j)^2 / (2 l^2))``, ``u = max(v, v_min)``.
A takeover passing Algorithm 1's behaviour filter is one observation ``z = g_desire`` of the
bin at the release speed (noise ``(sigma_obs u_c)^2``); process noise ``q`` per update lets
it follow a drifting preference. The pedal's direction, short-press runs and the safety
bounds apply as in :mod:`ecu.adaptation`. Units: gaps m, speeds m/s, ``sigma_*``, ``q`` s.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from dbc.vocab.dgpt import Dgpt, SafetyBounds
from ecu.adaptation import (
    AdaptationParams,
    Decision,
    Reason,
    TakeoverSummary,
    against_pedal,
    applied,
    behaviour_filter,
    centre_bin,
    predict_steady_gap,
    safety_filter,
    with_pedal,
)


@dataclasses.dataclass(frozen=True)
class BayesParams:
    """Parameters of :class:`BayesAdaptation`: prior and observation standard deviations of the
    time gap (s; 0.4 s about the spread of preferred time gaps among the OpenACC drivers), the
    correlation length over speed (m/s), the drift per update (s), the slowest speed (m/s)."""

    prior_sigma_s: float = 0.4
    obs_sigma_s: float = 0.3
    length_mps: float = 15.0
    process_sigma_s: float = 0.05
    min_speed_mps: float = 10.0

    def __post_init__(self) -> None:
        values = dataclasses.astuple(self)
        if not all(isinstance(x, float | int) and math.isfinite(x) and x > 0 for x in values):
            raise ValueError(f"bayes parameters must be finite and > 0: {self}")


def prior_covariance(speed_mps: np.ndarray, sigma_s: float, p: BayesParams) -> np.ndarray:
    """The (n, n) covariance of the table's gaps (m^2) for a time-gap deviation ``sigma_s``."""
    u = np.maximum(speed_mps, p.min_speed_mps) * sigma_s
    dv = speed_mps[:, None] - speed_mps[None, :]
    return np.asarray(np.outer(u, u) * np.exp(-0.5 * (dv / p.length_mps) ** 2))


class BayesAdaptation:
    """The Bayesian adaptation (module docstring). One object per ECU: it keeps the belief."""

    def __init__(self, **fields: Any) -> None:
        names = {f.name for f in dataclasses.fields(BayesParams)}
        self.params = BayesParams(**{k: v for k, v in fields.items() if k in names})
        self.rule = AdaptationParams(**{k: v for k, v in fields.items() if k not in names})
        self._cov: np.ndarray | None = None
        self._table: Dgpt | None = None

    def variance_m2(self) -> np.ndarray | None:
        """The current per-bin variance of the table, m^2 (None before the first takeover)."""
        return None if self._cov is None else np.diag(self._cov).copy()

    def update(
        self,
        table: Dgpt,
        takeover: TakeoverSummary,
        *,
        bounds: SafetyBounds,
        short_run: bool,
        created_utc: str,
    ) -> tuple[Dgpt | None, Decision]:
        """One Kalman update of the table from the takeover (None: unchanged)."""
        reason = behaviour_filter(takeover, self.rule, short_run=short_run)
        if reason is not Reason.APPLIED:
            return None, Decision(applied=False, reason=reason)
        speed = table.speed_mps
        if self._table is not table or self._cov is None:  # a new table: a fresh belief
            self._cov = prior_covariance(speed, self.params.prior_sigma_s, self.params)
        g_desire = predict_steady_gap(takeover, self.rule)
        centre = centre_bin(table, takeover.v_mps)
        if against_pedal(takeover.pedal, g_desire - float(table.gap_m[centre])):
            return None, Decision(applied=False, reason=Reason.AGAINST_PEDAL, g_desire_m=g_desire)
        p = self.params
        cov = self._cov
        u_c = max(float(speed[centre]), p.min_speed_mps)
        gain = cov[:, centre] / (cov[centre, centre] + (p.obs_sigma_s * u_c) ** 2)
        gap = table.gap_m + gain * (g_desire - float(table.gap_m[centre]))
        cov = cov - np.outer(gain, cov[centre, :])
        self._cov = cov + prior_covariance(speed, p.process_sigma_s, p)
        gap = with_pedal(table.gap_m, safety_filter(speed, gap, bounds), takeover.pedal)
        new = table.with_gaps(gap, "adapted", created_utc=created_utc)
        self._table = new
        return new, applied(table, new, centre, g_desire)
