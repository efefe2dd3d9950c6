"""Held-out gap error of each learner against the empirical baseline, per driver.

Every trip trains on its first 70 % and is tested on the rest: the mean absolute difference
(m) between the table at the ego speed and the actual gap over the near-steady test samples
(``|v_lead - v| < 0.5 m/s``, ``|a| < 0.3 m/s^2``), at speeds both cover. Drivers: real human
pairs (OpenACC), d1..d5 and drawn drivers.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from cloud_sync.errors import CloudSyncError
from cloud_sync.irl.sources.tripfiles import read_csv_trip
from cloud_sync.learners import learn
from dbc.vocab import FormatError
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog import Trip
from pacc.study.irl_table import manual_trips
from sim_bus.dataset import load_human_pairs
from sim_bus.drivers import DriverParams

TRAIN_FRACTION = 0.7
BASELINE = "empirical"
#: learners to evaluate: (spec, arguments as (name, value) pairs)
LearnerSpecs = tuple[tuple[str, tuple[tuple[str, Any], ...]], ...]
_TRIP_ARRAYS = ("t_s", "v_mps", "gap_m", "v_lead_mps", "a_mps2", "accel_pedal", "brake_pedal")


@dataclass(frozen=True)
class HeldOutTask:
    """One driver's held-out evaluation; picklable. ``trips``: the real driver's trips (None:
    a simulated ``driver``'s manual trips with ``seed``)."""

    name: str
    kind: str  # "real", "builtin" or "drawn"
    learners: LearnerSpecs
    seed: int
    trips: tuple[Trip, ...] | None = None
    driver: DriverParams | None = None
    group: str = ""  # the population seed of a drawn driver


def part(trip: Trip, start: int, stop: int) -> Trip:
    """Samples ``start:stop`` of a trip (a time split)."""
    arrays = {name: getattr(trip, name)[start:stop] for name in _TRIP_ARRAYS}
    return dataclasses.replace(trip, **arrays, acc_state=trip.acc_state[start:stop])


def held_out_error(table: Dgpt, test: Trip, covered: np.ndarray) -> float:
    """Mean |DGPT(v) - g| (m) over the near-steady samples of ``test`` at speeds whose bin is
    ``covered`` ((n,) bool on the table's axis); NaN without one."""
    v, g, vl, a = test.v_mps, test.gap_m, test.v_lead_mps, test.a_mps2
    axis = table.speed_mps
    finite = np.isfinite(v)
    vv = np.where(finite, v, 0.0)
    bins = np.clip(np.round((vv - axis[0]) / table.step_mps).astype(np.int64), 0, axis.size - 1)
    steady = finite & np.isfinite(g) & (np.abs(vl - v) < 0.5) & (np.abs(a) < 0.3) & covered[bins]
    if not steady.any():
        return math.nan
    return float(np.mean(np.abs(table.lookup(v[steady]) - g[steady])))


def real_tasks(csvs: Sequence[str], learners: LearnerSpecs, seed: int) -> list[HeldOutTask]:
    """The shipped OpenACC human pairs and each CSV as one real driver each."""
    tasks = []
    for p in load_human_pairs():
        t = np.arange(p.v_follower_mps.size) * p.dt_s
        a = np.gradient(p.v_follower_mps, t)
        trip = Trip.manual(t, p.v_follower_mps, p.gap_m, p.v_leader_mps, a, {"source": p.pair_id})
        tasks.append(HeldOutTask(f"real:{p.pair_id}", "real", learners, seed, trips=(trip,)))
    for path in csvs:
        trip = read_csv_trip(path)
        tasks.append(HeldOutTask(f"real:{Path(path).stem}", "real", learners, seed, trips=(trip,)))
    return tasks


def heldout_task(task: HeldOutTask) -> dict[str, Any]:
    """Learn with each learner and the baseline on the first 70 %, test on the rest."""
    if task.trips is not None:
        trips = list(task.trips)
    else:
        assert task.driver is not None
        trips = manual_trips(task.driver, task.seed)
    cuts = [int(TRAIN_FRACTION * t.t_s.size) for t in trips]
    train = [part(t, 0, c) for t, c in zip(trips, cuts, strict=True)]
    test = [part(t, c, t.t_s.size) for t, c in zip(trips, cuts, strict=True)]
    rec: dict[str, Any] = {"driver": task.name, "kind": task.kind, "group": task.group, "rows": []}
    try:
        base = learn(BASELINE, train, driver_id=task.name, seed=task.seed)
    except (FormatError, CloudSyncError, ValueError) as exc:
        rec["error"] = f"baseline: {exc}"
        return rec
    base_cov = np.asarray(base.meta["covered"], dtype=bool)
    for spec, args in task.learners:
        row: dict[str, Any] = {"learner": spec}
        try:
            table = learn(spec, train, driver_id=task.name, seed=task.seed, params=dict(args))
        except (FormatError, CloudSyncError, ValueError) as exc:
            row["error"] = str(exc)
            rec["rows"].append(row)
            continue
        both = np.asarray(table.meta["covered"], dtype=bool) & base_cov
        mine = [held_out_error(table, t, both) for t in test]
        theirs = [held_out_error(base, t, both) for t in test]
        ok = [i for i, x in enumerate(mine) if math.isfinite(x)]
        row["learn_s"] = float(table.meta["learn_s"])
        row["bins"] = int(both.sum())
        if ok:
            row["error_m"] = float(np.mean([mine[i] for i in ok]))
            row["baseline_m"] = float(np.mean([theirs[i] for i in ok]))
        rec["rows"].append(row)
    return rec
