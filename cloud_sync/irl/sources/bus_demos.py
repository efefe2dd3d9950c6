"""Demonstrations from a real car's bus log: the manual car-following stretches as trip logs.

``pacc demos extract LOG... -o trips/`` (:mod:`pacc.commands.demos`): any log python-can reads
is decoded through the car's binding (:class:`dbc.endpoint.Inbox`) and sampled as the ECU
records (:class:`ecu.manual.ManualRecorder`, :func:`dbc.vocab.sampling.keep_sample`) at its
command frames, else on a ``period_s`` grid; times relative to the first frame, rounded to
:data:`TIME_RESOLUTION_S` s. Samples with the ACC not engaged, a valid lead and good inputs,
in runs of ``min_s``..``max_s`` s, become manual trip logs; the report says what was dropped.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dbc.codec import Codec
from dbc.endpoint import Inbox
from dbc.frame import raw_of
from dbc.vocab.acc_state import AccState
from dbc.vocab.pedals import PedalScale
from dbc.vocab.sampling import MANUAL_MAX_S, MANUAL_MIN_S, PERIOD_EPS_S, keep_interval_s
from dbc.vocab.triplog import Trip

#: the trips' sample period, s (the ECU recorder's and the simulator's trip logs' too)
DT_S = 0.1
#: sample times are rounded to this, s (module docstring)
TIME_RESOLUTION_S = 1e-6
_ROLES = ("ego", "pedals", "radar", "command")
_COLS = ("t_s", "v", "a", "gap", "v_lead", "accel", "brake", "state", "lead", "fresh")


@dataclass
class ExtractReport:
    """What one log gave: seconds kept, seconds dropped per reason, the trips."""

    path: Path
    frames: int = 0
    kept_s: float = 0.0
    dropped_s: dict[str, float] = field(default_factory=dict)
    trips: list[Trip] = field(default_factory=list)

    def lines(self) -> list[str]:
        """The report as text lines."""
        total = self.kept_s + sum(self.dropped_s.values())
        out = [
            f"{self.path}: {self.frames} frames, {total:.1f} s: kept {self.kept_s:.1f} s in "
            f"{len(self.trips)} trips"
        ]
        out += [
            f"  dropped {s:7.1f} s: {why}"
            for why, s in sorted(self.dropped_s.items(), key=lambda x: -x[1])
        ]
        return out


def read_frames(path: Path) -> Iterator[Any]:
    """The frames of any log python-can reads (an ASC with its absolute times)."""
    import can  # noqa: PLC0415 - python-can only when a log is read

    kwargs = {"relative_timestamp": False} if path.suffix.lower() == ".asc" else {}
    with can.LogReader(path, **kwargs) as reader:
        yield from reader


class _Sampler:
    """The decoded roles and their samples: at the ECU's cycles (the command frames) and on
    a plain ``period_s`` grid, both kept until the log's end tells which to use."""

    def __init__(self, codec: Codec, period_s: float) -> None:
        roles = tuple(r for r in _ROLES if r in codec.roles)
        self.inbox = Inbox(codec, roles)
        self.pedals = PedalScale.from_codec(codec) if "pedals" in roles else None
        self.period_s = period_s
        command = codec.roles.get("command")
        #: the cycle's last command frame (the ECU sends the role's messages in order)
        self.marker = None if command is None else command.parts[-1].frame_id
        cycle = 0.0 if command is None else command.parts[-1].cycle_s
        #: the ECU recorder's rule (dbc.vocab.sampling.keep_sample): a cycle is kept this
        #: long after the last kept one
        self.keep_after_s = keep_interval_s(period_s, cycle)
        self.at_cycles: dict[str, list[float]] = {k: [] for k in _COLS}
        self.on_grid: dict[str, list[float]] = {k: [] for k in _COLS}
        self.markers: list[float] = []
        self._kept = -math.inf
        self._k = 0
        self._t0: float | None = None

    def frame(self, msg: Any) -> None:
        """One frame of the log, in log order."""
        stamp = float(msg.timestamp)
        if self._t0 is None:
            self._t0 = stamp
        t = round((stamp - self._t0) / TIME_RESOLUTION_S) * TIME_RESOLUTION_S
        while t > self._k * self.period_s + PERIOD_EPS_S:  # grid points before this frame
            _sample(self.on_grid, self.inbox, self._k * self.period_s, self.pedals)
            self._k += 1
        _, key, data = raw_of(msg)
        self.inbox.accept(key, data, t)
        if msg.arbitration_id == self.marker:
            self.markers.append(t)
            if t - self._kept >= self.keep_after_s:
                self._kept = t
                _sample(self.at_cycles, self.inbox, t, self.pedals)

    def rows(self) -> dict[str, np.ndarray]:
        """The samples at the ECU's cycles if the log has them at a cycle dividing
        ``period_s``, else on the grid."""
        rows = self.on_grid
        if len(self.markers) > 1:
            cycle = float(np.median(np.diff(self.markers)))
            ratio = self.period_s / cycle if cycle > 0 else 0.0
            # a whole number of cycles per sample (a real-time ECU's cycles jitter a little)
            if ratio >= 0.95 and abs(ratio - round(ratio)) < 0.05:
                rows = self.at_cycles
        return {k: np.asarray(v, dtype=np.float64) for k, v in rows.items()}


def _grid(
    frames: Iterable[Any], codec: Codec, period_s: float = DT_S
) -> tuple[dict[str, np.ndarray], int]:
    """The roles' values at the samples (module docstring; NaN where a role is missing),
    and the number of frames."""
    sampler = _Sampler(codec, period_s)
    n = 0
    for msg in frames:
        n += 1
        sampler.frame(msg)
    return sampler.rows(), n


def _value(values: dict[str, Any] | None, key: str) -> float:
    if values is None or values.get(key) is None:
        return math.nan
    return float(values[key])


def _finite(*xs: float) -> bool:
    return all(map(math.isfinite, xs))


def _sample(rows: dict[str, list[float]], inbox: Inbox, t: float, pedals: Any) -> None:
    """One sample at ``t``: the latest values and whether the inputs are good as the ECU
    checks them (:func:`ecu.busio.inputs_from`, :func:`ecu.signals.input_fault`)."""
    ego, ped, radar, cmd = (inbox.latest(r) if r in inbox.roles else None for r in _ROLES)
    v, a = _value(ego, "speed_mps"), _value(ego, "accel_mps2")
    accel = pedals.accel(_value(ped, "accel_pedal_pct")) if pedals else math.nan
    brake = pedals.brake(_value(ped, "brake_pressure_bar")) if pedals else math.nan
    lead = _value(radar, "lead_valid") == 1.0
    gap, rel = _value(radar, "gap_m"), _value(radar, "rel_speed_mps")
    roles = inbox.roles
    speed_ok = (
        ego is not None
        and _value(ego, "speed_valid") == 1.0
        and inbox.fresh("ego", t)
        and _finite(v, a)
        and v >= 0.0
    )
    pedals_ok = ped is not None and inbox.fresh("pedals", t) and _finite(accel, brake)
    radar_ok = (
        "radar" in roles
        and radar is not None
        and inbox.fresh("radar", t)
        and (not lead or _finite(gap, rel, _value(radar, "lead_accel_mps2")))
    )
    rows["t_s"].append(t)
    rows["v"].append(v)
    rows["a"].append(a)
    rows["gap"].append(gap if lead else math.nan)
    rows["v_lead"].append(v + rel if lead else math.nan)
    rows["accel"].append(accel)
    rows["brake"].append(brake)
    state = _value(cmd, "acc_state")
    rows["state"].append(float(AccState.OFF) if math.isnan(state) else state)
    rows["lead"].append(1.0 if lead else 0.0)
    rows["fresh"].append(1.0 if speed_ok and pedals_ok and radar_ok else 0.0)


def _reasons(g: dict[str, np.ndarray]) -> np.ndarray:
    """Per grid point: "" (usable) or why it is dropped (the first reason that applies)."""
    why = np.full(len(g["t_s"]), "", dtype=object)
    engaged = ~np.isin(g["state"], (float(AccState.OFF), float(AccState.STANDBY)))
    for mask, text in (
        (~np.isfinite(g["accel"]) | ~np.isfinite(g["brake"]), "pedals missing"),
        (g["fresh"] == 0.0, "speed, pedals or radar not fresh (timeout, checksum, counter)"),
        (~np.isfinite(g["v"]), "no speed"),
        (engaged, "ACC engaged (the ECU drives, not the driver)"),
        (g["lead"] == 0.0, "no lead vehicle"),
    ):
        why[(why == "") & mask] = text
    return why


def bus_trip(frames: Iterable[Any], codec: Codec, meta: dict[str, Any] | None = None) -> Trip:
    """The whole log as one trip (every 10-Hz sample, ACC on or off; NaN where a role is
    missing), as ``pacc plot --binding`` draws it; TripLogError for fewer than two samples."""
    g, _ = _grid(frames, codec)
    return _trip(g, slice(0, len(g["t_s"])), {"mode": "bus", "source": "pacc plot", **(meta or {})})


def extract_demos(
    path: str | os.PathLike[str],
    codec: Codec,
    *,
    driver_id: str,
    condition: str = "default",
    min_s: float = MANUAL_MIN_S,
    max_s: float = MANUAL_MAX_S,
    frames: Iterable[Any] | None = None,
) -> ExtractReport:
    """The manual car-following stretches of the log at ``path`` (``frames``: already read)
    decoded by ``codec``, tagged ``driver_id``/``condition``: stretches under ``min_s`` s
    dropped, longer than ``max_s`` s cut."""
    path = Path(path)
    g, n = _grid(read_frames(path) if frames is None else frames, codec)
    report = ExtractReport(path, frames=n)
    why = _reasons(g)
    ok = why == ""
    for reason in set(why[~ok].tolist()):
        report.dropped_s[reason] = float(np.sum(why == reason)) * DT_S
    edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(np.int8), [0]))))
    max_n = max(1, int(round(max_s / DT_S)))
    for first, end in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        for start in range(first, end, max_n):
            stop = min(start + max_n, end)
            seconds = (stop - start) * DT_S
            if seconds < min_s - PERIOD_EPS_S:
                short = f"stretch shorter than {min_s:g} s"
                report.dropped_s[short] = report.dropped_s.get(short, 0.0) + seconds
                continue
            meta = {
                "driver_id": driver_id,
                "condition": condition,
                "mode": "manual",
                "source": "pacc demos extract",
                "log": path.name,
                "log_t0_s": float(g["t_s"][start]),
            }
            report.trips.append(_trip(g, slice(start, stop), meta))
            report.kept_s += seconds
    return report


def _trip(g: dict[str, np.ndarray], sl: slice, meta: dict[str, Any]) -> Trip:
    """The samples ``sl`` as a trip log, time from its first sample."""
    t = g["t_s"][sl]
    return Trip(
        t_s=t - (t[0] if len(t) else 0.0),
        v_mps=g["v"][sl],
        gap_m=g["gap"][sl],
        v_lead_mps=g["v_lead"][sl],
        a_mps2=g["a"][sl],
        accel_pedal=g["accel"][sl],
        brake_pedal=g["brake"][sl],
        acc_state=g["state"][sl].astype(np.int64),
        meta=meta,
    )
