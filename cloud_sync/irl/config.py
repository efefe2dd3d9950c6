"""The IRL trainer's configuration: everything that decides a learned table.

:class:`IrlConfig` is frozen and checked when built (:class:`cloud_sync.errors.TrainingError`);
:mod:`cloud_sync.irl.trainer` and :func:`cloud_sync.irl.extract.empirical_baseline` take it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from cloud_sync.errors import TrainingError
from cloud_sync.irl.features import FeatureConfig
from cloud_sync.irl.mdp import GridConfig
from dbc.vocab.dgpt import SafetyBounds


@dataclass(frozen=True)
class IrlConfig:
    """Everything that decides a learned table (units in names).

    ``horizon_steps``: the longest demonstration segment (decisions). ``l2``: weight of the
    quadratic penalty on α (towards the previous α when fine-tuning). ``max_iter``/``gtol``/
    ``ftol``: the L-BFGS stopping rule (iterations; max |gradient component| per segment;
    relative objective decrease). ``min_total_demo_s``: refuse less usable demonstration.
    ``min_coverage_s``: seconds within ±0.5 m/s for a speed bin to count as evidence.
    ``takeover_weight``: weight of an ACC trip's takeover samples against manual samples.
    ``blend_window_mps``: when continuing from an earlier table, new evidence moves the table
    within this distance of its speeds, blended by its amount (weight c/(c + blend_half_s)
    for c seconds of new evidence); elsewhere the table is kept;
    the table's gaps may range ±``init_support_ratio`` around the earlier gaps.
    """

    grid: GridConfig = field(default_factory=GridConfig)
    features: FeatureConfig = field(default_factory=FeatureConfig)
    bounds: SafetyBounds = field(default_factory=SafetyBounds)
    horizon_steps: int = 5
    l2: float = 0.01
    max_iter: int = 150
    gtol: float = 1e-3
    ftol: float = 1e-7
    max_gap_m: float = 120.0
    min_total_demo_s: float = 60.0
    min_coverage_s: float = 10.0
    lowpass_cutoff: float = 0.1
    gap_resolution_m: float = 0.25
    takeover_weight: float = 5.0
    dgpt_step_mps: float = 0.5
    blend_window_mps: float = 2.0
    blend_half_s: float = 10.0
    init_support_ratio: float = 0.3

    def __post_init__(self) -> None:
        if self.horizon_steps < 1:
            raise TrainingError("horizon_steps must be >= 1")
        if not (self.l2 >= 0 and self.max_iter >= 1 and self.gtol > 0 and self.ftol > 0):
            raise TrainingError("l2 must be >= 0, max_iter >= 1, gtol and ftol > 0")
        if not 0 < self.lowpass_cutoff < 1:
            raise TrainingError("lowpass_cutoff must be in (0, 1)")
        positive = (
            "max_gap_m",
            "min_coverage_s",
            "gap_resolution_m",
            "takeover_weight",
            "dgpt_step_mps",
            "blend_half_s",
        )
        for name in positive:  # finite and > 0 (NaN fails the comparison too)
            value = getattr(self, name)
            if not 0 < value < math.inf:
                raise TrainingError(f"{name} must be a finite number > 0, got {value}")
        for name in ("min_total_demo_s", "blend_window_mps", "init_support_ratio"):
            value = getattr(self, name)
            if not 0 <= value < math.inf:
                raise TrainingError(f"{name} must be a finite number >= 0, got {value}")
