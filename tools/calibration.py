"""Calibrate the built-in drivers against the real human pairs: ``python -m tools.calibration``.

Measures the steady-state time gap (gap / follower speed, samples with |v_lead − v| < 0.5 m/s)
per 5 m/s speed band, median per follower: for each real human-driven pair of the shipped
OpenACC data, and for each built-in driver following the same real leader traces by hand
(sim_bus.manual, seed 0). Prints a Markdown table (used in docs/drivers.md). A maintainer's
tool, run from the repository root; not part of the installed package.
"""

from __future__ import annotations

import argparse

import numpy as np

from sim_bus.dataset import load_human_pairs
from sim_bus.drivers import BUILTIN_DRIVERS
from sim_bus.lead.profile import LeadProfile
from sim_bus.manual import manual_trip

BANDS_MPS: tuple[tuple[float, float], ...] = (
    (10.0, 15.0),
    (15.0, 20.0),
    (20.0, 25.0),
    (25.0, 30.0),
)
MIN_SAMPLES = 100  # 10 s of steady following in a band


def headway_by_band(
    v_mps: np.ndarray, gap_m: np.ndarray, v_lead_mps: np.ndarray
) -> list[float | None]:
    """Median steady-state time gap (s) per band of BANDS_MPS; None with < 10 s of data."""
    steady = np.abs(v_lead_mps - v_mps) < 0.5
    out: list[float | None] = []
    for lo, hi in BANDS_MPS:
        m = steady & (v_mps >= lo) & (v_mps < hi)
        out.append(float(np.median(gap_m[m] / v_mps[m])) if m.sum() >= MIN_SAMPLES else None)
    return out


def calibration_rows(
    seed: int = 0,
) -> tuple[list[tuple[str, list[float | None]]], list[tuple[str, list[float | None]]]]:
    """(real pair rows, built-in driver rows): name and the per-band median time gaps."""
    pairs = load_human_pairs()
    real = [
        (
            f"{p.pair_id} ({p.follower_make})",
            headway_by_band(p.v_follower_mps, p.gap_m, p.v_leader_mps),
        )
        for p in pairs
    ]
    ours = []
    for d in BUILTIN_DRIVERS.values():
        v_all, g_all, vl_all = [], [], []
        for p in pairs:
            n = len(p.v_leader_mps)
            trip = manual_trip(d, LeadProfile(p.pair_id, np.arange(n) * 0.1, p.v_leader_mps), seed)
            v_all.append(trip.v_mps)
            g_all.append(trip.gap_m)
            vl_all.append(trip.v_lead_mps)
        ours.append(
            (
                f"{d.driver_id}: {d.description.split(':')[0]}",
                headway_by_band(
                    np.concatenate(v_all), np.concatenate(g_all), np.concatenate(vl_all)
                ),
            )
        )
    return real, ours


def _fmt(x: float | None) -> str:
    return "–" if x is None else f"{x:.2f}"


def markdown(seed: int = 0) -> str:
    """The calibration table as Markdown."""
    real, ours = calibration_rows(seed)
    head = "| follower | " + " | ".join(f"{lo:.0f}–{hi:.0f} m/s" for lo, hi in BANDS_MPS) + " |"
    sep = "|---" * (len(BANDS_MPS) + 1) + "|"
    lines = [head, sep]
    lines += [f"| real {name} | " + " | ".join(_fmt(x) for x in vals) + " |" for name, vals in real]
    cols = list(zip(*[vals for _, vals in real], strict=True))
    lo_hi = [[x for x in c if x is not None] for c in cols]
    lines.append(
        "| **real, range** | "
        + " | ".join(f"**{min(c):.2f}–{max(c):.2f}**" if c else "–" for c in lo_hi)
        + " |"
    )
    lines += [f"| sim {name} | " + " | ".join(_fmt(x) for x in vals) + " |" for name, vals in ours]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Print the calibration table."""
    p = argparse.ArgumentParser(prog="python -m tools.calibration", description=__doc__)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    if args.seed < 0:
        print(f"python -m tools.calibration: error: --seed must be >= 0, got {args.seed}")
        return 2
    print(markdown(args.seed))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
