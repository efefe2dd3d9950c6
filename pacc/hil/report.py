"""Table I from real participants: the session folders of ``pacc hil --protocol paper``.

Each finished ACC drive (``drives/acc*.json``) is one row of the synthetic study's
``drives.csv`` (driver = participant, trial 1); the table, the averages, the plot and the
paired tests are the synthetic study's code (:mod:`pacc.study.report`,
:mod:`pacc.study.stats`). Practice and manual drives are not in the table.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from pacc.hil.plan import trip_of
from pacc.study.drive import CONTROLLERS
from pacc.study.report import (
    CONTROLLER_TITLES,
    FIELDS,
    INCREMENTAL_FIELDS,
    PAPER_AVERAGES,
    format_incremental,
    format_table,
    md_table,
    plot,
    poi_nim,
    read_drives,
    write_csv,
)
from pacc.study.spec import StudySpec
from pacc.study.stats import averages, cell_means, holm, paired_comparison, per_driver
from sim_bus.errors import SimError

#: the seed of the bootstrap intervals (a report of the same sessions gives the same figures)
REPORT_SEED = 0


def _records(sessions: Path, pattern: str) -> list[dict[str, Any]]:
    """The drive records ``drives/<pattern>`` of every session (participant, then trip order):
    their row (Table I's columns), table version and trip; SimError naming one not readable."""
    out = []
    for folder in sorted(p for p in sessions.iterdir() if (p / "manifest.json").is_file()):
        for path in sorted((folder / "drives").glob(pattern), key=lambda p: (trip_of(p.stem), p)):
            try:
                rec = json.loads(path.read_text(encoding="utf-8"))
                out.append(
                    {
                        **{k: rec["row"][k] for k in FIELDS},
                        "trip": trip_of(path.stem),
                        "dgpt_version": rec["table_version"],
                        "uploaded": rec.get("incremental", {}).get("uploaded", 0),
                    }
                )
            except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
                raise SimError(f"{path}: not a drive record ({exc})") from exc
    return out


def complete(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows of participants who drove every (controller, scenario) cell."""
    cells: dict[str, set[tuple[str, str]]] = {}
    for r in rows:
        cells.setdefault(str(r["driver"]), set()).add((str(r["scenario"]), str(r["controller"])))
    full = {d for d, c in cells.items() if len(c) == 2 * len(CONTROLLERS)}
    return [r for r in rows if r["driver"] in full]


def paired_tests(rows: list[dict[str, Any]]) -> list[str]:
    """Each controller against Predefined on the participants' mean PoI and NIM: mean
    difference, paired bootstrap 95 % interval, Wilcoxon p (Holm over the family)."""
    drivers, poi = per_driver(rows, "poi_pct")
    values = (poi, per_driver(rows, "nim_per_min")[1])
    rng = np.random.default_rng(REPORT_SEED)
    results = [
        (c, name, paired_comparison(values[k]["predefined"], values[k][c], rng))
        for c in CONTROLLERS[1:]
        for k, name in ((0, "PoI (points)"), (1, "NIM (/min)"))
    ]
    adjusted = holm([r[2].p_value for r in results])
    lines = [f"Paired against Predefined over {len(drivers)} participants:", ""]
    for (c, name, p), adj in zip(results, adjusted, strict=True):
        lo, hi = p.ci
        ci = "n/a" if math.isnan(lo) else f"[{lo:+.1f}, {hi:+.1f}]"
        lines.append(
            f"- {CONTROLLER_TITLES[c]} {name}: {p.mean_diff:+.1f} (95 % CI {ci}), "
            f"Wilcoxon p {p.p_value:.3f} (Holm {adj:.3f}); better/worse/same "
            f"{p.better}/{p.worse}/{p.ties}"
        )
    return lines


def side_by_side(people: list[dict[str, Any]], synthetic: list[dict[str, Any]]) -> str:
    """Markdown: the averages per controller, people beside synthetic drivers and the paper."""
    ours, syn = averages(cell_means(people)), averages(cell_means(synthetic))
    body = [
        f"{CONTROLLER_TITLES[c]} | " + poi_nim([ours[c], syn[c], PAPER_AVERAGES[c]])
        for c in CONTROLLERS
        if c in ours and c in syn
    ]
    head = "controller | people PoI | NIM | synthetic PoI | NIM | paper PoI | NIM"
    lines = [
        "## People beside synthetic drivers (averages over drivers and scenarios)",
        "",
        *md_table(head, body, right=6),
        "",
        f"{len({r['driver'] for r in people})} people, "
        f"{len({r['driver'] for r in synthetic})} synthetic drivers.",
    ]
    return "\n".join(lines) + "\n"


def build_table(sessions: Path, out: Path, synthetic: Path | None = None) -> str:
    """Write ``table1.md``, ``drives.csv`` and ``table1.png`` of the sessions to ``out``;
    the table's text. ``synthetic``: a ``pacc study`` drives.csv whose averages go beside.
    SimError when no participant finished every cell."""
    if not sessions.is_dir():
        raise SimError(f"{sessions}: not a folder of hil sessions")
    rows = complete(_records(sessions, "acc*.json"))
    if not rows:
        raise SimError(f"{sessions}: no participant has finished all eight ACC drives")
    drivers = tuple(dict.fromkeys(str(r["driver"]) for r in rows))
    cfg = StudySpec(drivers=drivers, trials=1, seed=int(rows[0]["seed"]))
    text = format_table(cfg, rows).replace(
        "(synthetic drivers, CAN bus)", "(people in the loop, pacc hil, CAN bus)"
    )
    text += "\n" + "\n".join(paired_tests(rows)) + "\n"
    if synthetic is not None:
        text += "\n" + side_by_side(rows, read_drives(synthetic))
    out.mkdir(parents=True, exist_ok=True)
    (out / "table1.md").write_text(text, encoding="utf-8")
    write_csv(out / "drives.csv", rows)
    plot(out / "table1.png", rows, who="people, pacc hil")
    inc = _records(sessions, "inc*.json")
    if inc:
        text += "\n" + format_incremental(inc)
        (out / "table1.md").write_text(text, encoding="utf-8")
        write_csv(out / "incremental.csv", inc, INCREMENTAL_FIELDS)
    return text
