"""``pacc cloud learn``: learn a driver's DGPT by IRL from demonstration files.

FILES are ``.mcap`` trip logs or ``.csv`` car-following pairs. With ``--init`` (an earlier
IRL table) training continues from its reward weights, speeds without new evidence keep its
gaps, and the output is its next version; when some FILES are ACC trips (trip-log mode
``acc``), this is fine-tuning from their takeovers (``cloud_sync.irl.trainer.fine_tune``), the
manual FILES counting as earlier demonstrations. Bad input (files, names, options) exits 2.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path
from typing import Any

from cloud_sync.errors import CloudSyncError
from dbc.vocab import FormatError
from ecu import EcuError
from pacc.commands._args import fail, integer, number, same_file


def _do_learn(args: argparse.Namespace) -> int:
    import numpy as np  # noqa: PLC0415

    from cloud_sync.api import is_plain_name  # noqa: PLC0415
    from cloud_sync.irl.config import IrlConfig  # noqa: PLC0415
    from cloud_sync.irl.demos import is_acc_trip  # noqa: PLC0415
    from cloud_sync.irl.sources.tripfiles import load_trip  # noqa: PLC0415
    from cloud_sync.irl.trainer import METHOD, fine_tune, learn_dgpt  # noqa: PLC0415
    from dbc.vocab.dgpt_file import load_dgpt, save_dgpt  # noqa: PLC0415

    for option, name in (("--driver", args.driver), ("--condition", args.condition)):
        if not is_plain_name(name):
            return fail(
                "pacc cloud learn", f"{option} {name!r}: not a plain name (letters, digits, _.-)"
            )
    if args.learner != "irl":
        return _other_learner(args)
    try:
        _check_outputs(args, args.plot)  # now, not after training
        config = IrlConfig(takeover_weight=args.takeover_weight)
        trips = [load_trip(p) for p in args.demos]
        init = load_dgpt(args.init) if args.init else None
        acc = [t for t in trips if is_acc_trip(t)]
        if init is None and len(acc) == len(trips):
            raise CloudSyncError(
                "every --demos trip is an ACC drive (pacc drive/sim --log, takeovers): IRL "
                "learns a first table from manual driving; make demonstrations with "
                "pacc drive --manual --log FILE (or give --init TABLE to fine-tune)"
            )
        if init is not None and acc and init.meta.get("method") == METHOD:
            # ACC trips given with an IRL table: fine-tune from their takeovers
            manual = [t for t in trips if not is_acc_trip(t)]
            result = fine_tune(
                acc, init, demos=manual, seed=args.seed, progress=not args.quiet, config=config
            )
        else:
            result = learn_dgpt(
                trips,
                driver_id=args.driver,
                condition=args.condition,
                init=init,
                seed=args.seed,
                progress=not args.quiet,
                config=config,
            )
        save_dgpt(result.table, args.output)
        if args.plot:
            from cloud_sync.irl.plot import plot_result  # noqa: PLC0415  (matplotlib: --plot only)

            plot_result(result, args.plot)
    except (CloudSyncError, EcuError, FormatError) as exc:
        return fail("pacc cloud learn", exc)
    t = result.table
    cov = result.covered
    ranges = ", ".join(f"{a:g}-{b:g}" for a, b in t.meta["covered_mps"])
    print(f"driver {t.driver_id} ({t.condition}): DGPT v{t.version} -> {args.output}")
    print(
        f"demonstrations: {len(trips)} trip(s), {t.meta['usable_demo_s']:.0f} s usable, "
        f"{t.meta['n_segments']} segments; covered speeds {ranges} m/s"
    )
    print(
        f"IRL: {result.n_iter} iterations in {result.train_s:.1f} s "
        f"({'converged' if result.converged else 'stopped: ' + result.message})"
    )
    if result.baseline is not None:
        d = t.gap_m[cov] - result.baseline.gap_m[cov]
        print(
            f"IRL vs empirical baseline over covered speeds: RMSE {np.sqrt(np.mean(d * d)):.2f} m"
        )
    for v in (10.0, 20.0, 30.0):
        print(f"  DGPT({v:g} m/s) = {t.lookup(v):.1f} m ({(t.lookup(v) - 4.0) / v:.2f} s + 4 m)")
    if args.plot:
        print(f"plot -> {args.plot}")
    return 0


def _other_learner(args: argparse.Namespace) -> int:
    """``--learner SPEC`` other than irl: the table of that learner (docs/plugins.md)."""
    from cloud_sync.irl.sources.tripfiles import load_trip  # noqa: PLC0415 - numpy: learn runs only
    from cloud_sync.learners import learn  # noqa: PLC0415
    from dbc.vocab.dgpt_file import save_dgpt  # noqa: PLC0415

    try:
        if args.init or args.plot:
            raise CloudSyncError("--init and --plot are the IRL learner's: not with --learner")
        _check_outputs(args, None)
        trips = [load_trip(p) for p in args.demos]
        table = learn(args.learner, trips, driver_id=args.driver, seed=args.seed)
        save_dgpt(table, args.output)
    except (CloudSyncError, EcuError, FormatError) as exc:
        return fail("pacc cloud learn", exc)
    covered = sum(bool(c) for c in table.meta["covered"])
    print(
        f"{args.learner}: {covered} of {table.speed_mps.size} speed bins covered, "
        f"{table.meta['learn_s']:.2f} s; table written to {args.output}"
    )
    return 0


def _check_outputs(args: argparse.Namespace, plot: str | None) -> None:
    """Raise CloudSyncError unless ``-o`` (and ``plot``) can be written, before training.

    A path must name a file in an existing, writable folder that is none of the inputs; the
    plot's suffix must be an image format matplotlib writes (png, pdf, svg, ...).
    """
    inputs = [*args.demos, *([args.init] if args.init else [])]
    for flag, name in (("-o", args.output), ("--plot", plot)):
        if name is None:
            continue
        taken = [p for p in inputs if same_file(p, name)]
        if taken:
            raise CloudSyncError(f"{flag} {name} is an input: it would overwrite {taken[0]}")
        path = Path(name)
        parent = path.resolve().parent
        if path.is_dir() or not (parent.is_dir() and os.access(parent, os.W_OK)):
            raise CloudSyncError(f"{flag} {name}: not a writable file location")
    if plot is not None:
        from matplotlib.figure import Figure  # noqa: PLC0415  (~0.9 s, --plot only)

        formats = Figure().canvas.get_supported_filetypes()
        suffix = Path(plot).suffix.lower().lstrip(".")
        if suffix not in formats:
            raise CloudSyncError(
                f"--plot {plot}: unknown image format {suffix!r} (one of {', '.join(formats)})"
            )


def add_subparser(subparsers: Any) -> None:
    """Register ``learn`` on an argparse sub-parsers object."""
    p = subparsers.add_parser(
        "learn",
        help="learn a driver's DGPT by inverse RL from demonstrations",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--demos", nargs="+", required=True, metavar="FILE", help=".mcap or .csv trips")
    p.add_argument("--driver", required=True, metavar="ID", help="driver id of the table")
    p.add_argument("--condition", default="default", metavar="TAG", help="driving condition")
    p.add_argument("--init", metavar="DGPT.json", help="earlier IRL table to fine-tune")
    p.add_argument("-o", "--output", required=True, metavar="DGPT.json", help="the learned table")
    p.add_argument("--plot", metavar="PNG", help="write the reward / DGPT figure here")
    p.add_argument("--seed", type=integer(0), default=0, help="seed (default: %(default)s)")
    p.add_argument("--learner", default="irl", metavar="SPEC", help="irl, empirical, gp, ...")
    p.add_argument("--takeover-weight", type=number(0.0, 1000.0), default=5.0, help="vs manual")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_do_learn)
