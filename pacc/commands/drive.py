"""``pacc drive``: the ECU node and the simulator in one process, lockstep, one virtual bus.

    pacc drive --scenario B|A|cutin|cutout|leadloss|stopgo|C|FILE.csv --driver d3
               --controller predefined|predefined+oa|irl|irl+oa
               [--profile DGPT.json] [--seed N] [--faults SPEC] [--log run.mcap]
               [--can-log bus.mcap]
               [--adaptation-mode paper|timegap]

prints PoI, NIM, min gap, min time-to-collision, RMS jerk, takeovers, adaptations and
collisions. A drive is a pure function of (configuration, seed, shipped data): the ECU and
the simulator each get a python-can ``virtual`` bus on a private channel, and time is the
simulator's (every frame stamped with simulated time). Exit status: 0, 1 if the drive
ended in a collision, 2 on bad options or input files.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from dbc.errors import DbcError
from dbc.network import add_network_arguments
from ecu import EcuError
from ecu.adaptation import ADAPTATION_MODES
from pacc.vocab import FormatError
from pacc.vocab.dgpt import load_dgpt
from pacc.vocab.triplog import TripLogError, write_trip
from sim_bus.drivers import CONDITION_FACTORS, load_driver
from sim_bus.errors import SimError
from sim_bus.faults import parse_faults
from sim_bus.study.drive import (
    CONTROLLERS,
    DriveConfig,
    DriveResult,
    adaptation_params,
    drive_codec,
    log_to_trip,
    predefined_table,
    resolve_profile,
    run_drive,
    with_condition,
)
from sim_bus.study.irl_table import irl_table


def format_result(r: DriveResult) -> str:
    """The human-readable report printed by ``pacc drive``."""
    m = r.metrics
    c = r.config
    safety = r.log.safety()
    col = f"1 at t = {r.collision_t_s:.2f} s" if r.collision else "0"
    lines = [
        f"drive: scenario {c.scenario}, driver {c.driver_id}, controller {c.controller}"
        + (
            f" ({c.adaptation.mode} adaptation)"
            if c.adaptation is not None and c.controller.endswith("+oa")
            else ""
        )
        + f", seed {c.seed}, {r.sim_s:.1f} s simulated in {r.wall_s:.2f} s "
        f"({r.realtime_factor:.0f}x real time)",
        f"  PoI            {m.poi_pct:7.2f} %   (ACC-ON {m.acc_on_s:.1f} s)",
        f"  NIM            {m.nim_per_min:7.2f} /min ({m.press_onsets} presses)",
        f"  min gap        {m.min_gap_m:7.2f} m",
        f"  min TTC        {m.min_ttc_s:7.2f} s",
        f"  TTC < 2 s      {safety.below_own_s:7.2f} s under the ACC, "
        f"{safety.below_override_s:.2f} s while the driver's accelerator overrode it",
        f"  RMS jerk       {m.rms_jerk_mps3:7.3f} m/s^3",
        f"  gap error      {m.gap_error_mean_m:7.2f} m mean, {m.gap_error_rms_m:.2f} m RMS "
        "(vs. the driver's preference)",
        f"  takeovers      {r.takeovers:7d}",
        f"  adaptations    {r.adaptations:7d}",
        f"  collisions     {col}",
        f"  frames         {r.frames_sent} sent by the simulator, {r.frames_faulted} faulted; "
        f"ECU E2E errors {r.summary.e2e_errors or 'none'}",
    ]
    if r.road_events:
        played = ", ".join(
            f"{kind} at {t:.0f} s" + (f" ({gap:.1f} m)" if gap is not None else " (skipped)")
            for t, kind, gap in r.road_events
            if gap is not None or kind != "lead_loss"
        )
        losses = sum(1 for _, kind, _ in r.road_events if kind == "lead_loss")
        lines.append(f"  road events    {played}" + (f"; {losses} lead loss(es)" if losses else ""))
    return "\n".join(lines)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="pacc drive",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument(
        "--scenario",
        default="B",
        help="A, B, manual1..manual4, a road scenario (cutin, cutout, leadloss, stopgo, C: "
        "mixed traffic) or a CSV of t_s,v_lead_mps (default B)",
    )
    p.add_argument("--driver", default="d1", help="d1..d5 or a driver .toml/.json (default d1)")
    p.add_argument("--controller", default="predefined", choices=CONTROLLERS)
    p.add_argument("--profile", type=Path, help="DGPT JSON for the irl controllers")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--faults", default="", help="fault SPEC, e.g. 'radar:dropout=100-105'")
    p.add_argument("--log", type=Path, help="write the drive as an MCAP trip log")
    p.add_argument(
        "--can-log",
        type=Path,
        metavar="FILE",
        help="record the ECU's bus traffic (raw and decoded), its internals and the "
        "simulated world to this MCAP file",
    )
    p.add_argument("--duration", type=float, help="simulate only the first N seconds")
    p.add_argument(
        "--brake-mode",
        choices=("resume", "cancel"),
        default="resume",
        help="brake press: override and resume (paper) or cancel (production)",
    )
    p.add_argument(
        "--condition-factor",
        type=float,
        default=1.0,
        help="multiply the driver's preference, e.g. 1.2 for rain (default 1)",
    )
    p.add_argument(
        "--condition",
        choices=sorted(CONDITION_FACTORS),
        default="dry",
        help="driving condition: wet or night lengthen the driver's preference "
        "(docs/drivers.md; multiplies --condition-factor)",
    )
    p.add_argument(
        "--cache", type=Path, help="cache folder of learned IRL tables (default ~/.cache/pacc)"
    )
    p.add_argument(
        "--adaptation-mode",
        choices=ADAPTATION_MODES,
        help="online adaptation of the +oa controllers: the paper's Algorithm 1 "
        "or the time-gap update (default: the ECU's, see docs/ecu.md)",
    )
    add_network_arguments(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc drive``; returns the exit status."""
    args = _parser().parse_args(argv)
    try:
        base = load_driver(args.driver)
        driver = with_condition(base, args.condition_factor * CONDITION_FACTORS[args.condition])
        parse_faults(args.faults)
        if args.duration is not None and not (args.duration > 0):
            raise SimError("--duration must be > 0")
        cfg = DriveConfig(
            scenario=args.scenario,
            driver_id=driver.driver_id,
            controller=args.controller,
            seed=args.seed,
            duration_s=args.duration,
            faults=args.faults,
            brake_mode=args.brake_mode,
            adaptation=adaptation_params(args.adaptation_mode),
            dbc=args.dbc,
            binding=args.binding,
        )
        drive_codec(cfg)  # a DBC without its binding: refused before any learning
        profile = resolve_profile(args.scenario, args.seed)
        if args.controller.startswith("irl"):
            if args.profile is not None:
                table = load_dgpt(args.profile)
            else:
                print(
                    "learning the IRL table from the driver's manual trips (cached) ...",
                    file=sys.stderr,
                )
                table = irl_table(base, args.seed, args.cache)  # learned in normal conditions
        else:
            table = predefined_table(driver)
        result = run_drive(cfg, driver, table, profile, can_log=args.can_log)
    except (SimError, EcuError, FormatError, DbcError, OSError) as exc:
        print(f"pacc drive: error: {exc}", file=sys.stderr)
        return 2
    print(format_result(result))
    if args.log is not None:
        try:
            write_trip(args.log, log_to_trip(result, driver))
        except (TripLogError, OSError) as exc:
            print(f"pacc drive: error: cannot write {args.log}: {exc}", file=sys.stderr)
            return 2
        print(f"  log            {args.log}")
    if args.can_log is not None:
        failed = result.extra.get("can_log_error")
        if failed:
            print(f"pacc drive: error: bus recording failed: {failed}", file=sys.stderr)
            return 2
        print(f"  bus recording  {args.can_log}")
    return 1 if result.collision else 0


if __name__ == "__main__":
    raise SystemExit(main())
