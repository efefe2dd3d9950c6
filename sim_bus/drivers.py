"""Driver parameters: the hidden gap preference and the habits of a synthetic driver.

A driver prefers the gap g*(v) = d0 + c·T(v)·v, with d0 the standstill distance, T(v) a
time headway given as a breakpoint table over speed (read with np.interp, held at the ends)
and c a condition factor (1 = dry daylight; rain lengthens the preference, c > 1). The ECU
never sees these numbers; it learns about the driver only through CAN frames.

Five built-in drivers span the paper's diversity (close follower, moderate, very cautious,
speed-dependent, inconsistent). More can be loaded from TOML or JSON with the same field
names (see docs/drivers.md); a file may also name a built-in as ``base`` and override fields.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import tomllib
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np

from sim_bus.errors import DriverError


def random_streams(
    seed: int, driver_id: str, tag: int
) -> tuple[np.random.Generator, np.random.Generator]:
    """The plant's and the driver's random streams of one drive: a pure function of the seed,
    the driver (two drivers of one seed share no taps, noise or trip shift) and ``tag``."""
    plant, driver = np.random.SeedSequence([seed, zlib.crc32(driver_id.encode()), tag]).spawn(2)
    return np.random.default_rng(plant), np.random.default_rng(driver)


PredefinedSetting = Literal["low", "medium", "high"]
#: the paper's predefined headways (s) per setting, and the HMI GapSetting code of each
PREDEFINED_HEADWAY_S: dict[str, float] = {"low": 1.0, "medium": 3.0, "high": 4.0}
GAP_SETTING_CODE: dict[str, int] = {"low": 1, "medium": 2, "high": 3}
_DRIVER_ID = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


@dataclass(frozen=True)
class DriverParams:
    """One synthetic driver (units in the names; times in s, gaps in m, speeds in m/s)."""

    driver_id: str
    description: str = ""
    # hidden preference g*(v) = standstill_m + condition·T(v)·v
    standstill_m: float = 4.0
    headway_speeds_mps: tuple[float, ...] = (5.0, 15.0, 25.0, 35.0)
    headway_s: tuple[float, ...] = (1.8, 1.8, 1.8, 1.8)
    condition_factor: float = 1.0
    condition_drift_per_min: float = 0.0  # std of the factor's random walk per √minute
    # under ACC the driver judges the gap against acc_preference_factor · g*(v): drivers
    # often want a different gap when not in control than the one they keep by hand
    acc_preference_factor: float = 1.0
    # ... and a time gap longer by acc_offset_s (s; < 0: shorter) than the one it keeps by
    # hand: the manual-vs-ACC mismatch (prior in sim_bus.population)
    acc_offset_s: float = 0.0
    # between trips the time headway shifts by N(0, trip_shift_sd_s) s, one draw per trip
    trip_shift_sd_s: float = 0.0
    # tolerance and timing of interventions under ACC
    comfort_band: float = 0.15  # relative half-width of the comfortable gap band
    comfort_band_min_m: float = 2.0
    patience_s: float = 1.5  # time out of the band (too close) before pressing
    patience_far_s: float = 4.0  # time out of the band (too far) before pressing
    lookahead_s: float = 1.5  # horizon of the predicted gap when judging "closing too fast"
    ttc_brake_s: float = 3.0  # brake at once below this time-to-collision
    reaction_s: float = 0.6
    # release: the gap feels right when the gap predicted anticipation_s ahead is within
    # release_band of the preference; the pedal is then held prolong_s longer
    release_band: float = 0.06
    anticipation_s: float = 1.0
    prolong_s: float = 0.3
    refractory_s: float = 1.0  # minimum time between two presses
    press_max_s: float = 3.0  # a press lasts at most this long (drivers nudge in bursts)
    press_min_s: float = 0.4  # and at least this long (a brief presser: 0.3 s)
    # manual driving: IDM+ around the preference
    accel_max_mps2: float = 1.5
    decel_comfort_mps2: float = 2.0
    desired_speed_mps: float = 36.0
    accel_noise_mps2: float = 0.15
    spurious_press_per_min: float = 0.0  # presses not about the gap (taps, mistrust), per min
    tap_s: float = 0.3  # ... and how long each lasts (at least press_min_s)
    predefined_setting: PredefinedSetting = "medium"
    # 2: a brake press lasts while the time-to-collision is below ttc_brake_s and
    # brakes at least as hard as stopping short of the lead needs; an accelerator press ends
    # by the following model's decision, not its control noise. 1: the earlier model, kept
    # by d1..d5 so that Table I stays comparable (docs/drivers.md)
    revision: int = 2

    def __post_init__(self) -> None:
        self._check_id()
        self._check_preference()
        self._check_habits()

    def _check_id(self) -> None:
        if not (isinstance(self.driver_id, str) and _DRIVER_ID.fullmatch(self.driver_id)):
            # it names files (the IRL cache) and tables: no path separators, no surprises
            raise DriverError(
                f"driver_id must be 1-64 letters, digits, '_', '-' or '.', "
                f"starting with a letter or digit; got {self.driver_id!r}"
            )

    def _check_preference(self) -> None:
        speeds, heads = self.headway_speeds_mps, self.headway_s
        if len(speeds) != len(heads) or len(speeds) < 1:
            raise DriverError(
                f"{self.driver_id}: headway_speeds_mps and headway_s differ in length or are empty"
            )
        if any(not b > a for a, b in zip(speeds, speeds[1:], strict=False)) or not all(
            math.isfinite(v) for v in speeds
        ):
            raise DriverError(f"{self.driver_id}: headway_speeds_mps must be finite and increase")
        if not all(0.3 <= h <= 6.0 for h in heads):
            raise DriverError(f"{self.driver_id}: headway_s must lie in 0.3..6.0 s")
        if not 0.5 <= self.standstill_m <= 15.0:
            raise DriverError(f"{self.driver_id}: standstill_m must lie in 0.5..15 m")
        if not 0.5 <= self.condition_factor <= 2.0:
            raise DriverError(f"{self.driver_id}: condition_factor must lie in 0.5..2")
        if not 0.5 <= self.acc_preference_factor <= 2.0:
            raise DriverError(f"{self.driver_id}: acc_preference_factor must lie in 0.5..2")
        if not (-1.5 <= self.acc_offset_s <= 2.0 and min(heads) + self.acc_offset_s >= 0.3 - 1e-9):
            raise DriverError(
                f"{self.driver_id}: acc_offset_s must lie in -1.5..2 s and keep every "
                "headway under ACC at 0.3 s or more"
            )
        if not 0.0 <= self.trip_shift_sd_s <= 1.0:
            raise DriverError(f"{self.driver_id}: trip_shift_sd_s must lie in 0..1 s")

    def _check_habits(self) -> None:
        positive = (
            "patience_s",
            "patience_far_s",
            "reaction_s",
            "accel_max_mps2",
            "press_max_s",
            "press_min_s",
            "decel_comfort_mps2",
            "desired_speed_mps",
            "comfort_band",
        )
        for name in positive:
            if not getattr(self, name) > 0:
                raise DriverError(f"{self.driver_id}: {name} must be > 0")
        nonneg = (
            "condition_drift_per_min",
            "comfort_band_min_m",
            "lookahead_s",
            "ttc_brake_s",
            "release_band",
            "anticipation_s",
            "prolong_s",
            "refractory_s",
            "accel_noise_mps2",
            "spurious_press_per_min",
            "tap_s",
        )
        for name in nonneg:
            if not getattr(self, name) >= 0:
                raise DriverError(f"{self.driver_id}: {name} must be >= 0")
        if self.revision not in (1, 2):
            raise DriverError(f"{self.driver_id}: revision must be 1 or 2")
        if self.press_min_s > self.press_max_s:
            raise DriverError(f"{self.driver_id}: press_min_s exceeds press_max_s")
        if self.predefined_setting not in PREDEFINED_HEADWAY_S:
            raise DriverError(
                f"{self.driver_id}: predefined_setting must be one of "
                f"{sorted(PREDEFINED_HEADWAY_S)}"
            )

    def headway_at(self, v_mps: np.ndarray | float) -> np.ndarray:
        """The preferred time headway T(v) (s), same shape as ``v_mps``."""
        return np.asarray(np.interp(v_mps, self.headway_speeds_mps, self.headway_s))

    def preferred_gap_m(
        self, v_mps: np.ndarray | float, condition_factor: float = 1.0
    ) -> np.ndarray:
        """The hidden preferred gap g*(v) = d0 + c·T(v)·v (m), same shape as ``v_mps``.

        ``condition_factor`` multiplies the driver's own ``condition_factor``.
        """
        v = np.maximum(np.asarray(v_mps, dtype=np.float64), 0.0)
        c = self.condition_factor * condition_factor
        return self.standstill_m + c * self.headway_at(v) * v

    def acc_preferred_gap_m(
        self, v_mps: np.ndarray | float, condition_factor: float = 1.0
    ) -> np.ndarray:
        """The gap the driver wants under ACC (m):
        ``acc_preference_factor · (g*(v) + c·acc_offset_s·v)``."""
        v = np.maximum(np.asarray(v_mps, dtype=np.float64), 0.0)
        c = self.condition_factor * condition_factor
        offset = c * self.acc_offset_s * v
        return self.acc_preference_factor * (self.preferred_gap_m(v_mps, condition_factor) + offset)

    @property
    def predefined_headway_s(self) -> float:
        """The constant headway this driver picks for the Predefined controller (s)."""
        return PREDEFINED_HEADWAY_S[self.predefined_setting]


#: condition factors of ``pacc drive --condition``: wet adds about 0.1 s to a 2-s time gap
#: (Rahman & Lownes 2012: 1.97 -> 2.1 s in rain); night is longer too (Zhu et al., Shanghai
#: NDS: "longer headways ... nighttime"), its size not seen: 5 % is an assumption
CONDITION_FACTORS: dict[str, float] = {"dry": 1.0, "wet": 1.066, "night": 1.05}

BUILTIN_DRIVERS: dict[str, DriverParams] = {
    "d1": DriverParams(
        "d1",
        "close follower: short headway, impatient, brakes late",
        standstill_m=3.0,
        headway_s=(1.15, 1.2, 1.25, 1.3),
        comfort_band=0.15,
        patience_s=1.2,
        patience_far_s=2.5,
        reaction_s=0.5,
        anticipation_s=1.2,
        accel_max_mps2=2.0,
        decel_comfort_mps2=2.5,
        press_max_s=2.5,
        predefined_setting="low",
        revision=1,
    ),
    "d2": DriverParams(
        "d2",
        "moderate: medium headway, average patience",
        standstill_m=4.0,
        headway_s=(1.6, 1.7, 1.8, 1.9),
        comfort_band=0.15,
        patience_s=1.5,
        patience_far_s=4.0,
        reaction_s=0.6,
        acc_preference_factor=1.1,
        predefined_setting="medium",
        revision=1,
    ),
    "d3": DriverParams(
        "d3",
        "very cautious: long headway, brakes early, prolongs its presses",
        standstill_m=5.0,
        headway_s=(2.3, 2.5, 2.7, 2.8),
        comfort_band=0.12,
        patience_s=1.0,
        patience_far_s=6.0,
        lookahead_s=2.0,
        ttc_brake_s=4.0,
        reaction_s=0.8,
        anticipation_s=0.3,
        prolong_s=1.0,
        accel_max_mps2=1.2,
        decel_comfort_mps2=1.8,
        acc_preference_factor=1.1,
        press_max_s=4.0,
        predefined_setting="high",
        revision=1,
    ),
    "d4": DriverParams(
        "d4",
        "speed-dependent: close in town, far on the motorway",
        standstill_m=4.0,
        headway_s=(1.2, 1.5, 2.3, 2.7),
        comfort_band=0.15,
        patience_s=1.5,
        patience_far_s=3.5,
        reaction_s=0.6,
        acc_preference_factor=0.92,
        predefined_setting="medium",
        revision=1,
    ),
    "d5": DriverParams(
        "d5",
        "inconsistent: drifting preference, noisy control, random short taps",
        standstill_m=4.0,
        headway_s=(1.7, 1.9, 2.1, 2.2),
        condition_drift_per_min=0.05,
        comfort_band=0.18,
        patience_s=2.0,
        patience_far_s=4.0,
        reaction_s=0.7,
        anticipation_s=0.6,
        prolong_s=0.6,
        accel_noise_mps2=0.3,
        spurious_press_per_min=0.5,
        press_max_s=2.0,
        predefined_setting="medium",
        revision=1,
    ),
}


def _tuple_fields(raw: dict[str, Any]) -> dict[str, Any]:
    out = dict(raw)
    for name in ("headway_speeds_mps", "headway_s"):
        if name in out and isinstance(out[name], list):
            out[name] = tuple(float(x) for x in out[name])
    return out


def driver_from_dict(raw: dict[str, Any], origin: str = "<dict>") -> DriverParams:
    """Build a DriverParams from a mapping; ``base`` names a built-in to start from."""
    if not isinstance(raw, dict):
        raise DriverError(f"{origin}: a driver must be a table/object")
    data = dict(raw)
    base_name = data.pop("base", None)
    known = {f.name for f in dataclasses.fields(DriverParams)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise DriverError(f"{origin}: unknown driver fields {unknown}")
    try:
        if base_name is not None:
            if base_name not in BUILTIN_DRIVERS:
                raise DriverError(f"{origin}: unknown base driver {base_name!r}")
            data.setdefault("driver_id", f"{base_name}-custom")
            return dataclasses.replace(BUILTIN_DRIVERS[base_name], **_tuple_fields(data))
        if "driver_id" not in data:
            raise DriverError(f"{origin}: driver_id is required (or a base driver)")
        return DriverParams(**_tuple_fields(data))
    except (TypeError, ValueError) as exc:  # a wrong type or a non-numeric list entry
        raise DriverError(f"{origin}: {exc}") from exc


def load_driver(spec: str | Path) -> DriverParams:
    """A built-in driver by name ("d1".."d5") or a driver file (``.toml`` or ``.json``).

    A TOML file holds the fields at top level or under ``[driver]``. Raises DriverError
    naming the file and the defect.
    """
    text = str(spec)
    if text in BUILTIN_DRIVERS:
        return BUILTIN_DRIVERS[text]
    path = Path(spec)
    if not path.exists():
        raise DriverError(
            f"unknown driver {text!r}: not one of {sorted(BUILTIN_DRIVERS)} and no such file"
        )
    try:
        if path.suffix.lower() == ".toml":
            raw: Any = tomllib.loads(path.read_text(encoding="utf-8"))
        elif path.suffix.lower() == ".json":
            raw = json.loads(path.read_text(encoding="utf-8"))
        else:
            raise DriverError(f"{path}: a driver file must end in .toml or .json")
    except (OSError, ValueError) as exc:
        raise DriverError(f"{path}: {exc}") from exc
    if isinstance(raw, dict) and isinstance(raw.get("driver"), dict):
        raw = raw["driver"]
    return driver_from_dict(raw, str(path))
