"""``pacc validate``: the synthetic drivers side by side with real people.

``pacc validate following`` fits every car-following model (:mod:`sim_bus.following`) per
real human follower of the shipped OpenACC pairs on the first half, replays the real lead on
the held-out rest, and prints the spacing and speed errors per pair (the drivers' model
against per-pair calibrated IDM: the ratio). ``pacc validate people DRIVES_CSV`` puts a
population study's Table I (``pacc study --population N``'s ``drives.csv``) beside the
paper's people, with 95 % bootstrap intervals over drivers, and the paired verdicts.
``--plot FILE`` draws either as a PNG.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pacc.commands._args import CommandParser, integer

if TYPE_CHECKING:
    from sim_bus.following import Fit


def _row(*cells: object) -> str:
    return "| " + " | ".join(map(str, cells)) + " |"


def following_table(fits: Sequence[Fit]) -> str:
    """Markdown: held-out spacing NRMSE per pair and model, speed NRMSE, driver/IDM ratio."""
    import numpy as np  # noqa: PLC0415 - numpy and scipy only when run, not for --help

    models = list(dict.fromkeys(f.model for f in fits))
    by = {(f.pair_id, f.model): f for f in fits}
    pairs = list(dict.fromkeys(f.pair_id for f in fits))
    spacing = [f"{m} spacing" for m in models]
    lines = [
        _row("pair", *spacing, "driver / idm", *(f"{m} speed" for m in models)),
        "|---" * (2 * len(models) + 2) + "|",
    ]
    for p in pairs:
        ratio = by[(p, "driver")].spacing / by[(p, "idm")].spacing
        cells = [f"{by[(p, m)].spacing:.3f}" for m in models]
        lines.append(_row(p, *cells, f"{ratio:.2f}", *(f"{by[(p, m)].speed:.3f}" for m in models)))
    mean = {m: float(np.mean([by[(p, m)].spacing for p in pairs])) for m in models}
    means = [f"**{mean[m]:.3f}**" for m in models]
    lines.append(_row("**mean**", *means) + " |" * (len(models) + 1))
    return "\n".join(lines)


def people_table(rows: Sequence[dict[str, Any]]) -> str:
    """Markdown: Table I averages with 95 % CIs beside the paper's, and paired verdicts."""
    import numpy as np  # noqa: PLC0415

    from pacc.study.report import CONTROLLER_TITLES, PAPER_AVERAGES  # noqa: PLC0415
    from pacc.study.stats import bootstrap_ci, comparisons, holm, per_driver  # noqa: PLC0415

    rng = np.random.default_rng(0)
    lines = [
        "| controller | PoI % [95 % CI] | paper | NIM /min [95 % CI] | paper |",
        "|---" * 5 + "|",
    ]
    values: dict[str, dict[str, np.ndarray]] = {}
    drivers: list[str] = []
    for metric in ("poi_pct", "nim_per_min"):
        drivers, values[metric] = per_driver(rows, metric)
    for c, mine in values["poi_pct"].items():
        nim = values["nim_per_min"][c]
        ci_p, ci_n = bootstrap_ci(mine, rng), bootstrap_ci(nim, rng)
        lines.append(
            f"| {CONTROLLER_TITLES[c]} | {mine.mean():.1f} [{ci_p[0]:.1f}, {ci_p[1]:.1f}] "
            f"| {PAPER_AVERAGES[c][0]:.1f} | {nim.mean():.2f} [{ci_n[0]:.2f}, {ci_n[1]:.2f}] "
            f"| {PAPER_AVERAGES[c][1]:.1f} |"
        )
    poi = values["poi_pct"]
    tests = comparisons(poi, rng)
    keys = list(tests)
    adjusted = dict(zip(keys, holm([tests[k].p_value for k in keys]), strict=True))
    n = len(drivers)
    lines.append("")
    for a, b in (("irl", "predefined+oa"), ("irl", "irl+oa")):
        key = (a, b) if (a, b) in tests else (b, a)
        res = tests[key]
        diff = res.mean_diff if key == (a, b) else -res.mean_diff
        better = int(np.sum(poi[b] < poi[a]))
        lines.append(
            f"- {CONTROLLER_TITLES[b]} vs {CONTROLLER_TITLES[a]}: PoI {diff:+.2f} points, "
            f"lower for {better} of {n} drivers, Holm p {adjusted[key]:.2g}"
        )
    spread = {c: float(np.std(v, ddof=1)) for c, v in poi.items()}
    lines.append(
        "- spread between drivers (sd of PoI %): "
        + ", ".join(f"{CONTROLLER_TITLES[c]} {s:.1f}" for c, s in spread.items())
    )
    # seconds pressed per press: PoI % of a minute (0.6 s per point) over presses per minute
    press = {c: 0.6 * v.mean() / values["nim_per_min"][c].mean() for c, v in poi.items()}
    paper = {c: 0.6 * PAPER_AVERAGES[c][0] / PAPER_AVERAGES[c][1] for c in press}
    lines.append(
        "- mean press s (PoI × 0.6 / NIM): "
        + ", ".join(f"{CONTROLLER_TITLES[c]} {s:.2f} ({paper[c]:.2f})" for c, s in press.items())
        + " (paper in brackets)"
    )
    return "\n".join(lines)


def _plot_following(path: Path, fits: Sequence[Fit], reverse: bool = False) -> None:
    import matplotlib  # noqa: PLC0415  (only the plot needs it)

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # noqa: PLC0415
    import numpy as np  # noqa: PLC0415

    pairs = list(dict.fromkeys(f.pair_id for f in fits))
    models = list(dict.fromkeys(f.model for f in fits))
    by = {(f.pair_id, f.model): f.spacing for f in fits}
    x = np.arange(len(pairs))
    fig, ax = plt.subplots(figsize=(10, 4))
    w = 0.8 / len(models)
    for i, m in enumerate(models):
        ax.bar(x + i * w - 0.4 + w / 2, [by[(p, m)] for p in pairs], w, label=m)
    ax.set_xticks(x, [p.replace("040719_", "") for p in pairs], rotation=20)
    ax.set_ylabel("held-out spacing NRMSE")
    parts = "second half; scored: first" if reverse else "first half; scored: rest"
    ax.set_title(f"Car following on real OpenACC human pairs (fit: {parts})")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``pacc validate``; returns the exit status."""
    p = CommandParser(prog="pacc validate", description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="what", required=True)
    f = sub.add_parser("following", help="car-following models against real trajectories")
    f.add_argument("--pairs", type=integer(0), default=0, help="the first N pairs (0: all)")
    f.add_argument("--maxiter", type=integer(1), default=60, help="generations of each fit")
    f.add_argument("--plot", type=Path, help="a PNG of the held-out spacing errors")
    f.add_argument("--reverse", action="store_true", help="fit on the second half, score the first")
    g = sub.add_parser("people", help="a population study's Table I beside the paper's")
    g.add_argument("drives", type=Path, help="drives.csv of pacc study --population")
    g.add_argument("--plot", type=Path, help="a PNG of the averages beside the paper's")
    args = p.parse_args(argv)
    if args.what == "following":
        from functools import partial  # noqa: PLC0415

        from sim_bus.dataset import load_human_pairs  # noqa: PLC0415
        from sim_bus.following import MODELS, dynamics_prior, fit_pair  # noqa: PLC0415

        pairs = load_human_pairs()
        pairs = pairs[: args.pairs] if args.pairs else pairs
        fit = partial(fit_pair, maxiter=args.maxiter, reverse=args.reverse)
        fits = [fit(m, pair) for pair in pairs for m in MODELS]
        print(following_table(fits))
        if len(pairs) > 1:  # the population's prior over the dynamics, from the driver fits
            prior = dynamics_prior(fits)
            cells = (f"{k} {m:.2f} ({sd:.2f})" for k, (m, sd) in prior.items())
            print("\nprior, median (sd of log): " + ", ".join(cells))
        if args.plot:
            _plot_following(args.plot, fits, args.reverse)
        return 0
    from pacc.study.report import plot, read_drives  # noqa: PLC0415

    rows = read_drives(args.drives)
    print(people_table(rows))
    if args.plot:
        plot(args.plot, rows)
    return 0
