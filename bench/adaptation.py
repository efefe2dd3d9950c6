"""Instrumentation of the online DGPT adaptation: what each takeover teaches the table.

Run: ``.venv/bin/python bench/adaptation.py [--drivers d1,d3] [--scenarios A,B]
[--controllers predefined+oa,irl+oa] [--modes paper,timegap] [--trials 1] [--duration S]
[--takeovers]``.

For every drive (driver x scenario x controller x adaptation mode x trial, study seed 0 like
``pacc study``) it prints:

- with ``--takeovers``, one line per takeover: start, pedal, duration, speed, gap at press and
  at release, the driver's hidden ACC preference there, the adaptation's g_desire, decision
  and reason, and whether the press ended at the driver's ``press_max_s`` (a cut burst);
- the table's gap error against the driver's hidden ACC preference
  (``DriverParams.acc_preferred_gap_m``), RMS over the speeds the drive visited (weighted by
  time spent there), at the start, after each quarter of the trip and at the end;
- the g_desire error (g_desire minus the preference at the release speed): mean and RMS, by
  pedal, showing whether the steady-state prediction is biased;
- PoI and NIM.

The named peer is the paper's Algorithm 1 (mode ``paper``): the summary at the end prints the
averages per mode and the ratio of each mode's figures to the paper mode's.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import Counter, defaultdict
from typing import Any

import numpy as np

from dbc.vocab.dgpt import Dgpt
from ecu.adaptation import ADAPTATION_MODES, AdaptationParams
from pacc.study.drive import DriveConfig, DriveResult, predefined_table, run_drive
from pacc.study.irl_table import irl_table
from sim_bus.drivers import DriverParams, load_driver
from sim_bus.lead.scenarios import canonical_profiles

ACC_ENGAGED = (2, 3)  # ACTIVE, OVERRIDE


def visited_weights(table: Dgpt, v_mps: np.ndarray) -> np.ndarray:
    """Time share of the drive spent nearest each speed bin, shape ``(n_bins,)``, sums to 1."""
    idx = np.clip(
        np.rint((v_mps - table.speed_mps[0]) / table.step_mps), 0, table.speed_mps.size - 1
    ).astype(int)
    w = np.bincount(idx, minlength=table.speed_mps.size).astype(float)
    return np.asarray(w / max(w.sum(), 1.0))


def table_error_m(table: Dgpt, driver: DriverParams, weights: np.ndarray) -> float:
    """RMS of DGPT - ACC preference over the speed bins, weighted by ``weights``, m."""
    err = table.gap_m - driver.acc_preferred_gap_m(table.speed_mps)
    return float(np.sqrt(np.sum(weights * err**2)))


def takeovers(result: DriveResult, driver: DriverParams) -> list[dict[str, Any]]:
    """Pedal presses under ACC from the world log, matched to the ECU's decisions."""
    log = result.log
    pressed = (log.accel_pressed | log.brake_pressed).astype(bool)
    engaged = np.isin(log.acc_state, ACC_ENGAGED)
    rows: list[dict[str, Any]] = []
    i, n = 0, len(pressed)
    while i < n:
        if pressed[i] and engaged[i]:
            j = i
            while j + 1 < n and pressed[j + 1]:
                j += 1
            end = min(j + 1, n - 1)  # first released sample
            v = float(log.v_mps[end])
            rows.append(
                {
                    "start_s": float(log.t_s[i]),
                    "release_s": float(log.t_s[end]),
                    "pedal": "brake" if log.brake_pressed[i] else "accel",
                    "duration_s": float(log.t_s[end] - log.t_s[i]),
                    "v_mps": v,
                    "dv_mps": float(log.v_lead_mps[end] - v),
                    "gap_press_m": float(log.gap_m[i]),
                    "gap_release_m": float(log.gap_m[end]),
                    "pref_m": float(driver.acc_preferred_gap_m(v)),
                    "cut": float(log.t_s[end] - log.t_s[i]) >= driver.press_max_s - 0.06,
                    "g_desire_m": math.nan,
                    "reason": "-",
                }
            )
            i = j + 1
        else:
            i += 1
    for ev in result.adaptation_events:  # nearest takeover release (ECU sees it ~1 cycle late)
        best = min(rows, key=lambda r: abs(r["release_s"] - ev.t_s), default=None)
        if best is not None and abs(best["release_s"] - ev.t_s) < 0.3:
            best["g_desire_m"] = ev.decision.g_desire_m
            best["reason"] = ev.decision.reason.value
    return rows


def error_trace(
    result: DriveResult, initial: Dgpt, driver: DriverParams
) -> tuple[list[float], float]:
    """Table error (m) at the start, after each quarter and at the end; the visited weights'
    error of the final table is the last entry. Also the final table's error at all speeds
    5..30 m/s (unweighted)."""
    w = visited_weights(initial, result.log.v_mps)
    t_end = float(result.log.t_s[-1])
    tables = [(0.0, initial)] + [(ev.t_s, ev.table) for ev in result.adaptation_events]
    trace = []
    for q in (0.0, 0.25, 0.5, 0.75, 1.0):
        current = [tb for t, tb in tables if t <= q * t_end + 1e-9][-1]
        trace.append(table_error_m(current, driver, w))
    band = (initial.speed_mps >= 5.0) & (initial.speed_mps <= 30.0)
    flat = band / band.sum()
    return trace, table_error_m(result.final_table, driver, flat)


def _takeover_rows(
    rows: list[dict[str, Any]],
    mode: str,
    gd_err: dict[tuple[str, str, bool], list[float]],
    *,
    verbose: bool,
) -> None:
    """Collect g_desire - preference (m) per (mode, pedal, cut); print each row if verbose."""
    for row in rows:
        gd = row["g_desire_m"] - row["pref_m"]
        if math.isfinite(gd):
            gd_err[(mode, row["pedal"], row["cut"])].append(gd)
        if verbose:
            print(
                f"    {row['start_s']:6.1f} s {row['pedal']:5s} "
                f"{row['duration_s']:4.1f} s{'*' if row['cut'] else ' '} "
                f"v {row['v_mps']:5.1f} dv {row['dv_mps']:+5.1f} "
                f"gap {row['gap_press_m']:5.1f} -> "
                f"{row['gap_release_m']:5.1f} pref {row['pref_m']:5.1f} "
                f"g_desire {row['g_desire_m']:5.1f} {row['reason']}"
            )


def main(argv: list[str] | None = None) -> int:
    """Run the drives and print the instrumentation; 0 on success."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--drivers", default="d1,d2,d3,d4,d5")
    p.add_argument("--scenarios", default="A,B")
    p.add_argument("--controllers", default="predefined+oa,irl+oa")
    p.add_argument("--modes", default=",".join(ADAPTATION_MODES))
    p.add_argument("--trials", type=int, default=1)
    p.add_argument("--seed", type=int, default=0, help="study seed (default 0)")
    p.add_argument("--duration", type=float)
    p.add_argument("--takeovers", action="store_true", help="one line per takeover")
    args = p.parse_args(argv)
    profiles = canonical_profiles(args.seed)
    split = [x for x in args.modes.split(",") if x]
    summary: dict[str, list[tuple[float, float, float, float, float]]] = defaultdict(list)
    gd_err: dict[tuple[str, str, bool], list[float]] = defaultdict(list)
    reasons: dict[str, Counter[str]] = defaultdict(Counter)
    start = time.perf_counter()
    for name in args.drivers.split(","):
        driver = load_driver(name)
        for controller in args.controllers.split(","):
            initial = (
                irl_table(driver, args.seed, None)
                if controller.startswith("irl")
                else predefined_table(driver)
            )
            for scenario in args.scenarios.split(","):
                for mode in split:
                    params = AdaptationParams(mode=mode)
                    for trial in range(args.trials):
                        cfg = DriveConfig(
                            scenario=scenario,
                            driver_id=name,
                            controller=controller,
                            seed=args.seed + trial,
                            duration_s=args.duration,
                            adaptation=params,
                        )
                        r = run_drive(cfg, driver, initial, profiles[scenario])
                        rows = takeovers(r, driver)
                        trace, flat = error_trace(r, initial, driver)
                        m = r.metrics
                        print(
                            f"{name} {scenario} {controller:13s} {mode:8s} t{trial}: "
                            f"PoI {m.poi_pct:5.1f} % NIM {m.nim_per_min:4.1f} "
                            f"takeovers {len(rows):2d} applied {r.adaptations:2d} | "
                            "table error (visited, m) "
                            + " ".join(f"{e:5.1f}" for e in trace)
                            + f" | 5-30 m/s {flat:5.1f}"
                        )
                        reasons[mode].update(e.decision.reason.value for e in r.adaptation_events)
                        reasons[mode]["cut at press_max_s"] += sum(x["cut"] for x in rows)
                        reasons[mode]["takeovers"] += len(rows)
                        _takeover_rows(rows, mode, gd_err, verbose=args.takeovers)
                        summary[mode].append((m.poi_pct, m.nim_per_min, trace[0], trace[-1], flat))
    print(
        f"\n{sum(len(v) for v in summary.values())} drives in "
        f"{time.perf_counter() - start:.1f} s  (* = press cut at press_max_s)"
    )
    print("\ng_desire - preference at the release speed (m): mean / RMS / count")
    for (mode, pedal, cut), vals in sorted(gd_err.items()):
        a = np.asarray(vals)
        print(
            f"  {mode:8s} {pedal:5s} {'cut' if cut else 'released':8s} "
            f"{a.mean():+6.2f} / {np.sqrt(np.mean(a**2)):5.2f} / {a.size}"
        )
    print("\ndecisions per mode (and takeovers cut at the driver's press_max_s):")
    for mode, counts in reasons.items():
        print(f"  {mode:8s} " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    print(
        "\naverages per mode: PoI %, NIM /min, table error start -> end (visited), end (5-30 m/s)"
    )
    base = summary.get("paper")
    for mode, figures in summary.items():
        a = np.asarray(figures).mean(axis=0)
        ratio = ""
        if base and mode != "paper":
            b = np.asarray(base).mean(axis=0)
            ratio = (
                f"  | vs paper: PoI x{a[0] / b[0]:.2f}, NIM x{a[1] / b[1]:.2f}, "
                f"end error x{a[3] / b[3]:.2f}"
            )
        print(
            f"  {mode:8s} PoI {a[0]:5.1f}  NIM {a[1]:4.1f}  error {a[2]:5.1f} -> {a[3]:5.1f}"
            f"  ({a[4]:5.1f}){ratio}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
