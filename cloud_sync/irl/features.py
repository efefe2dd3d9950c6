"""Reward features: Gaussian radial basis functions over (v, g), plus two comfort terms.

    r(s, a) = κ(dv)·Σ_ij α_ij·φ_i(v)·ψ_j(u(v, g))  +  α_dv·(−(dv/dv_max)²)  +  α_a·(−(a/a_max)²)

``φ_i``, ``ψ_j`` Gaussian RBFs in speed (m/s) and a gap coordinate ``u``; ``κ(dv) =
exp(−½(dv/w_dv)²)`` weights steady following (1 when ``dv_width_mps`` is 0). ``u`` is the time
gap ``g/max(v, v_floor)`` (s, :func:`make_time_gap_features`, the default) or ``g − ℓ(v)`` (m)
from a fitted line (:func:`make_features`). Layout of ``alpha``: ``A.ravel()`` (n_cv, n_cg),
then ``alpha_dv``, ``alpha_a``. Rationale and measurements: docs/irl.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from cloud_sync.errors import TrainingError
from cloud_sync.irl.mdp import Grid

#: the gap coordinate of the RBFs: ``time_gap`` (default), ``g/max(v, floor)`` on fixed
#: centres, nothing fitted to the data; ``offset``, ``g − ℓ(v)`` from a reference line fitted
#: to the demonstrations (the earlier basis, kept for comparison and for tables that carry it)
GAP_BASES = ("time_gap", "offset")


@dataclass(frozen=True)
class FeatureConfig:
    """RBF layout (units in names): centre spacings, width as a multiple of the spacing, the
    ``gap_basis`` (:data:`GAP_BASES`) and its centres, κ(dv)'s width (0: none)."""

    v_spacing_mps: float = 2.0
    gap_spacing_m: float = 3.0
    width_ratio: float = 1.0
    offset_range_m: float = 30.0
    gap_basis: str = "time_gap"
    time_gap_spacing_s: float = 0.1
    time_gap_max_s: float = 6.0
    time_gap_floor_mps: float = 5.0
    dv_width_mps: float = 0.35

    def __post_init__(self) -> None:
        if self.gap_basis not in GAP_BASES:
            raise TrainingError(
                f"FeatureConfig.gap_basis must be one of {', '.join(GAP_BASES)}, "
                f"got {self.gap_basis!r}"
            )
        positive = "v_spacing_mps gap_spacing_m width_ratio time_gap_spacing_s time_gap_max_s"
        for name in (*positive.split(), "time_gap_floor_mps"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise TrainingError(f"FeatureConfig.{name} must be finite and > 0, got {value}")
        if not 0.0 <= self.dv_width_mps < math.inf:
            raise TrainingError(
                f"FeatureConfig.dv_width_mps must be finite and >= 0, got {self.dv_width_mps}"
            )


@dataclass(frozen=True)
class Features:
    """RBF centres (n_cv,), (n_cg,) and widths, the reference line, and on the grid: ``Bv``
    (n_v, n_cv), ``Bg`` (n_v, n_gap, n_cg), comfort ``f_dv`` (n_dv,), ``f_a`` (n_actions,),
    κ(dv) ``k_dv`` (n_dv,)."""

    v_centres_mps: np.ndarray
    gap_centres_m: np.ndarray
    v_width_mps: float
    gap_width_m: float
    Bv: np.ndarray
    Bg: np.ndarray
    f_dv: np.ndarray
    f_a: np.ndarray
    k_dv: np.ndarray
    dv_width_mps: float = 0.0
    ref_c0_m: float = 0.0
    ref_c1_s: float = 0.0
    time_gap_floor_mps: float = 0.0

    @property
    def n_rbf(self) -> int:
        """Number of (v, g) RBF features."""
        return int(self.v_centres_mps.size * self.gap_centres_m.size)

    @property
    def n_features(self) -> int:
        """Total number of features K."""
        return self.n_rbf + 2

    def split(self, alpha: np.ndarray) -> tuple[np.ndarray, float, float]:
        """``alpha`` (K,) → (A of shape (n_cv, n_cg), alpha_dv, alpha_a)."""
        if alpha.shape != (self.n_features,):
            raise TrainingError(f"alpha has shape {alpha.shape}, expected ({self.n_features},)")
        A = alpha[: self.n_rbf].reshape(self.v_centres_mps.size, self.gap_centres_m.size)
        return A, float(alpha[self.n_rbf]), float(alpha[self.n_rbf + 1])

    def reward_vg(self, alpha: np.ndarray, v_mps: np.ndarray, gap_m: np.ndarray) -> np.ndarray:
        """The (v, g) reward on the outer product of ``v_mps`` (n,) and ``gap_m`` (m,): (n, m)."""
        A, _, _ = self.split(alpha)
        bv = rbf(v_mps, self.v_centres_mps, self.v_width_mps)
        line = (self.ref_c0_m, self.ref_c1_s, self.time_gap_floor_mps)
        bg = gap_basis(v_mps, gap_m, self.gap_centres_m, self.gap_width_m, *line)
        return np.asarray(np.einsum("kj,klj->kl", bv @ A, bg))

    def counts(self, m_vg: np.ndarray) -> np.ndarray:
        """(v, g) feature counts (n_cv·n_cg,) of a grid visitation ``m_vg`` (n_v, n_gap)."""
        return np.asarray(np.einsum("kl,ki,klj->ij", m_vg, self.Bv, self.Bg).ravel())

    def spec(self) -> dict[str, float | list[float]]:
        """JSON-serialisable description (centres and widths)."""
        return {
            "v_centres_mps": [float(c) for c in self.v_centres_mps],
            "gap_centres_m": [float(c) for c in self.gap_centres_m],
            "v_width_mps": float(self.v_width_mps),
            "gap_width_m": float(self.gap_width_m),
            "ref_c0_m": float(self.ref_c0_m),
            "ref_c1_s": float(self.ref_c1_s),
            "time_gap_floor_mps": float(self.time_gap_floor_mps),
            "dv_width_mps": float(self.dv_width_mps),
        }


def rbf(x: np.ndarray, centres: np.ndarray, width: float) -> np.ndarray:
    """Gaussian RBFs of ``x`` (n,) at ``centres`` (k,): shape (n, k), values in (0, 1]."""
    z = (np.asarray(x, dtype=np.float64)[:, None] - centres[None, :]) / width
    return np.asarray(np.exp(-0.5 * z * z))


def gap_basis(
    v_mps: np.ndarray,
    gap_m: np.ndarray,
    centres: np.ndarray,
    width: float,
    c0: float,
    c1: float,
    time_gap_floor_mps: float = 0.0,
) -> np.ndarray:
    """Gap RBFs (n, m, k) of ``gap_m`` (m,) at each speed of ``v_mps`` (n,): of the time gap
    ``g/max(v, floor)`` (s) with a floor > 0, else of the offset ``g − (c0 + c1·v)`` (m)."""
    g = np.asarray(gap_m, dtype=np.float64)[None, :]
    v = np.asarray(v_mps, dtype=np.float64)[:, None]
    time_gap = time_gap_floor_mps > 0.0
    u = g / np.maximum(v, time_gap_floor_mps) if time_gap else g - (c0 + c1 * v)
    z = (u[:, :, None] - centres[None, None, :]) / width
    return np.asarray(np.exp(-0.5 * z * z))


def dv_weight(dv_mps: np.ndarray, width_mps: float) -> np.ndarray:
    """κ(dv) = exp(−½(dv/width)²) of ``dv_mps`` (n,), the weight of the (v, g) reward; 1 for
    width 0."""
    if width_mps <= 0.0:
        return np.ones_like(dv_mps, dtype=np.float64)
    return np.asarray(np.exp(-0.5 * (dv_mps / width_mps) ** 2))


def _build(
    grid: Grid,
    vc: np.ndarray,
    gc: np.ndarray,
    wv: float,
    wg: float,
    c0: float,
    c1: float,
    floor: float = 0.0,
    dv_width: float = 0.0,
) -> Features:
    f_dv = -((grid.dv_mps / float(np.max(np.abs(grid.dv_mps)))) ** 2)
    f_a = -((grid.accels_mps2 / float(np.max(np.abs(grid.accels_mps2)))) ** 2)
    bv, bg = rbf(grid.v_mps, vc, wv), gap_basis(grid.v_mps, grid.gap_m, gc, wg, c0, c1, floor)
    k_dv = dv_weight(grid.dv_mps, dv_width)
    return Features(vc, gc, wv, wg, bv, bg, f_dv, f_a, k_dv, dv_width, c0, c1, floor)


def make_features(
    grid: Grid, config: FeatureConfig, ref_c0_m: float = 0.0, ref_c1_s: float = 0.0
) -> Features:
    """RBFs at the configured spacings: speed centres over the grid's speed range, gap-offset
    centres over ±``offset_range_m`` around the reference line ``ref_c0_m + ref_c1_s·v``
    (with the plain line ``0 + 0·v``, over the grid's gap range)."""
    vc = np.arange(grid.v_mps[0], grid.v_mps[-1] + 1e-9, config.v_spacing_mps)
    if ref_c0_m == 0.0 and ref_c1_s == 0.0:
        gc = np.arange(grid.gap_m[0], grid.gap_m[-1] + 1e-9, config.gap_spacing_m)
    else:
        half = config.offset_range_m
        gc = np.arange(-half, half + 1e-9, config.gap_spacing_m)
    wv, wg = config.width_ratio * config.v_spacing_mps, config.width_ratio * config.gap_spacing_m
    return _build(grid, vc, gc, wv, wg, ref_c0_m, ref_c1_s, dv_width=config.dv_width_mps)


def make_time_gap_features(grid: Grid, config: FeatureConfig) -> Features:
    """RBFs over speed (as :func:`make_features`) times RBFs over the time gap
    ``g/max(v, config.time_gap_floor_mps)``, centres every ``time_gap_spacing_s`` over
    0 … ``time_gap_max_s`` (s): fixed, fitted to nothing, so any smooth preference g*(v) —
    non-monotonic ones too — is a ridge of the basis."""
    vc = np.arange(grid.v_mps[0], grid.v_mps[-1] + 1e-9, config.v_spacing_mps)
    gc = np.arange(0.0, config.time_gap_max_s + 1e-9, config.time_gap_spacing_s)
    wv, wg = (
        config.width_ratio * config.v_spacing_mps,
        config.width_ratio * config.time_gap_spacing_s,
    )
    return _build(grid, vc, gc, wv, wg, 0.0, 0.0, config.time_gap_floor_mps, config.dv_width_mps)


def features_from_spec(grid: Grid, spec: dict[str, object]) -> Features:
    """Rebuild :class:`Features` on ``grid`` from :meth:`Features.spec`."""
    try:
        vc = np.asarray(spec["v_centres_mps"], dtype=np.float64)
        gc = np.asarray(spec["gap_centres_m"], dtype=np.float64)
        wv = float(spec["v_width_mps"])  # type: ignore[arg-type]
        wg = float(spec["gap_width_m"])  # type: ignore[arg-type]
        c0 = float(spec.get("ref_c0_m", 0.0))  # type: ignore[arg-type]
        c1 = float(spec.get("ref_c1_s", 0.0))  # type: ignore[arg-type]
        floor = float(spec.get("time_gap_floor_mps", 0.0))  # type: ignore[arg-type]
        dv_width = float(spec.get("dv_width_mps", 0.0))  # type: ignore[arg-type]
    except (KeyError, TypeError, ValueError) as exc:
        raise TrainingError(f"invalid feature spec: {exc}") from exc
    if vc.ndim != 1 or gc.ndim != 1 or not (wv > 0 and wg > 0 and floor >= 0 and dv_width >= 0):
        raise TrainingError(
            "invalid feature spec: centres must be 1-D, widths > 0, time-gap floor and dv "
            "width >= 0"
        )
    return _build(grid, vc, gc, wv, wg, c0, c1, floor, dv_width)
