"""Safety on any seed: drawn drivers x road scenarios x controllers, seeds drawn at run time.

Run: ``.venv/bin/python bench/safety.py [--seeds 3] [--drivers 5]
[--kinds cutin,cutout,leadloss,stopgo,C,B] [--controllers predefined,predefined+oa]
[--duration S] [--irl] [--population-seeds 123,456] [--workers N] [--csv ROWS.csv]``.

Population seeds (which drivers) and road seeds (which events, which noise) are drawn with
:mod:`secrets` when the run starts, never fixed in code, and printed so that a failure can be
traced (re-run it with ``--population-seeds`` and ``--road-seeds``). For every drive it
records collisions, min time-to-collision and min gap, and the time below 2 s TTC, split into
the time under the ACC (or the driver's brake) and the time while the driver's own
accelerator press overrode the ACC (the driver closed the gap, not the ECU). It prints one
row per controller and per scenario kind, and every drive that collided or fell below 2 s
TTC outside an accelerator press. The time after a cut-in that began below 2 s TTC (the
cutter set it; no controller raises it at once) is its own column: there the ECU's job is to
avoid the collision within its envelope. ``--irl`` adds the IRL controllers (each drawn driver's
table is learned from its manual trips of the population seed first, as ``pacc study
--population`` does: about 10 s per driver, cached). ``--workers N`` runs one driver's
drives per task in N processes (default: the machine's cores); ``--csv`` writes every
drive's row as it finishes, so a long grid that is stopped keeps what it ran. ``TOR`` counts
the ECU's takeover requests at its limit (ACC_Command TakeoverRequest while engaged: the
braking needed exceeds what the ACC may command, :func:`ecu.cycle.stops.beyond_authority`).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import secrets
import sys
import time
from collections import defaultdict
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

from pacc.study.drive import DriveConfig, predefined_table, resolve_profile, run_drive
from pacc.study.irl_table import irl_table
from sim_bus.lead.events import ROAD_SCENARIOS
from sim_bus.population import draw_population

TTC_LIMIT_S = 2.0


def _drive(
    driver: Any,
    kind: str,
    controller: str,
    seed: int,
    duration: float | None,
    pop_seed: int,
    cache: Path | None,
) -> dict[str, Any]:
    irl = controller.startswith("irl")
    table = irl_table(driver, pop_seed, cache) if irl else predefined_table(driver)
    profile = resolve_profile(kind, seed)
    cfg = DriveConfig(
        scenario=kind,
        driver_id=driver.driver_id,
        controller=controller,  # type: ignore[arg-type]
        seed=seed,
        duration_s=duration,
    )
    r = run_drive(cfg, driver, table, profile)
    s = r.safety(TTC_LIMIT_S)
    return {
        "driver": driver.driver_id,
        "kind": kind,
        "controller": controller,
        "seed": seed,
        "collision": r.collision,
        "min_ttc": s.min_ttc_s,
        "min_ttc_own": s.min_ttc_own_s,
        "min_gap": s.min_gap_m,
        "below_own": s.below_own_s,
        "below_override": s.below_override_s,
        "below_cut_in": s.below_cut_in_s,
        "poi": r.metrics.poi_pct,
        "tor": r.limit_requests,
        "events": len([e for e in r.road_events if e[2] is not None]),
    }


def _driver_rows(
    pop: int,
    index: int,
    n: int,
    road: int,
    kinds: list[str],
    controllers: list[str],
    duration: float | None,
    cache: Path | None,
) -> list[dict[str, Any]]:
    """Every drive of one drawn driver (a worker's task): its rows."""
    driver = draw_population(n, pop)[index]
    return [
        _drive(driver, kind, controller, road, duration, pop, cache)
        for kind in kinds
        for controller in controllers
    ]


def _run_grid(
    pops: list[int], roads: list[int], n: int, args: argparse.Namespace, workers: int
) -> Iterator[dict[str, Any]]:
    """The rows of the grid as the drivers finish (in ``workers`` processes when > 1)."""
    named = args.controllers.split(",") + (["irl", "irl+oa"] if args.irl else [])
    controllers = list(dict.fromkeys(named))  # each once, as first named
    kinds = args.kinds.split(",")
    tasks = [
        (pop, i, n, road, kinds, controllers, args.duration, args.cache)
        for pop, road in zip(pops, roads, strict=True)
        for i in range(n)
    ]
    if workers <= 1:
        for task in tasks:
            yield from _driver_rows(*task)
        return
    with ProcessPoolExecutor(workers) as pool:
        for fut in as_completed([pool.submit(_driver_rows, *t) for t in tasks]):
            yield from fut.result()


def main(argv: list[str] | None = None) -> int:
    """Run the grid and print the table; exit status 1 if any drive collided."""
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--seeds", type=int, default=3, help="population seeds to draw")
    p.add_argument("--drivers", type=int, default=5, help="drivers per population seed")
    p.add_argument("--kinds", default=",".join((*ROAD_SCENARIOS, "B")))
    p.add_argument("--controllers", default="predefined,predefined+oa")
    p.add_argument("--irl", action="store_true", help="also irl and irl+oa")
    p.add_argument("--duration", type=float, help="shorten every drive to S seconds")
    p.add_argument("--population-seeds", help="comma-separated (default: drawn now)")
    p.add_argument("--road-seeds", help="comma-separated, one per population seed")
    p.add_argument("--cache", type=Path, help="cache folder of learned IRL tables")
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="processes")
    p.add_argument("--csv", type=Path, help="write every drive's row here as it finishes")
    args = p.parse_args(argv)
    pops = (
        [int(x) for x in args.population_seeds.split(",")]
        if args.population_seeds
        else [secrets.randbelow(10**6) for _ in range(args.seeds)]
    )
    roads = (
        [int(x) for x in args.road_seeds.split(",")]
        if args.road_seeds
        else [secrets.randbelow(10**6) for _ in pops]
    )
    print(f"population seeds {pops}, road seeds {roads} (drawn at run time unless given)")
    rows = []
    start = time.perf_counter()
    out = args.csv.open("w", newline="", encoding="utf-8") if args.csv else None
    writer: csv.DictWriter[str] | None = None
    try:
        for row in _run_grid(pops, roads, args.drivers, args, max(args.workers, 1)):
            rows.append(row)
            if out is not None:
                if writer is None:
                    writer = csv.DictWriter(out, fieldnames=list(row))
                    writer.writeheader()
                writer.writerow(row)
                out.flush()
            if row["collision"] or row["below_own"] > 0.0:
                print(f"  ! {row}", flush=True)
    finally:
        if out is not None:
            out.close()
    wall = time.perf_counter() - start
    print(f"{len(rows)} drives in {wall:.0f} s\n")
    _report(rows)
    return 1 if any(r["collision"] for r in rows) or math.isnan(wall) else 0


def _mean_poi(rows: list[dict[str, Any]]) -> float:
    """Mean PoI (%) of the drives that had ACC-ON time (a drive never engaged has none)."""
    pois = [r["poi"] for r in rows if math.isfinite(r["poi"])]
    return sum(pois) / len(pois) if pois else math.nan


def _report(rows: list[dict[str, Any]]) -> None:
    """Print one row per controller and scenario kind, then the drives to look at."""
    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for r in rows:
        groups[(r["controller"], r["kind"])].append(r)
    head = (
        f"{'controller':14s} {'kind':9s} {'drives':>6s} {'coll':>4s} {'minTTC':>7s} "
        f"{'own':>6s} {'min gap':>7s} {'<2s ACC':>8s} {'<2s acc-press':>13s} "
        f"{'<2s cut-in':>10s} {'TOR':>4s} {'PoI %':>6s}"
    )
    print(head)
    for (controller, kind), rs in sorted(groups.items()):
        print(
            f"{controller:14s} {kind:9s} {len(rs):6d} {sum(r['collision'] for r in rs):4d} "
            f"{min(r['min_ttc'] for r in rs):7.2f} {min(r['min_ttc_own'] for r in rs):6.2f} "
            f"{min(r['min_gap'] for r in rs):7.2f} {sum(r['below_own'] for r in rs):8.2f} "
            f"{sum(r['below_override'] for r in rs):13.2f} "
            f"{sum(r['below_cut_in'] for r in rs):10.2f} "
            f"{sum(r['tor'] for r in rs):4d} "
            f"{_mean_poi(rs):6.1f}"
        )
    _drives(
        [r for r in rows if r["collision"] or r["below_own"] > 0.0],
        f"\n{{}} drives collided or fell below {TTC_LIMIT_S} s TTC outside a press:",
        "collision {collision}, min TTC {min_ttc_own:.2f} s, {below_own:.2f} s below, "
        "min gap {min_gap:.2f} m, takeover requests {tor}",
    )
    _drives(
        [r for r in rows if r["below_override"] > 0.0],
        f"{{}} drives below {TTC_LIMIT_S} s only while the driver's accelerator pressed",
        "{below_override:.2f} s, min TTC {min_ttc:.2f} s",
    )
    _drives(
        [r for r in rows if r["below_cut_in"] > 0.0],
        f"{{}} drives below {TTC_LIMIT_S} s after a cut-in that began below it",
        "{below_cut_in:.2f} s, min TTC {min_ttc:.2f} s, min gap {min_gap:.2f} m, "
        "collision {collision}",
    )


def _drives(rows: list[dict[str, Any]], title: str, detail: str) -> None:
    """``title`` with the count, then each drive with its seeds (to trace it) and ``detail``
    (a format of the row's fields)."""
    print(title.format(len(rows)))
    for r in rows:
        print(
            f"  {r['driver']} {r['kind']} {r['controller']} road seed {r['seed']}: "
            + detail.format(**r)
        )


if __name__ == "__main__":
    sys.exit(main())
