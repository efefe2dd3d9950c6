"""The Driving Gap Preference Table (DGPT): the desired gap to the lead (m) per ego speed.

A uniform speed axis 0..40 m/s (step <= 0.5 m/s), one bumper-to-bumper gap per bin,
interpolated linearly and held beyond the ends, with its provenance (version, driver,
condition, source, creation time, meta). Valid by construction (shapes, axis, finite values;
:class:`SafetyBounds` where asked), else :class:`DgptError`. File format:
:mod:`dbc.vocab.dgpt_file`.
"""

from __future__ import annotations

import math
import re
from dataclasses import astuple, dataclass, field, replace
from datetime import UTC, datetime
from typing import Any, Literal, TypeVar, cast, get_args, overload

import numpy as np
import numpy.typing as npt

from dbc.vocab import FormatError

FORMAT_TAG = "pacc.dgpt/1"
#: the highest table version: ACC_Status carries it in 16 bits (DgptVersion, dbc/pacc.dbc)
MAX_VERSION = 0xFFFF
#: a driver id or condition: 1-64 letters, digits, ``_ . -``, starting with a letter or
#: digit (they name folders in the cloud's store and on the vehicle: never ``..`` or ``/``)
PLAIN_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")
#: Upper end of the speed axis, m/s.
AXIS_MAX_MPS = 40.0
#: Coarsest allowed speed-axis step, m/s.
AXIS_MAX_STEP_MPS = 0.5
#: Default speed-axis step of generated tables, m/s.
DEFAULT_STEP_MPS = 0.5
_AXIS_TOL = 1e-6

Source = Literal["predefined", "irl", "adapted"]
_SOURCES: tuple[str, ...] = get_args(Source)
FloatArray = npt.NDArray[np.float64]
_V = TypeVar("_V", float, FloatArray)


class DgptError(FormatError):
    """A DGPT is malformed, unsafe, or cannot be read or written."""


def utc_now_iso() -> str:
    """Current UTC time as ISO 8601 with a ``Z`` suffix, second resolution."""
    return datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


@dataclass(frozen=True)
class SafetyBounds:
    """The safe region of a DGPT: ``standstill_min_m + headway_min_s * v`` to
    ``standstill_max_m + headway_max_s * v`` (v m/s, gaps m); ``standstill_m`` is the nominal
    standstill distance d0 (predefined tables, the adaptation's safety filter)."""

    standstill_m: float = 4.0
    headway_min_s: float = 0.8
    headway_max_s: float = 5.0
    standstill_min_m: float = 2.0
    standstill_max_m: float = 10.0

    def __post_init__(self) -> None:
        if not all(math.isfinite(x) and x >= 0.0 for x in astuple(self)):
            raise DgptError(f"SafetyBounds must be finite and non-negative: {self}")
        if self.headway_min_s > self.headway_max_s:
            raise DgptError("SafetyBounds: headway_min_s exceeds headway_max_s")
        if not self.standstill_min_m <= self.standstill_m <= self.standstill_max_m:
            raise DgptError(
                "SafetyBounds: need standstill_min_m <= standstill_m <= standstill_max_m"
            )

    def lower_m(self, v_mps: _V) -> _V:
        """Smallest safe gap (m) at speed ``v_mps`` (scalar or array of any shape)."""
        return self.standstill_min_m + self.headway_min_s * v_mps

    def upper_m(self, v_mps: _V) -> _V:
        """Largest safe gap (m) at speed ``v_mps`` (scalar or array of any shape)."""
        return self.standstill_max_m + self.headway_max_s * v_mps


def speed_axis(step_mps: float = DEFAULT_STEP_MPS) -> FloatArray:
    """The uniform speed axis 0..40 m/s with ``step_mps`` (shape ``(n,)``)."""
    if not 0.0 < step_mps <= AXIS_MAX_STEP_MPS:
        raise DgptError(f"speed step must be in (0, {AXIS_MAX_STEP_MPS}] m/s, got {step_mps}")
    n = int(round(AXIS_MAX_MPS / step_mps))
    if abs(n * step_mps - AXIS_MAX_MPS) > _AXIS_TOL:
        raise DgptError(f"speed step {step_mps} m/s does not divide {AXIS_MAX_MPS} m/s")
    return np.linspace(0.0, AXIS_MAX_MPS, n + 1)


def _readonly(a: Any, name: str) -> FloatArray:
    try:
        arr = np.array(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise DgptError(f"{name} is not an array of numbers: {exc}") from None
    arr.setflags(write=False)
    return arr


def _check_structure(speed: FloatArray, gap: FloatArray) -> None:
    if speed.ndim != 1 or gap.ndim != 1:
        raise DgptError(f"speed_mps and gap_m must be 1-D, got shapes {speed.shape}, {gap.shape}")
    if speed.shape != gap.shape:
        raise DgptError(f"speed_mps and gap_m differ in length: {speed.size} vs {gap.size}")
    if speed.size < 2:
        raise DgptError("a DGPT needs at least two speed bins")
    if not np.all(np.isfinite(speed)):
        raise DgptError("speed_mps contains a non-finite value")
    if not np.all(np.isfinite(gap)):
        bad = int(np.flatnonzero(~np.isfinite(gap))[0])
        raise DgptError(f"gap_m[{bad}] is not finite ({gap[bad]})")
    steps = np.diff(speed)
    if not np.all(steps > 0.0):
        raise DgptError("speed_mps is not strictly increasing")
    if abs(speed[0]) > _AXIS_TOL or abs(speed[-1] - AXIS_MAX_MPS) > _AXIS_TOL:
        raise DgptError(
            f"speed_mps must span 0..{AXIS_MAX_MPS:g} m/s, got {speed[0]:g}..{speed[-1]:g}"
        )
    step = float(steps.mean())
    if np.max(np.abs(steps - step)) > 1e-4:
        raise DgptError("speed_mps is not uniformly spaced")
    if step > AXIS_MAX_STEP_MPS + _AXIS_TOL:
        raise DgptError(f"speed step {step:g} m/s is coarser than {AXIS_MAX_STEP_MPS} m/s")


def clamp_to_bounds(
    speed_mps: FloatArray, gap_m: FloatArray, bounds: SafetyBounds | None = None
) -> FloatArray:
    """``gap_m`` (shape ``(n,)``) clipped bin-wise into ``bounds`` at ``speed_mps`` (``(n,)``)."""
    b = bounds if bounds is not None else SafetyBounds()
    return np.clip(gap_m, b.lower_m(speed_mps), b.upper_m(speed_mps))


@dataclass(frozen=True, eq=False)
class Dgpt:
    """A DGPT (immutable, read-only arrays): ``speed_mps`` (n,) axis, m/s; ``gap_m`` (n,)
    gaps, m; ``version`` 0..:data:`MAX_VERSION`, +1 per change; ``driver_id`` and
    ``condition`` (plain names in a file); ``source``; ``created_utc`` ISO 8601; ``meta``."""

    speed_mps: FloatArray
    gap_m: FloatArray
    version: int = 0
    driver_id: str = "guest"
    condition: str = "default"
    source: Source = "predefined"
    created_utc: str = field(default_factory=utc_now_iso)
    meta: dict[str, Any] = field(default_factory=dict)
    # lookup()'s scalar fast path: Python floats, no numpy call per control cycle
    _v0: float = field(init=False, repr=False)
    _dv: float = field(init=False, repr=False)
    _gaps: tuple[float, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        speed = _readonly(self.speed_mps, "speed_mps")
        gap = _readonly(self.gap_m, "gap_m")
        _check_structure(speed, gap)
        if isinstance(self.version, bool) or not isinstance(self.version, int | np.integer):
            raise DgptError(f"version must be an integer, got {self.version!r}")
        if not 0 <= self.version <= MAX_VERSION:
            raise DgptError(f"version must be 0 to {MAX_VERSION}, got {self.version}")
        if self.source not in _SOURCES:
            raise DgptError(f"source must be one of {_SOURCES}, got {self.source!r}")
        for name in ("driver_id", "condition", "created_utc"):
            if not isinstance(getattr(self, name), str):
                raise DgptError(f"{name} must be a string")
        if not isinstance(self.meta, dict):
            raise DgptError("meta must be a JSON object")
        object.__setattr__(self, "speed_mps", speed)
        object.__setattr__(self, "gap_m", gap)
        object.__setattr__(self, "version", int(self.version))
        object.__setattr__(self, "_v0", float(speed[0]))
        object.__setattr__(self, "_dv", float(speed[1] - speed[0]))
        object.__setattr__(self, "_gaps", tuple(float(g) for g in gap))

    @property
    def step_mps(self) -> float:
        """Speed-axis step, m/s."""
        return self._dv

    @overload
    def lookup(self, v_mps: float) -> float: ...
    @overload
    def lookup(self, v_mps: FloatArray) -> FloatArray: ...
    def lookup(self, v_mps: float | FloatArray) -> float | FloatArray:
        """Desired gap (m) at speed ``v_mps`` (m/s; a scalar or an array of any shape),
        interpolated linearly, ends held; NaN gives NaN."""
        if isinstance(v_mps, np.ndarray):
            return cast(FloatArray, np.interp(v_mps, self.speed_mps, self.gap_m))
        gaps, v0, dv = self._gaps, self._v0, self._dv
        x = (float(v_mps) - v0) / dv
        if not x > 0.0:
            return gaps[0] if x <= 0.0 else math.nan
        last = len(gaps) - 1
        if x >= last:
            return gaps[last]
        i = int(x)
        f = x - i
        return gaps[i] + f * (gaps[i + 1] - gaps[i])

    def slope(self, v_mps: float) -> float:
        """d(gap)/d(speed) of the interpolant at ``v_mps``, in s (0 beyond the axis ends)."""
        gaps, v0, dv = self._gaps, self._v0, self._dv
        x = (float(v_mps) - v0) / dv
        last = len(gaps) - 1
        if not 0.0 <= x < last:
            return 0.0
        i = int(x)
        return (gaps[i + 1] - gaps[i]) / dv

    def with_gaps(
        self,
        gap_m: FloatArray,
        source: Source = "adapted",
        *,
        created_utc: str | None = None,
        meta: dict[str, Any] | None = None,
    ) -> Dgpt:
        """A copy with new gaps (n,), m, ``version + 1``, ``source`` and ``meta`` (default: a
        copy of this table's)."""
        return replace(
            self,
            gap_m=np.asarray(gap_m, dtype=np.float64).copy(),
            version=self.version + 1,
            source=source,
            created_utc=created_utc if created_utc is not None else utc_now_iso(),
            meta=dict(self.meta) if meta is None else dict(meta),
        )

    def check_bounds(self, bounds: SafetyBounds | None = None) -> None:
        """Raise :class:`DgptError` naming the first bin whose gap lies outside ``bounds``
        (default bounds)."""
        b, speed, gap = bounds if bounds is not None else SafetyBounds(), self.speed_mps, self.gap_m
        lo, hi = b.lower_m(speed), b.upper_m(speed)
        bad = np.flatnonzero((gap < lo - 1e-9) | (gap > hi + 1e-9))
        if bad.size:
            i = int(bad[0])
            raise DgptError(
                f"gap {gap[i]:.3f} m at {speed[i]:g} m/s is outside the safety bounds "
                f"[{lo[i]:.3f}, {hi[i]:.3f}] m ({bad.size} bin(s) out of bounds)"
            )

    def to_json_dict(self) -> dict[str, Any]:
        """The JSON object of this table (format ``pacc.dgpt/1``)."""
        return {
            "format": FORMAT_TAG,
            "driver_id": self.driver_id,
            "condition": self.condition,
            "source": self.source,
            "version": self.version,
            "created_utc": self.created_utc,
            "speed_mps": [float(v) for v in self.speed_mps],  # exact: bounds are re-checked
            "gap_m": [float(g) for g in self.gap_m],
            "meta": self.meta,
        }


def predefined(
    headway_s: float,
    standstill_m: float = 4.0,
    driver_id: str = "guest",
    *,
    condition: str = "default",
    step_mps: float = DEFAULT_STEP_MPS,
    bounds: SafetyBounds | None = None,
    created_utc: str | None = None,
) -> Dgpt:
    """A constant-time-headway table ``gap(v) = standstill_m + headway_s * v`` (the paper's
    1, 3 and 4 s); :class:`DgptError` if it leaves ``bounds``."""
    if not (math.isfinite(headway_s) and math.isfinite(standstill_m)):
        raise DgptError(f"headway and standstill must be finite: {headway_s}, {standstill_m}")
    speed = speed_axis(step_mps)
    table = Dgpt(
        speed_mps=speed,
        gap_m=standstill_m + headway_s * speed,
        version=0,
        driver_id=driver_id,
        condition=condition,
        source="predefined",
        created_utc=created_utc if created_utc is not None else utc_now_iso(),
        meta={"headway_s": float(headway_s), "standstill_m": float(standstill_m)},
    )
    try:
        table.check_bounds(bounds)
    except DgptError as exc:
        raise DgptError(f"predefined table {headway_s:g} s + {standstill_m:g} m: {exc}") from None
    return table
