"""A lead speed profile as a CSV file: ``t_s,v_lead_mps`` rows (s, m/s), read back at 10 Hz;
an unusable file is a :class:`~sim_bus.errors.ScenarioError` naming it."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from sim_bus.errors import ScenarioError
from sim_bus.lead.profile import DT_S, LeadProfile


def save_profile_csv(profile: LeadProfile, path: Path) -> None:
    """Write ``t_s,v_lead_mps`` rows (header first) to ``path``."""
    with Path(path).open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["t_s", "v_lead_mps"])
        for t, v in zip(profile.t_s.tolist(), profile.v_lead_mps.tolist(), strict=True):
            writer.writerow([f"{t:.3f}", f"{v:.5f}"])


#: the fastest lead a profile may hold, m/s (about 360 km/h)
MAX_LEAD_SPEED_MPS = 100.0
#: the longest profile, s (a day at 10 Hz is 864 000 samples)
MAX_PROFILE_S = 86_400.0


def load_profile_csv(path: Path, name: str | None = None) -> LeadProfile:
    """Read a ``t_s,v_lead_mps`` CSV (increasing times, 1 s to :data:`MAX_PROFILE_S`; speeds
    0 to :data:`MAX_LEAD_SPEED_MPS`) resampled to 10 Hz."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            rows = list(csv.DictReader(handle))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:  # unreadable, not text, not CSV
        raise ScenarioError(f"{path}: {exc}") from exc
    if not rows or not {"t_s", "v_lead_mps"} <= set(rows[0]):
        raise ScenarioError(f"{path}: need a header with columns t_s and v_lead_mps")
    try:
        t = np.array([float(r["t_s"]) for r in rows])
        v = np.array([float(r["v_lead_mps"]) for r in rows])
    except (TypeError, ValueError) as exc:
        raise ScenarioError(f"{path}: non-numeric value ({exc})") from exc
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(v))):
        raise ScenarioError(f"{path}: non-finite values")
    if len(t) < 2 or np.any(np.diff(t) <= 0):
        raise ScenarioError(f"{path}: t_s must be strictly increasing")
    if np.any(v < 0):
        raise ScenarioError(f"{path}: negative speed")
    if np.any(v > MAX_LEAD_SPEED_MPS):
        raise ScenarioError(
            f"{path}: lead speed {v.max():g} m/s above {MAX_LEAD_SPEED_MPS:g} m/s (not a car)"
        )
    if t[-1] - t[0] < 1.0:
        raise ScenarioError(f"{path}: shorter than 1 s")
    if t[-1] - t[0] > MAX_PROFILE_S:
        raise ScenarioError(
            f"{path}: spans {t[-1] - t[0]:g} s, more than {MAX_PROFILE_S:g} s (a day)"
        )
    n = int(np.floor((t[-1] - t[0]) / DT_S + 1e-9)) + 1
    grid = np.arange(n) * DT_S
    return LeadProfile(name or path.stem, grid, np.interp(grid + t[0], t, v))
