"""Trip files by suffix: ``.mcap`` (pacc trip logs) and ``.csv`` (car-following pairs).

CSV: the OpenACC leader/follower columns (SI units, gap bumper to bumper); required ``t,
v_follower, spacing, v_leader``, ``a_follower`` optional (else the derivative of
``v_follower``). Manual driving: ``acc_state`` 0, pedals NaN.
"""

from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Any

import numpy as np

from dbc.vocab.triplog import Trip, TripLogError
from dbc.vocab.triplog_file import read_trip
from dbc.vocab.tripmode import TripMode

REQUIRED_CSV_COLUMNS: tuple[str, ...] = ("t", "v_follower", "spacing", "v_leader")


def read_csv_trip(
    path: str | os.PathLike[str], *, driver_id: str | None = None, condition: str = "default"
) -> Trip:
    """A car-following CSV as a manual :class:`Trip` (``driver_id``: the stem unless given);
    TripLogError naming the file if unreadable, a column missing or a cell not numeric."""
    path = Path(path)
    try:
        with path.open(newline="") as stream:
            header = next(csv.reader(stream), None)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:  # unreadable, not text, not CSV
        raise TripLogError(f"{path}: cannot read CSV ({exc})") from exc
    if not header:
        raise TripLogError(f"{path}: empty CSV file")
    names = [h.strip() for h in header]
    missing = [c for c in REQUIRED_CSV_COLUMNS if c not in names]
    if missing:
        raise TripLogError(
            f"{path}: CSV lacks column(s) {', '.join(missing)} (has: {', '.join(names)})"
        )
    try:
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, dtype=np.float64)
    except ValueError as exc:
        raise TripLogError(f"{path}: non-numeric or ragged CSV data ({exc})") from exc
    if data.shape[0] and data.shape[1] != len(names):
        raise TripLogError(f"{path}: {data.shape[1]} values per row, header has {len(names)}")
    col = {name: data[:, i] for i, name in enumerate(names)} if data.shape[0] else {}
    n = data.shape[0]
    t = col.get("t", np.zeros(0))
    v = col.get("v_follower", np.zeros(0))
    if "a_follower" in col:
        a = col["a_follower"]
    elif n > 1:
        a = np.gradient(v, t)
    else:
        a = np.zeros(n)
    meta: dict[str, Any] = {
        "driver_id": driver_id if driver_id is not None else path.stem,
        "condition": condition,
        "mode": TripMode.MANUAL.value,
        "source": path.name,
    }
    try:
        return Trip.manual(
            t, v, col.get("spacing", np.zeros(0)), col.get("v_leader", np.zeros(0)), a, meta
        )
    except TripLogError as exc:
        raise TripLogError(f"{path}: {exc}") from exc


def load_trip(path: str | os.PathLike[str]) -> Trip:
    """Read a trip file, dispatched by suffix: ``.mcap`` → :func:`read_trip`, ``.csv`` →
    :func:`read_csv_trip`. Any other suffix raises :class:`TripLogError`."""
    suffix = Path(path).suffix.lower()
    if suffix == ".mcap":
        return read_trip(path)
    if suffix == ".csv":
        return read_csv_trip(path)
    raise TripLogError(f"{path}: unknown trip file type {suffix!r} (expected .mcap or .csv)")
