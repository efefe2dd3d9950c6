"""The driver's pedals as fractions 0..1 of full scale, scaled once from the network.

The bus carries the accelerator in % and the brake pressure in bar; full scale is the DBC's
upper bound of the bound field (100 %, 250 bar in ``dbc/pacc.dbc``), so the ECU's and the
simulator's trip logs give one pedal one value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from dbc.vocab import FormatError

if TYPE_CHECKING:
    from dbc.codec import Codec


@dataclass(frozen=True, slots=True)
class PedalScale:
    """Full scale of the pedal fields: accelerator %, brake pressure bar."""

    accel_full_pct: float
    brake_full_bar: float

    def __post_init__(self) -> None:
        for name in ("accel_full_pct", "brake_full_bar"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise FormatError(f"PedalScale.{name} must be finite and > 0, got {value}")

    @classmethod
    def from_codec(cls, codec: Codec) -> PedalScale:
        """Full scale = the DBC maximum of each bound pedal field (a network without a brake
        pressure signal reports 0 bar: its full scale is then 1 bar, the fraction 0)."""
        pedals = codec.roles["pedals"]
        brake = pedals.part_of("brake_pressure_bar")
        return cls(
            accel_full_pct=pedals.bounds("accel_pedal_pct")[1],
            brake_full_bar=1.0 if brake is None else brake.bounds("brake_pressure_bar")[1],
        )

    def accel(self, pct: float) -> float:
        """Accelerator fraction 0..1 of a position in % (NaN stays NaN)."""
        return _unit(pct / self.accel_full_pct)

    def brake(self, bar: float) -> float:
        """Brake fraction 0..1 of a pressure in bar (NaN stays NaN)."""
        return _unit(bar / self.brake_full_bar)


def _unit(x: float) -> float:
    """``x`` clipped to [0, 1]; NaN passes through (the caller's validity checks see it)."""
    return 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)
