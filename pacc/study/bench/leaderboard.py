"""The leaderboard of ``pacc bench``: one line per method, from the drives and held-out rows.

Per method: PoI % and NIM /min as the mean over drivers with a bootstrap 95 % interval, the
per-seed means, the lowest and median-lowest min TTC (s), collisions, the held-out gap error
of its learner against the empirical baseline (m) and paired tests against the paper's method
on the same drivers, Holm-adjusted over the methods (:mod:`pacc.study.stats`).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pacc.study.bench.heldout import BASELINE
from pacc.study.report import bars, md_table
from pacc.study.report import write_csv as write_rows
from pacc.study.stats import bootstrap_ci, driver_means, holm, paired_comparison

PAPER = "paper"


def _seed_of(driver: str) -> str:
    """A drawn driver's population (``p<seed>-NNNN``); "" for the others."""
    return driver.split("-")[0][1:] if driver.startswith("p") and "-" in driver else ""


def _fmt(x: float, ci: tuple[float, float] | None = None, digits: int = 2) -> str:
    if not math.isfinite(x):
        return "–"
    text = f"{x:.{digits}f}"
    if ci is not None and all(math.isfinite(c) for c in ci):
        text += f" [{ci[0]:.{digits}f}, {ci[1]:.{digits}f}]"
    return text


def heldout_stats(records: Sequence[Mapping[str, Any]], learner: str) -> dict[str, Any]:
    """Held-out error of ``learner``: per kind (real, drawn, builtin) the mean error, the
    baseline's, wins (error <= baseline; None for the baseline itself) and drivers; the mean
    learning time (s)."""
    out: dict[str, Any] = {"learn_s": math.nan}
    times = []
    for kind in ("real", "drawn", "builtin"):
        mine, base = [], []
        for rec in records:
            if rec["kind"] != kind:
                continue
            for row in rec["rows"]:
                if row["learner"] == learner and "error_m" in row:
                    mine.append(row["error_m"])
                    base.append(row["baseline_m"])
                    times.append(row["learn_s"])
        m, b = np.asarray(mine), np.asarray(base)
        out[kind] = {
            "error_m": float(m.mean()) if m.size else math.nan,
            "baseline_m": float(b.mean()) if b.size else math.nan,
            "wins": None if learner == BASELINE else int(np.sum(m <= b)),  # not against itself
            "n": int(m.size),
        }
    if times:
        out["learn_s"] = float(np.mean(times))
    return out


def leaderboard(
    rows: Sequence[Mapping[str, Any]],
    heldout: Sequence[Mapping[str, Any]],
    methods: Sequence[Mapping[str, Any]],
    *,
    rng_seed: int = 0,
) -> list[dict[str, Any]]:
    """One dict per method (the columns of leaderboard.csv), in the order of ``methods``."""
    rng = np.random.default_rng(rng_seed)
    board = []
    means = {key: driver_means(rows, key, by="method") for key in ("poi_pct", "nim_per_min")}
    for m in methods:
        name = m["name"]
        line: dict[str, Any] = {
            "method": name,
            "table": m["table"],
            "adaptation": m["adaptation"],
            "controller": m["controller"],
        }
        mine = [r for r in rows if r["method"] == name]
        line["drives"] = len(mine)
        for key, short in (("poi_pct", "poi"), ("nim_per_min", "nim")):
            by_driver = means[key].get(name, {})
            vals = np.asarray(list(by_driver.values()))
            line[short] = float(vals.mean()) if vals.size else math.nan
            line[f"{short}_ci"] = bootstrap_ci(vals, rng)
            seeds: dict[str, list[float]] = defaultdict(list)
            for d, v in by_driver.items():
                if _seed_of(d):
                    seeds[_seed_of(d)].append(v)
            line[f"{short}_by_seed"] = {s: float(np.mean(v)) for s, v in sorted(seeds.items())}
        ttc = [float(r["min_ttc_s"]) for r in mine]
        drivers = dict.fromkeys(r["driver"] for r in mine)
        lowest = [min(float(r["min_ttc_s"]) for r in mine if r["driver"] == d) for d in drivers]
        line["min_ttc"] = min(ttc) if ttc else math.nan
        line["min_ttc_median"] = float(np.median(lowest)) if lowest else math.nan
        line["collisions"] = sum(int(r["collision"]) for r in mine)
        line["plugin_fault_drives"] = sum(1 for r in mine if r["plugin_faults"])
        line["heldout"] = heldout_stats(heldout, m["table"]) if m["table"] != "predefined" else None
        for key, short in (("poi_pct", "poi"), ("nim_per_min", "nim")):
            ref, mine_d = means[key].get(PAPER, {}), means[key].get(name, {})
            line[f"{short}_vs_paper"] = _paired(ref, mine_d, rng, name)
        board.append(line)
    for short in ("poi", "nim"):
        tests = [(i, b[f"{short}_vs_paper"]) for i, b in enumerate(board)]
        live = [(i, t) for i, t in tests if t is not None]
        for (i, t), p in zip(live, holm([t["p"] for _, t in live]), strict=True):
            board[i][f"{short}_vs_paper"] = {**t, "p_holm": p}
    return board


def _paired(
    ref: Mapping[str, float], mine: Mapping[str, float], rng: np.random.Generator, name: str
) -> dict[str, Any] | None:
    if name == PAPER or not ref:
        return None
    common = sorted(set(ref) & set(mine))
    if len(common) < 2:
        return None
    res = paired_comparison(np.array([ref[d] for d in common]), np.array([mine[d] for d in common]),
                            rng)  # fmt: skip
    return {"diff": res.mean_diff, "ci": res.ci, "p": res.p_value, "better": res.better,
            "worse": res.worse, "n": len(common)}  # fmt: skip


def _heldout_cell(h: Mapping[str, Any] | None, kind: str) -> str:
    if h is None or not h[kind]["n"]:
        return "–"
    k = h[kind]
    wins = "the baseline" if k["wins"] is None else f"{k['wins']}/{k['n']}"
    return f"{k['error_m']:.2f} vs {k['baseline_m']:.2f} ({wins})"


def _paired_cell(t: Mapping[str, Any] | None) -> str:
    if t is None:
        return "–"
    lo, hi = t["ci"]
    return f"{t['diff']:+.2f} [{lo:+.2f}, {hi:+.2f}] p={t.get('p_holm', t['p']):.3f}"


def markdown(board: Sequence[Mapping[str, Any]], header: str) -> str:
    """The leaderboard as Markdown, ``header`` (seeds, sizes) above it."""
    head = (
        "method | drives | PoI % [95 % CI drivers] | PoI by seed | NIM /min [CI] | min TTC s "
        "(lowest / median) | collisions | held-out gap error m vs baseline, real (wins/n) | "
        "drawn (wins/n) | d1..d5 (wins/n) | learn s | ΔPoI vs paper [CI] p(Holm) | "
        "ΔNIM vs paper [CI] p(Holm)"
    )
    lines = []
    for b in board:
        seeds = ", ".join(f"{v:.1f}" for v in b["poi_by_seed"].values()) or "–"
        h = b["heldout"]
        lines.append(
            f"{b['method']} | {b['drives']} | {_fmt(b['poi'], b['poi_ci'])} | {seeds} | "
            f"{_fmt(b['nim'], b['nim_ci'])} | {_fmt(b['min_ttc'])} / {_fmt(b['min_ttc_median'])} "
            f"| {b['collisions']} | {_heldout_cell(h, 'real')} | {_heldout_cell(h, 'drawn')} | "
            f"{_heldout_cell(h, 'builtin')} | "
            f"{_fmt(h['learn_s']) if h is not None else '–'} | "
            f"{_paired_cell(b['poi_vs_paper'])} | {_paired_cell(b['nim_vs_paper'])}"
        )
    return "\n".join([header, "", *md_table(head, lines)]) + "\n"


def write_csv(path: Path, board: Sequence[Mapping[str, Any]]) -> None:
    """The leaderboard flat, one row per method."""
    rows = []
    for b in board:
        h = b["heldout"] or {}
        row = {k: b[k] for k in ("method", "table", "adaptation", "controller", "drives")}
        for s in ("poi", "nim"):
            row |= {s: b[s], f"{s}_lo": b[f"{s}_ci"][0], f"{s}_hi": b[f"{s}_ci"][1]}
        row |= {k: b[k] for k in ("min_ttc", "min_ttc_median", "collisions")}
        for kind in ("real", "drawn"):
            k = h.get(kind, {})
            row |= {
                f"heldout_{kind}_m": k.get("error_m"),
                f"baseline_{kind}_m": k.get("baseline_m"),
            }
            row |= {f"wins_{kind}": k.get("wins"), f"n_{kind}": k.get("n")}
        pp, pn = b["poi_vs_paper"] or {}, b["nim_vs_paper"] or {}
        row |= {"learn_s": h.get("learn_s"), "dpoi_vs_paper": pp.get("diff")}
        row |= {"p_poi_holm": pp.get("p_holm"), "dnim_vs_paper": pn.get("diff")}
        rows.append({**row, "p_nim_holm": pn.get("p_holm")})
    write_rows(path, rows, list(rows[0]) if rows else [])


def plot(path: Path, board: Sequence[Mapping[str, Any]]) -> None:
    """PoI and NIM per method with their intervals across drivers."""
    means = np.array([[b[short] for b in board] for short in ("poi", "nim")], dtype=float)
    ci = np.array([[b[f"{short}_ci"] for b in board] for short in ("poi", "nim")], dtype=float)
    err = [
        np.vstack([np.nan_to_num(means[k] - ci[k, :, 0]), np.nan_to_num(ci[k, :, 1] - means[k])])
        for k in (0, 1)
    ]
    bars(
        path,
        "pacc bench: mean over drivers, 95 % bootstrap interval",
        [b["method"] for b in board],
        [("", means, err)],
    )
