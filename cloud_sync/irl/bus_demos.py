"""Demonstrations from a real car's bus log: the manual car-following stretches as trip logs.

``pacc demos extract LOG... --dbc CAR.dbc --binding CAR.binding.toml -o trips/``
(:mod:`pacc.commands.demos`). Any log python-can reads (BLF, ASC, candump ``.log``, TRC …,
and pacc's ``.mcap`` recordings through pacc's python-can plugin) is read frame by frame and
decoded through the car's binding (:class:`dbc.endpoint.Inbox`: the bound messages, their
checksums and counters, physical units): the ego speed and acceleration, the pedals, the
radar's lead, and the ACC's state where the car sends one. The decoded values are sampled on a
10-Hz grid (the last good value of each role, as the ECU reads them) and cut into stretches
where the driver drives and follows a lead: ACC not engaged (OFF or STANDBY, or no ACC frames
at all), lead valid, pedals and speed fresh. Stretches of ``min_s`` or more become manual trip
logs (:class:`pacc.vocab.triplog.Trip`, ``mode`` ``manual``) that the cloud learns from; the
report says how many seconds were kept and why the rest was dropped.
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
from pacc.vocab.acc_state import AccState
from pacc.vocab.pedals import PedalScale
from pacc.vocab.triplog import Trip

__all__ = ["DT_S", "ExtractReport", "bus_trip", "extract_demos", "read_frames"]

#: the trips' sample period, s (the simulator's trip logs use the same)
DT_S = 0.1
_ROLES = ("ego", "pedals", "radar", "command")


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


def _grid(frames: Iterable[Any], codec: Codec) -> tuple[dict[str, np.ndarray], int]:
    """The roles' values on a 10-Hz grid (last usable value, NaN where a role is not fresh),
    and the number of frames."""
    roles = tuple(r for r in _ROLES if r in codec.roles)
    inbox = Inbox(codec, roles)
    pedals = PedalScale.from_codec(codec) if "pedals" in roles else None
    rows: dict[str, list[float]] = {
        k: []
        for k in ("t_s", "v", "a", "gap", "v_lead", "accel", "brake", "state", "lead", "fresh")
    }
    n = 0
    t_next: float | None = None
    for msg in frames:
        n += 1
        t = float(msg.timestamp)
        if t_next is None:
            t_next = t
        while t >= t_next:  # the grid points before this frame see what came before it
            _sample(rows, inbox, t_next, pedals)
            t_next += DT_S
        inbox.accept_message(msg, t)
    return {k: np.asarray(v, dtype=np.float64) for k, v in rows.items()}, n


def _value(values: dict[str, Any] | None, key: str) -> float:
    if values is None or values.get(key) is None:
        return math.nan
    return float(values[key])


def _sample(rows: dict[str, list[float]], inbox: Inbox, t: float, pedals: Any) -> None:
    ego, ped, radar, cmd = (inbox.latest(r) if r in inbox.roles else None for r in _ROLES)
    fresh = all(inbox.fresh(r, t) for r in ("ego", "pedals", "radar") if r in inbox.roles)
    v = _value(ego, "speed_mps")
    lead = _value(radar, "lead_valid") == 1.0
    rows["t_s"].append(t)
    rows["v"].append(v)
    rows["a"].append(_value(ego, "accel_mps2"))
    rows["gap"].append(_value(radar, "gap_m") if lead else math.nan)
    rows["v_lead"].append(v + _value(radar, "rel_speed_mps") if lead else math.nan)
    rows["accel"].append(pedals.accel(_value(ped, "accel_pedal_pct")) if pedals else math.nan)
    rows["brake"].append(pedals.brake(_value(ped, "brake_pressure_bar")) if pedals else math.nan)
    state = _value(cmd, "acc_state")
    rows["state"].append(float(AccState.OFF) if math.isnan(state) else state)
    rows["lead"].append(1.0 if lead else 0.0)
    rows["fresh"].append(1.0 if fresh and ego is not None and ped is not None else 0.0)


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
    missing): what ``pacc plot --binding`` draws from a foreign log.

    Raises:
        TripLogError: fewer than two samples.
    """
    g, _ = _grid(frames, codec)
    return Trip(
        t_s=g["t_s"] - (g["t_s"][0] if len(g["t_s"]) else 0.0),
        v_mps=g["v"],
        gap_m=g["gap"],
        v_lead_mps=g["v_lead"],
        a_mps2=g["a"],
        accel_pedal=g["accel"],
        brake_pedal=g["brake"],
        acc_state=g["state"].astype(np.int64),
        meta={"mode": "bus", "source": "pacc plot", **(meta or {})},
    )


def extract_demos(
    path: str | os.PathLike[str],
    codec: Codec,
    *,
    driver_id: str,
    condition: str = "default",
    min_s: float = 10.0,
    frames: Iterable[Any] | None = None,
) -> ExtractReport:
    """The manual car-following stretches of the log at ``path`` (module docstring).

    Args:
        path: the log (any format python-can reads).
        codec: the car's DBC and binding.
        driver_id: the driver the trips are tagged with.
        condition: the driving condition they are tagged with.
        min_s: shorter stretches are dropped ("stretch shorter than …").
        frames: the frames, if already read (default: read ``path``).
    """
    path = Path(path)
    g, n = _grid(read_frames(path) if frames is None else frames, codec)
    report = ExtractReport(path, frames=n)
    why = _reasons(g)
    ok = why == ""
    for reason in set(why[~ok].tolist()):
        report.dropped_s[reason] = float(np.sum(why == reason)) * DT_S
    edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.astype(np.int8), [0]))))
    for start, end in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
        seconds = (end - start) * DT_S
        if seconds < min_s:
            short = f"stretch shorter than {min_s:g} s"
            report.dropped_s[short] = report.dropped_s.get(short, 0.0) + seconds
            continue
        sl = slice(start, end)
        meta = {
            "driver_id": driver_id,
            "condition": condition,
            "mode": "manual",
            "source": "pacc demos extract",
            "log": path.name,
            "log_t0_s": float(g["t_s"][start]),
        }
        trip = Trip(
            t_s=g["t_s"][sl] - g["t_s"][start],
            v_mps=g["v"][sl],
            gap_m=g["gap"][sl],
            v_lead_mps=g["v_lead"][sl],
            a_mps2=g["a"][sl],
            accel_pedal=g["accel"][sl],
            brake_pedal=g["brake"][sl],
            acc_state=g["state"][sl].astype(np.int64),
            meta=meta,
        )
        report.trips.append(trip)
        report.kept_s += seconds
    return report
