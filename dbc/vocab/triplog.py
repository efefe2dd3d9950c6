"""Trip logs: a car-following trip as arrays (:class:`Trip`).

One trip sampled at a fixed rate (10 Hz typical): 1-D arrays of one length ``n``, checked
when built (:class:`TripLogError`), and a ``meta`` dict (driver, condition, mode:
:mod:`dbc.vocab.tripmode`). File format: :mod:`dbc.vocab.triplog_file`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dbc.vocab import FormatError
from dbc.vocab.acc_state import AccState
from dbc.vocab.tripmode import TripMode, TripModeError


class TripLogError(FormatError):
    """A trip log (MCAP or CSV) cannot be read or written: unknown, corrupt or truncated."""


#: float columns of a trip, in file order
FLOAT_FIELDS: tuple[str, ...] = (
    "t_s",
    "v_mps",
    "gap_m",
    "v_lead_mps",
    "a_mps2",
    "accel_pedal",
    "brake_pedal",
)
#: the largest AccState code (FAULT)
ACC_STATE_MAX = int(max(AccState))


def _as_float_array(name: str, value: Any) -> np.ndarray:
    arr = np.array(value, dtype=np.float64)
    if arr.ndim != 1:
        raise TripLogError(f"Trip.{name} must be a 1-D array, got shape {arr.shape}")
    arr.setflags(write=False)
    return arr


def _as_state_array(value: Any) -> np.ndarray:
    """``value`` as a read-only int64 array of AccState codes (1-D, finite integers)."""
    raw = np.asarray(value)
    if raw.ndim != 1:
        raise TripLogError(f"Trip.acc_state must be 1-D, got shape {raw.shape}")
    if raw.size and not np.all(np.isfinite(raw.astype(np.float64))):
        raise TripLogError("Trip.acc_state must be finite integers")
    state = raw.astype(np.int64)
    if raw.size and not np.array_equal(state, raw):
        raise TripLogError("Trip.acc_state must hold integer AccState codes")
    state.setflags(write=False)
    return state


def _check_fraction(name: str, arr: np.ndarray) -> None:
    """Refuse a pedal column with a known value outside 0..1 (NaN: not recorded)."""
    known = arr[~np.isnan(arr)]
    if known.size and (known.min() < 0.0 or known.max() > 1.0):
        raise TripLogError(f"Trip.{name} outside 0..1")


@dataclass(frozen=True, eq=False)
class Trip:
    """One car-following trip, arrays (n,): ``t_s`` (s, finite, increasing), ``v_mps``,
    ``v_lead_mps`` (m/s), ``gap_m`` (m), ``a_mps2`` (m/s²), pedals 0..1 (NaN: not recorded;
    lead NaN: no lead), ``acc_state`` AccState codes (int64), JSON-ready ``meta``."""

    t_s: np.ndarray
    v_mps: np.ndarray
    gap_m: np.ndarray
    v_lead_mps: np.ndarray
    a_mps2: np.ndarray
    accel_pedal: np.ndarray
    brake_pedal: np.ndarray
    acc_state: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)
    #: trips compare by value; arrays are not hashable, so neither is a trip
    __hash__ = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        for name in FLOAT_FIELDS:
            object.__setattr__(self, name, _as_float_array(name, getattr(self, name)))
        state = _as_state_array(self.acc_state)
        object.__setattr__(self, "acc_state", state)
        n = self.t_s.shape[0]
        for name in (*FLOAT_FIELDS, "acc_state"):
            if getattr(self, name).shape[0] != n:
                raise TripLogError(
                    f"Trip arrays differ in length: t_s has {n}, {name} has "
                    f"{getattr(self, name).shape[0]}"
                )
        if not np.all(np.isfinite(self.t_s)):
            raise TripLogError("Trip.t_s must be finite")
        if n > 1 and not np.all(np.diff(self.t_s) > 0):
            raise TripLogError("Trip.t_s must be strictly increasing")
        if n and (state.min() < 0 or state.max() > ACC_STATE_MAX):
            raise TripLogError(f"Trip.acc_state outside 0..{ACC_STATE_MAX}")
        for name in ("accel_pedal", "brake_pedal"):
            _check_fraction(name, getattr(self, name))
        if not isinstance(self.meta, dict):
            raise TripLogError("Trip.meta must be a dict")
        object.__setattr__(self, "meta", dict(self.meta))

    @classmethod
    def manual(
        cls,
        t_s: np.ndarray,
        v_mps: np.ndarray,
        gap_m: np.ndarray,
        v_lead_mps: np.ndarray,
        a_mps2: np.ndarray,
        meta: dict[str, Any] | None = None,
    ) -> Trip:
        """A manual trip from the arrays (n,) t, v, gap, v_lead, a: pedals NaN, ``acc_state``
        0, ``meta["mode"] = "manual"``."""
        n = np.asarray(t_s).shape[0] if np.ndim(t_s) else 0
        return cls(
            t_s=t_s,
            v_mps=v_mps,
            gap_m=gap_m,
            v_lead_mps=v_lead_mps,
            a_mps2=a_mps2,
            accel_pedal=np.full(n, np.nan),
            brake_pedal=np.full(n, np.nan),
            acc_state=np.zeros(n, dtype=np.int64),
            meta={"mode": TripMode.MANUAL.value, **(meta or {})},
        )

    def __len__(self) -> int:
        return int(self.t_s.shape[0])

    @property
    def duration_s(self) -> float:
        """Time from the first to the last sample, s (0 for fewer than two samples)."""
        return float(self.t_s[-1] - self.t_s[0]) if len(self) > 1 else 0.0

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Trip):
            return NotImplemented
        return self.meta == other.meta and all(
            np.array_equal(getattr(self, k), getattr(other, k), equal_nan=True)
            for k in (*FLOAT_FIELDS, "acc_state")
        )


def trip_mode(trip: Trip) -> TripMode:
    """The trip mode of ``trip``: its ``meta["mode"]``, else ``acc`` when its ACC state was
    Active at some sample, else ``manual`` (TripModeError: an unknown mode)."""
    mode = trip.meta.get("mode")
    if mode is None:
        return (
            TripMode.ACC
            if bool(np.any(trip.acc_state == int(AccState.ACTIVE)))
            else TripMode.MANUAL
        )
    try:
        return TripMode(mode)
    except ValueError:
        known = ", ".join(m.value for m in TripMode)
        raise TripModeError(f"unknown trip mode {mode!r} (known: {known})") from None
