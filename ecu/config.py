"""Configuration of the ACC node: one frozen dataclass, validated on construction."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from dbc.vocab.dgpt import SafetyBounds
from ecu import EcuError
from ecu.adaptation import AdaptationParams
from ecu.controller import ControllerParams
from ecu.cycle.state import BrakeMode

#: Largest time step the controller integrates over in one call, s.
MAX_DT_S = 0.1
#: Highest cruise set speed of a production ACC, m/s (180 km/h; many cars stop at 160-210).
MAX_SET_SPEED_MPS = 50.0


class ConfigError(EcuError):
    """Invalid ECU configuration."""


@dataclass(frozen=True)
class EcuConfig:
    """Configuration of the ACC node (frozen; validated on construction; units in the names).

    ``brake_mode``: ``"resume"`` (brake = override, the paper's study) or ``"cancel"`` (back to
    STANDBY, production); ``set_speed_mps`` None: SET takes the current speed (capped);
    ``gap_controller`` / ``adaptation_method``: a plug-in spec (:mod:`ecu.methods`), guarded, with
    ``controller_args`` / ``adaptation_args`` (``""``: the built-in called directly);
    ``plugin_budget_s`` None: 10 ms for a controller, 100 ms for an adaptation."""

    adaptation: bool = True
    brake_mode: BrakeMode = "resume"
    adaptation_params: AdaptationParams = field(default_factory=AdaptationParams)
    controller: ControllerParams = field(default_factory=ControllerParams)
    bounds: SafetyBounds = field(default_factory=SafetyBounds)
    cycle_s: float = 0.02
    status_period_s: float = 0.1
    settle_s: float = 1.0  # inputs valid this long before SET re-engages
    set_speed_mps: float | None = None
    max_set_speed_mps: float = MAX_SET_SPEED_MPS
    record_period_s: float = 0.1
    pre_trigger_s: float = 5.0
    post_trigger_s: float = 5.0
    trip_meta: Mapping[str, Any] = field(default_factory=dict)  # copied into every trip
    gap_controller: str = ""
    controller_args: Mapping[str, Any] = field(default_factory=dict)
    adaptation_method: str = ""
    adaptation_args: Mapping[str, Any] = field(default_factory=dict)
    plugin_budget_s: float | None = None

    def __post_init__(self) -> None:
        if self.brake_mode not in ("resume", "cancel"):
            raise ConfigError(f"brake_mode must be 'resume' or 'cancel', got {self.brake_mode!r}")
        if not (0.0 < self.cycle_s <= MAX_DT_S and self.status_period_s >= self.cycle_s):
            raise ConfigError("need 0 < cycle_s <= 0.1 s and status_period_s >= cycle_s")
        if not (math.isfinite(self.settle_s) and self.settle_s >= 0.0):
            raise ConfigError("settle_s must be finite and >= 0")
        recorder = (self.record_period_s, self.pre_trigger_s, self.post_trigger_s)
        if not (all(math.isfinite(x) and x >= 0.0 for x in recorder) and self.record_period_s > 0):
            raise ConfigError(
                "need finite record_period_s > 0, pre_trigger_s >= 0 and post_trigger_s >= 0"
            )
        if not (math.isfinite(self.max_set_speed_mps) and self.max_set_speed_mps > 0.0):
            raise ConfigError("max_set_speed_mps must be finite and > 0")
        budget = self.plugin_budget_s
        if budget is not None and not (math.isfinite(budget) and budget > 0.0):
            raise ConfigError("plugin_budget_s must be finite and > 0")
        top = self.max_set_speed_mps
        if self.set_speed_mps is not None and not 0.0 <= self.set_speed_mps <= top:
            raise ConfigError(f"set_speed_mps must be within 0..max_set_speed_mps ({top:g} m/s)")
