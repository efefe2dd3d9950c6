"""Calibrate the drivers against real people: ``python -m tools.calibration [people ...]``.

``people SEED N [MISMATCH TAPS DRIFT [DRIVES_CSV [SCENARIO]]]``: Table I averages (PoI,
NIM) of N drivers of the ``people`` population of SEED with the three takeover scales given
(default: the frozen ``PEOPLE_SCALES``), 120-s drives of scenario B (or SCENARIO; the rows to
DRIVES_CSV, for ``pacc validate people``): what the scales were fitted with, on one seed, to
the paper's four PoI averages. ``kinds SEED``: the three held-out driver kinds, 3 drives
each per controller. ``trace SEED N``: why IRL draws presses (:func:`trace`). ``presses SEED
N``: brake and accelerator presses per controller (:func:`presses`). Without a
sub-command:

Measures the steady-state time gap (gap / follower speed, samples with |v_lead − v| < 0.5 m/s)
per 5 m/s speed band, median per follower: for each real human-driven pair of the shipped
OpenACC data, and for each built-in driver following the same real leader traces by hand
(sim_bus.manual, seed 0). Prints a Markdown table (used in docs/drivers.md). A maintainer's
tool, run from the repository root; not part of the installed package.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from cloud_sync.engine import map_unordered, open_executor
from dbc.vocab.dgpt import Dgpt, clamp_to_bounds
from pacc.study.drive import resolve_profile, run_drive
from pacc.study.pipeline import Drive, make_tables, plan, run_one
from pacc.study.report import write_csv
from pacc.study.spec import StudySpec, table1_method
from sim_bus.dataset import load_human_pairs
from sim_bus.drivers import BUILTIN_DRIVERS, DriverParams
from sim_bus.lead.profile import LeadProfile
from sim_bus.manual import manual_trip
from sim_bus.metrics import acc_on_mask
from sim_bus.population import PEOPLE_SCALES, TakeoverScales, draw_population, people_driver

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


CONTROLLERS = ("predefined", "predefined+oa", "irl", "irl+oa")
#: three driver kinds no calibration saw, each with a typical takeover life (an ACC-vs-manual
#: offset, drift, a between-trip shift): online adaptation must not make them worse
_LIFE: dict[str, Any] = {
    "acc_offset_s": 0.4,
    "trip_shift_sd_s": 0.15,
    "condition_drift_per_min": 0.03,
}
HELD_OUT_KINDS = (
    DriverParams(
        "nonmono", "a preference that dips and rises", headway_s=(1.4, 2.3, 1.5, 2.4), **_LIFE
    ),
    DriverParams(
        "slowpress",
        "long gap, slow to press, long presses",
        headway_s=(2.6, 2.8, 3.0, 3.1),
        patience_s=3.0,
        patience_far_s=7.0,
        press_min_s=0.6,
        press_max_s=4.0,
        predefined_setting="high",
        **_LIFE,
    ),
    DriverParams(
        "brief",
        "close follower pressing briefly and often",
        standstill_m=3.0,
        headway_s=(1.1, 1.15, 1.2, 1.25),
        patience_s=0.8,
        patience_far_s=2.0,
        refractory_s=0.5,
        press_min_s=0.3,
        press_max_s=0.6,
        spurious_press_per_min=3.0,
        predefined_setting="low",
        **_LIFE,
    ),
)


def manual_view(driver: DriverParams) -> DriverParams:
    """``driver`` without what only shows under ACC (offset, taps, press lengths): its manual
    trips, hence its IRL table, are the same for every mismatch and tap scale, so a table
    learned once serves them (the drift scale changes the manual trips too)."""
    return dataclasses.replace(
        driver,
        acc_offset_s=0.0,
        spurious_press_per_min=0.0,
        tap_s=0.3,
        press_max_s=driver.press_min_s + 1.0,
    )


def run_drivers(
    drivers: list[DriverParams],
    seed: int,
    controllers: tuple[str, ...] = CONTROLLERS,
    trials: int = 1,
    scenario: str = "B",
    irl_from: str = "learned",
    roads: str = "per-driver",
    worker: Callable[[Drive], dict[str, Any]] = run_one,
) -> list[dict[str, Any]]:
    """Every drive (120 s) of ``drivers`` under ``controllers`` in ``scenario``, two processes
    (the study pipeline's tables and drives; IRL learned in-process from :func:`manual_view`,
    cached in the default cache folder). ``irl_from`` ``manual``/``acc``: the IRL table is the
    driver's own manual or ACC preference instead (what a perfect learner would give). ``roads``:
    each driver its own draw of the scenario (``shared``: the seed's one, as before); ``worker``
    makes a drive's row (:func:`press_row`: its presses by pedal)."""
    spec = StudySpec(
        drivers=(), scenarios=(scenario,), methods=tuple(table1_method(c) for c in controllers),
        trials=trials, seed=seed, duration_s=120.0, learn_in="direct", logs=False, roads=roads,
    )  # fmt: skip
    by_id = {d.driver_id: d for d in drivers}
    with open_executor(None, 2) as executor:
        views = {i: manual_view(d) for i, d in by_id.items()}
        tables = make_tables(spec, views, Path(), executor, None)
        for (i, key), t in list(tables.items()):
            d = by_id[i]
            if irl_from != "learned" and isinstance(t, Dgpt) and t.source != "predefined":
                pref = d.preferred_gap_m if irl_from == "manual" else d.acc_preferred_gap_m
                tables[(i, key)] = t.with_gaps(clamp_to_bounds(t.speed_mps, pref(t.speed_mps)))
        drives = plan(spec, by_id, tables, Path())
        rows = dict(map_unordered(executor, worker, drives))
    return [rows[i] for i in sorted(rows)]


def averages(rows: list[dict[str, Any]]) -> str:
    """One line per controller: mean PoI % and NIM per minute over the rows."""
    out = []
    for c in dict.fromkeys(str(r["controller"]) for r in rows):
        mine = [r for r in rows if r["controller"] == c]
        poi = np.mean([float(r["poi_pct"]) for r in mine])
        nim = np.mean([float(r["nim_per_min"]) for r in mine])
        out.append(f"{c:<14} PoI {poi:5.1f} %  NIM {nim:5.2f} /min")
    return "\n".join(out)


def press_lengths(pressed: np.ndarray, on: np.ndarray, dt_s: float) -> list[float]:
    """The length (s) of every press of one pedal while the ACC is on: runs of ``pressed &
    on`` (bool arrays of one drive's samples, ``dt_s`` s apart)."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], (pressed & on).astype(np.int8), [0]))))
    return [float(n) * dt_s for n in edges[1::2] - edges[::2]]


def press_row(drive: Drive) -> dict[str, Any]:
    """A drive's controller, ACC-on minutes and press lengths by pedal (``brake``, ``accel``)."""
    road = resolve_profile(drive.config.scenario, drive.profile_seed)
    log = run_drive(drive.config, drive.driver, drive.table, road).log
    on = acc_on_mask(log.acc_state)
    dt = float(np.median(np.diff(log.t_s)))
    pedals = {"brake": log.brake_pressed, "accel": log.accel_pressed}
    lengths = {k: press_lengths(np.asarray(x, bool), on, dt) for k, x in pedals.items()}
    return {"controller": drive.method.name, "on_min": float(on.sum()) * dt / 60.0, **lengths}


def presses(rows: list[dict[str, Any]]) -> str:
    """Per controller and pedal: presses per minute of ACC-on time and their mean length (s)."""
    out = []
    for c in dict.fromkeys(str(r["controller"]) for r in rows):
        mine = [r for r in rows if r["controller"] == c]
        minutes = sum(float(r["on_min"]) for r in mine)
        cells = []
        for pedal in ("brake", "accel"):
            lens = [x for r in mine for x in r[pedal]]
            mean = float(np.mean(lens)) if lens else 0.0
            cells.append(f"{pedal} {len(lens) / minutes:5.2f} /min {mean:4.2f} s")
        out.append(f"{c:<14} " + "  ".join(cells))
    return "\n".join(out)


def trace(drivers: list[DriverParams], seed: int) -> str:
    """Why IRL draws presses: per controller the mean PoI, IRL with the learned table, with the
    driver's manual preference and with its ACC preference, and what IRL's PoI follows."""
    rows = run_drivers(drivers, seed, ("predefined", "irl"))
    rows += [dict(r, controller=f"irl={src}") for src in ("manual", "acc")
             for r in run_drivers(drivers, seed, ("irl",), irl_from=src)]  # fmt: skip
    poi = {(r["driver"], r["controller"]): float(r["poi_pct"]) for r in rows}
    irl = np.array([poi[(d.driver_id, "irl")] for d in drivers])
    pre = np.array([poi[(d.driver_id, "predefined")] for d in drivers])
    offset = np.array([abs(d.acc_offset_s) for d in drivers])
    far = np.array([abs(d.predefined_headway_s - float(np.mean(d.headway_s)) - d.acc_offset_s)
                    for d in drivers])  # fmt: skip
    return "\n".join([
        averages(rows),
        f"IRL below Predefined for {int((irl < pre).sum())} of {len(drivers)} drivers",
        f"Spearman: IRL PoI vs |ACC offset| {stats.spearmanr(irl, offset)[0]:.2f}; "
        f"Predefined PoI vs |setting - ACC headway| {stats.spearmanr(pre, far)[0]:.2f}",
        f"|ACC offset| s: mean {offset.mean():.2f}, max {offset.max():.2f}",
    ])  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    """Print the calibration table, a people run's averages, or the held-out kinds."""
    argv = sys.argv[1:] if argv is None else argv
    if argv and argv[0] == "people":
        seed, n = int(argv[1]), int(argv[2])
        scales = TakeoverScales(*(float(x) for x in argv[3:6])) if len(argv) > 5 else PEOPLE_SCALES
        base = draw_population(n, seed, population="headway")
        drivers = [people_driver(d, seed, i, scales) for i, d in enumerate(base)]
        rows = run_drivers(drivers, seed, scenario=argv[7] if len(argv) > 7 else "B")
        print(averages(rows))
        if len(argv) > 6:
            write_csv(Path(argv[6]), rows)
        return 0
    if argv and argv[0] == "presses":
        seed, n = int(argv[1]), int(argv[2])
        print(presses(run_drivers(list(draw_population(n, seed)), seed, worker=press_row)))
        return 0
    if argv and argv[0] == "trace":
        print(trace(list(draw_population(int(argv[2]), int(argv[1]))), int(argv[1])))
        return 0
    if argv and argv[0] == "kinds":
        seed = int(argv[1])
        for d in HELD_OUT_KINDS:
            print(d.driver_id, d.description)
            print(averages(run_drivers([d], seed, trials=3)))
        return 0
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
