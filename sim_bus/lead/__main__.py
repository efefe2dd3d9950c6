"""``python -m sim_bus.lead list|export NAME PATH [--seed N]``: the lead profiles a drive can
take (the canonical set and the road scenarios), listed or exported as CSV."""

from __future__ import annotations

import argparse
from pathlib import Path

from sim_bus.errors import ScenarioError
from sim_bus.lead.events import ROAD_SCENARIOS, road_profile
from sim_bus.lead.profile_csv import save_profile_csv
from sim_bus.lead.scenarios import canonical_profiles


def main(argv: list[str] | None = None) -> int:
    """List or export the named lead profiles; the exit status."""
    p = argparse.ArgumentParser(
        prog="python -m sim_bus.lead",
        description="list or export the lead profiles (canonical and road scenarios)",
    )
    p.add_argument("command", choices=("list", "export"))
    p.add_argument("name", nargs="?", help="profile to export (A, B, manual1..4, cutin, ...)")
    p.add_argument("path", nargs="?", type=Path, help="CSV file to write")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    try:
        profiles = dict(canonical_profiles(args.seed))  # then the road scenarios
        profiles.update({name: road_profile(name, args.seed) for name in ROAD_SCENARIOS})
    except ScenarioError as exc:
        print(f"error: {exc}")
        return 2
    if args.command == "list":
        for name, prof in profiles.items():
            v = prof.v_lead_mps
            print(
                f"{name:8s} {prof.duration_s:6.1f} s  v {v.min():5.1f}..{v.max():5.1f} m/s  "
                f"mean {v.mean():5.1f} m/s  {len(prof.segments)} segments  "
                f"{len(prof.events)} events"
            )
        return 0
    if args.name not in profiles or args.path is None:
        print(f"error: export needs NAME (one of {sorted(profiles)}) and PATH")
        return 2
    try:
        save_profile_csv(profiles[args.name], args.path)
    except OSError as exc:
        print(f"error: cannot write {args.path}: {exc}")
        return 2
    print(f"wrote {args.path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
