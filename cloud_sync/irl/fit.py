"""The IRL optimisation: reward weights α that explain the demonstrations (L-BFGS-B).

:func:`start_alpha` (the prior α or zeros plus N(0, 10⁻³) noise from the seed; the objective is
convex) and :func:`fit_alpha` (minimises :func:`cloud_sync.irl.mce_irl.objective`; a :class:`Fit`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy import optimize
from tqdm import tqdm

from cloud_sync.irl.config import IrlConfig
from cloud_sync.irl.mce_irl import CompiledMdp, DemoStats, objective

__all__ = ["Fit", "start_alpha", "fit_alpha"]


@dataclass(frozen=True)
class Fit:
    """The outcome of :func:`fit_alpha`: ``alpha`` (K,), iterations, whether the stopping
    rule was met and the optimiser's message, the final objective, wall time ``train_s`` (s)."""

    alpha: np.ndarray
    n_iter: int
    converged: bool
    message: str
    objective: float
    train_s: float


def start_alpha(n_features: int, prior: np.ndarray | None, seed: int) -> np.ndarray:
    """``prior`` (or zeros), shape (K,), plus N(0, 10⁻³) noise from ``default_rng(seed)``."""
    rng = np.random.default_rng(seed)
    alpha0 = prior.copy() if prior is not None else np.zeros(n_features)
    return np.asarray(alpha0 + rng.normal(0.0, 1e-3, n_features))


def fit_alpha(
    mdp: CompiledMdp,
    stats: DemoStats,
    alpha0: np.ndarray,
    prior: np.ndarray | None,
    cfg: IrlConfig,
    progress: bool = False,
) -> Fit:
    """Minimise the MCE-IRL dual by L-BFGS-B from ``alpha0`` (K,), L2 (``cfg.l2``) towards
    ``prior`` (stops at ``cfg.max_iter``, ``gtol``, ``ftol``); TrainingError if it diverges."""
    bar = tqdm(total=cfg.max_iter, desc="IRL", unit="it", leave=False) if progress else None

    def fun(alpha: np.ndarray) -> tuple[float, np.ndarray]:
        return objective(alpha, mdp, stats, l2=cfg.l2, prior=prior)

    def show(intermediate_result: optimize.OptimizeResult) -> None:
        if bar is not None:
            bar.update(1)
            bar.set_postfix(f=f"{intermediate_result.fun:.4f}")

    t0 = time.perf_counter()
    try:
        options = {"maxiter": cfg.max_iter, "gtol": cfg.gtol, "ftol": cfg.ftol}
        callback = show if bar is not None else None
        res = optimize.minimize(
            fun, alpha0, jac=True, method="L-BFGS-B", callback=callback, options=options
        )
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - t0
    return Fit(
        np.asarray(res.x), int(res.nit), bool(res.success), str(res.message), float(res.fun), wall
    )
