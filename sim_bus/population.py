"""A population of synthetic drivers drawn from distributions calibrated on real human pairs.

The five built-in drivers (d1..d5) are a hand-made showcase; a result that holds only for
them says little about drivers the project never saw. :func:`draw_population` draws any
number of drivers whose gap preference follows the real human followers of the shipped
OpenACC data (:mod:`sim_bus.dataset`, Makridis et al., 2021) and whose habits follow stated
priors.

**Calibrated on the real pairs** (:func:`calibrate`, pure, from the arrays):

- standstill distance ``d0``: per follower, the median gap while stopped (``v < 0.5 m/s``);
  population mean and standard deviation over the followers that stopped;
- the time headway ``T(v) = (g - d0)/v`` of near-steady following (``|v_lead - v| < 0.5``,
  ``|a| < 0.3``), median per 5-m/s band (10-30 m/s, bands with >= 10 s of data): per
  follower its level (mean of log T over the bands), its slope over speed (least squares,
  s per m/s) and the spread of the band medians about that line (the non-monotonic part);
  population mean and standard deviation of level and slope, and the mean spread.

A drawn driver's headway at the breakpoints 5/15/25/35 m/s is
``exp(level) + slope·(clip(v, 10, 30) - 20) + e`` with ``e ~ N(0, spread)`` independent per
breakpoint (so shapes that dip and rise, as the real followers' do), clipped to 0.6-4.0 s;
the line is not extrapolated beyond the 10-30 m/s the real data cover.

**Priors** (not identifiable from car-following trajectories, which hold no pedal presses):
reaction 0.4-2.0 s (log-normal around 0.8 s: brake reaction times of alert drivers are
0.7-1.5 s, Green, "How long does it take to stop?", Transportation Human Factors 2, 2000),
press length from ``press_min_s`` 0.3-0.6 s up to ``press_max_s`` 0.3-3.5 s longer,
patience 0.8-3.5 s (close) and 2-7 s (far), ACC factor ~ N(1, 0.08) in 0.8-1.25, comfort band
10-20 %, a drifting preference for one driver in five, random taps for one in five, and the
predefined setting nearest to the driver's own mean headway.

Driver ``i`` of population seed ``s`` is a pure function of ``(s, i)`` and the data: the first
N drivers of a larger population are the same N drivers (a run can be extended or resumed).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from sim_bus.dataset import HumanPair, load_human_pairs
from sim_bus.drivers import PREDEFINED_HEADWAY_S, DriverParams
from sim_bus.errors import DriverError

#: speed bands of the headway calibration, m/s (as tools/calibration.py)
BANDS_MPS: tuple[tuple[float, float], ...] = (
    (10.0, 15.0),
    (15.0, 20.0),
    (20.0, 25.0),
    (25.0, 30.0),
)
#: breakpoints of a drawn driver's headway table, m/s
BREAKPOINTS_MPS: tuple[float, ...] = (5.0, 15.0, 25.0, 35.0)
MIN_BAND_SAMPLES = 100  # 10 s at 10 Hz
HEADWAY_RANGE_S = (0.6, 4.0)
STANDSTILL_RANGE_M = (1.5, 8.0)


@dataclass(frozen=True)
class PopulationPrior:
    """The calibrated distributions of the gap preference (units in the names).

    Attributes:
        standstill_mean_m, standstill_sd_m: standstill distance d0 over the followers.
        log_headway_mean, log_headway_sd: level of the time headway, log of seconds.
        slope_mean_s_per_mps, slope_sd_s_per_mps: change of the headway per m/s of speed.
        shape_sd_s: spread of a follower's band headways about its own line, s.
        n_followers: real followers the figures come from.
    """

    standstill_mean_m: float
    standstill_sd_m: float
    log_headway_mean: float
    log_headway_sd: float
    slope_mean_s_per_mps: float
    slope_sd_s_per_mps: float
    shape_sd_s: float
    n_followers: int


def _standstill_m(pair: HumanPair) -> float:
    stopped = pair.v_follower_mps < 0.5
    return float(np.median(pair.gap_m[stopped])) if stopped.sum() >= 10 else math.nan


def band_headways(pair: HumanPair, standstill_m: float) -> list[tuple[float, float]]:
    """(band centre m/s, median time headway s) of near-steady following per band with
    >= 10 s of data; the headway is ``(g - d0)/v``."""
    v, g, vl = pair.v_follower_mps, pair.gap_m, pair.v_leader_mps
    a = np.gradient(v, pair.dt_s)
    steady = (np.abs(vl - v) < 0.5) & (np.abs(a) < 0.3)
    out = []
    for lo, hi in BANDS_MPS:
        m = steady & (v >= lo) & (v < hi)
        if m.sum() >= MIN_BAND_SAMPLES:
            out.append((0.5 * (lo + hi), float(np.median((g[m] - standstill_m) / v[m]))))
    return out


def calibrate(pairs: Sequence[HumanPair]) -> PopulationPrior:
    """The preference distributions of the real followers ``pairs`` (see the module doc)."""
    stand = np.array([_standstill_m(p) for p in pairs])
    stand = stand[np.isfinite(stand)]
    if stand.size < 2:
        raise DriverError("population calibration: fewer than two followers ever stopped")
    d0 = float(np.median(stand))
    levels, slopes, spreads = [], [], []
    for p in pairs:
        s0 = _standstill_m(p)
        bands = band_headways(p, s0 if math.isfinite(s0) else d0)
        if len(bands) < 2:
            continue
        x = np.array([c for c, _ in bands])
        h = np.array([t for _, t in bands])
        slope, icpt = np.polyfit(x, h, 1)
        levels.append(float(np.mean(np.log(h))))
        slopes.append(float(slope))
        if len(bands) >= 3:
            spreads.append(float(np.std(h - (icpt + slope * x), ddof=2 if len(bands) > 3 else 1)))
    if len(levels) < 2:
        raise DriverError("population calibration: fewer than two followers with two bands")
    return PopulationPrior(
        standstill_mean_m=float(np.mean(stand)),
        standstill_sd_m=float(np.std(stand, ddof=1)),
        log_headway_mean=float(np.mean(levels)),
        log_headway_sd=float(np.std(levels, ddof=1)),
        slope_mean_s_per_mps=float(np.mean(slopes)),
        slope_sd_s_per_mps=float(np.std(slopes, ddof=1)),
        shape_sd_s=float(np.mean(spreads)) if spreads else 0.0,
        n_followers=len(levels),
    )


@lru_cache(maxsize=1)
def shipped_prior() -> PopulationPrior:
    """:func:`calibrate` on the shipped real human pairs (computed once per process)."""
    return calibrate(load_human_pairs())


def _clip(x: float, lo: float, hi: float) -> float:
    return min(max(x, lo), hi)


def _lognormal(
    rng: np.random.Generator, median: float, sd_log: float, lo: float, hi: float
) -> float:
    return _clip(median * math.exp(sd_log * float(rng.standard_normal())), lo, hi)


def nearest_setting(headway_s: float) -> str:
    """The predefined setting (low/medium/high) whose headway is nearest ``headway_s``."""
    return min(PREDEFINED_HEADWAY_S, key=lambda k: abs(PREDEFINED_HEADWAY_S[k] - headway_s))


#: the manual-vs-ACC mismatch prior: the time gap wanted under ACC minus the one kept by
#: hand, scale·N(mean, sd) s clipped to the range (docs/drivers.md: direction from field
#: tests, bounds from reported ACC headways, size fitted)
MISMATCH_MEAN_S = 0.3
MISMATCH_SD_S = 0.3
MISMATCH_RANGE_S = (-0.5, 1.0)


def draw_driver(prior: PopulationPrior, seed: int, index: int) -> DriverParams:
    """Driver ``index`` of population ``seed`` (``headway``: no ACC-vs-manual mismatch): a pure
    function of (prior, seed, index)."""
    rng = np.random.default_rng([seed, index, 0x706F70])
    level = math.exp(prior.log_headway_mean + prior.log_headway_sd * float(rng.standard_normal()))
    slope = prior.slope_mean_s_per_mps + prior.slope_sd_s_per_mps * float(rng.standard_normal())
    shape = prior.shape_sd_s * rng.standard_normal(len(BREAKPOINTS_MPS))
    heads = tuple(
        round(_clip(level + slope * (_clip(v, 10.0, 30.0) - 20.0) + float(e), *HEADWAY_RANGE_S), 3)
        for v, e in zip(BREAKPOINTS_MPS, shape, strict=True)
    )
    d0 = _clip(
        prior.standstill_mean_m + prior.standstill_sd_m * float(rng.standard_normal()),
        *STANDSTILL_RANGE_M,
    )
    press_min = float(rng.uniform(0.3, 0.6))
    drifting = rng.random() < 0.2
    tapping = rng.random() < 0.2
    return DriverParams(
        driver_id=f"p{seed}-{index:04d}",
        description=f"drawn driver {index} of population seed {seed}",
        standstill_m=round(d0, 2),
        headway_speeds_mps=BREAKPOINTS_MPS,
        headway_s=heads,
        condition_drift_per_min=float(rng.uniform(0.02, 0.06)) if drifting else 0.0,
        acc_preference_factor=_clip(1.0 + 0.08 * float(rng.standard_normal()), 0.8, 1.25),
        comfort_band=float(rng.uniform(0.10, 0.20)),
        patience_s=_lognormal(rng, 1.5, 0.35, 0.8, 3.5),
        patience_far_s=_lognormal(rng, 4.0, 0.3, 2.0, 7.0),
        lookahead_s=float(rng.uniform(1.0, 2.0)),
        ttc_brake_s=float(rng.uniform(2.5, 4.0)),
        reaction_s=_lognormal(rng, 0.8, 0.35, 0.4, 2.0),
        anticipation_s=float(rng.uniform(0.3, 1.2)),
        prolong_s=float(rng.uniform(0.0, 1.0)),
        refractory_s=float(rng.uniform(0.5, 1.5)),
        press_min_s=press_min,
        press_max_s=press_min + float(rng.uniform(0.3, 3.5)),
        accel_max_mps2=float(rng.uniform(1.2, 2.0)),
        decel_comfort_mps2=float(rng.uniform(1.8, 2.5)),
        accel_noise_mps2=float(rng.uniform(0.1, 0.3)),
        spurious_press_per_min=float(rng.uniform(0.2, 1.0)) if tapping else 0.0,
        predefined_setting=nearest_setting(float(np.mean(heads))),  # type: ignore[arg-type]
    )


#: the manual-following dynamics of real human followers: (median, sd of the log, lowest,
#: highest) of the drivers' model fitted per follower (sim_bus.following.dynamics_prior over
#: the eight shipped OpenACC human pairs, ``pacc validate following``; docs/drivers.md), held
#: within the fits' bounds. The desired speed is not in it: the pairs never exceed 28 m/s, so
#: the fits cannot tell it
FOLLOWING_PRIOR: dict[str, tuple[float, float, float, float]] = {
    "accel_max_mps2": (1.73, 0.59, 0.43, 4.0),
    "decel_comfort_mps2": (1.86, 0.87, 0.5, 5.0),
    "reaction_s": (0.76, 1.73, 0.19, 1.5),
}


@dataclass(frozen=True)
class TakeoverScales:
    """The three scales of the ``people`` population's takeover prior, fitted on one seed to
    the paper's four PoI averages only (``python -m tools.calibration people``) and frozen."""

    mismatch: float  # × the ACC-vs-manual offset prior N(MISMATCH_MEAN_S, MISMATCH_SD_S),
    # clipped to MISMATCH_RANGE_S after scaling
    taps_per_min: float  # mean rate of presses that are not about the gap, per min
    drift: float  # × the drift prior: the headway's shift between trips, sd U(0.05, 0.25) s
    # (at most 1 s), and the within-trip walk of its condition, U(0.01, 0.05) per √min


#: the longest a driver holds a press about the gap beyond its shortest press: log-normal
#: around this, s. The paper's behaviour filter skips takeovers of P_T = 1 s or less as the
#: noise of short presses, so the presses it learns from, about the gap, are longer
PRESS_HOLD_S = 1.0
#: frozen after the fit (docs/drivers.md names the seed it was fitted on)
PEOPLE_SCALES = TakeoverScales(mismatch=0.6, taps_per_min=4.0, drift=2.5)
#: the populations by name; ``headway`` (the steady-state calibration alone) is the older one
POPULATIONS = ("headway", "people")
DEFAULT_POPULATION = "people"


def people_driver(
    base: DriverParams, seed: int, index: int, scales: TakeoverScales = PEOPLE_SCALES
) -> DriverParams:
    """``base`` with the ``people`` prior's dynamics and takeover habits (docs/drivers.md), from
    its own random stream (the preference of ``base`` is kept)."""
    rng = np.random.default_rng([seed, index, 0x706570])
    accel, decel, reaction = (_lognormal(rng, *prior) for prior in FOLLOWING_PRIOR.values())
    offset = _clip(
        scales.mismatch * (MISMATCH_MEAN_S + MISMATCH_SD_S * float(rng.standard_normal())),
        *MISMATCH_RANGE_S,
    )
    taps = scales.taps_per_min * math.exp(0.5 * float(rng.standard_normal()) - 0.125)
    return dataclasses.replace(
        base,
        accel_max_mps2=accel,
        decel_comfort_mps2=decel,
        reaction_s=reaction,
        acc_offset_s=round(max(offset, 0.3 - min(base.headway_s)), 4),
        acc_preference_factor=1.0,
        trip_shift_sd_s=min(scales.drift * float(rng.uniform(0.05, 0.25)), 1.0),
        condition_drift_per_min=scales.drift * float(rng.uniform(0.01, 0.05)),
        spurious_press_per_min=taps,
        tap_s=base.press_min_s,  # a press not about the gap: the driver's shortest
        press_max_s=base.press_min_s + _lognormal(rng, PRESS_HOLD_S, 0.4, 0.3, 4.0),
    )


def draw_population(
    n: int,
    seed: int,
    prior: PopulationPrior | None = None,
    population: str = DEFAULT_POPULATION,
) -> tuple[DriverParams, ...]:
    """``n`` drivers of population ``seed`` (ids ``p<seed>-0000`` …); DriverError if n < 1 or
    ``population`` is unknown. ``people``: the ``headway`` drivers with :func:`people_driver`'s
    dynamics and takeover habits (its mismatch and trip shift are the prior's)."""
    if n < 1 or seed < 0:
        raise DriverError(f"a population needs n >= 1 drivers and a seed >= 0, got {n}, {seed}")
    if population not in POPULATIONS:
        raise DriverError(f"unknown population {population!r}: one of {list(POPULATIONS)}")
    p = prior if prior is not None else shipped_prior()
    drivers = (draw_driver(p, seed, i) for i in range(n))
    if population == "people":
        return tuple(people_driver(d, seed, i) for i, d in enumerate(drivers))
    return tuple(drivers)
