"""Build ``sim_bus/data/openacc_human.npz`` from the JRC OpenACC human-driven pairs.

Run from the repository root as ``python -m tools.build_dataset [--source DIR] [--out FILE]``
(a maintainer's tool: not part of the installed package). The source is the
folder of leader->follower pair CSVs (10 Hz, SI units) extracted from the JRC OpenACC
AstaZero campaign (Makridis, Mattas, Anesiadou, Ciuffo, "OpenACC. An open database of
car-following experiments to study the properties of commercial ACC systems", Transportation
Research Part C 125, 2021), in which a human drove the follower. The output is a compact
copy the simulator reads at run time (never the source folder):

- ``v_leader_mps``, ``v_follower_mps``, ``gap_m``: float32, shape (N,), all pairs end to end;
- ``offsets``: int64, shape (P + 1,), pair ``i`` is ``[offsets[i], offsets[i + 1])``;
- ``pair_id``, ``follower_make``, ``leader_make``: str, shape (P,);
- ``dt_s``: float64 scalar sample period (0.1 s); ``source``: attribution text.

Values are rounded to float32 (speed resolution far below 1 mm/s) so the file stays small.
"""

from __future__ import annotations

import argparse
import csv
import warnings
from pathlib import Path

import numpy as np

from sim_bus.dataset import DATA_PATH
from sim_bus.errors import DataError

#: ../shared/data/openacc_astazero beside the repository
DEFAULT_SOURCE = Path(__file__).resolve().parents[2] / "shared" / "data" / "openacc_astazero"
#: the file the simulator reads (sim_bus.dataset)
DEFAULT_OUT = DATA_PATH
DT_S = 0.1
ATTRIBUTION = (
    "Derived from the JRC OpenACC database (European Commission Joint Research Centre), "
    "AstaZero campaign 4-5 July 2019, human-driven followers; Makridis, Mattas, Anesiadou, "
    "Ciuffo, Transportation Research Part C 125 (2021). Pairs extracted by "
    "TeRyZh/Segment-based-Calibration-of-Car-Following-Dynamics (oa_cf_pairs/)."
)
_COLUMNS = ("t", "v_follower", "v_leader", "spacing")


class BuildError(DataError):
    """The source folder does not hold usable pair files."""


def _read_pair(path: Path) -> dict[str, np.ndarray]:
    """Read one pair CSV into float64 columns (t, v_follower, v_leader, spacing), shape (n,)."""
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            header = next(csv.reader(handle), [])
        missing = [c for c in _COLUMNS if c not in header]
        if missing:
            raise BuildError(f"{path}: missing columns {missing}")
        with warnings.catch_warnings():  # a header without rows: refused below, not warned
            warnings.simplefilter("ignore", UserWarning)
            raw = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError, csv.Error) as exc:  # unreadable, not text, ragged, non-numeric
        raise BuildError(f"{path}: {exc}") from exc
    if raw.shape[0] < 2:
        raise BuildError(f"{path}: fewer than two samples")
    if raw.shape[1] != len(header):
        raise BuildError(f"{path}: {raw.shape[1]} values per row, header has {len(header)}")
    cols = {name: raw[:, header.index(name)] for name in _COLUMNS}
    if not all(np.all(np.isfinite(c)) for c in cols.values()):
        raise BuildError(f"{path}: non-finite values")
    steps = np.diff(cols["t"])
    if steps.size == 0 or np.max(np.abs(steps - DT_S)) > 1e-3:
        raise BuildError(f"{path}: not sampled at {DT_S} s")
    return cols


def _manifest(source: Path) -> dict[str, dict[str, str]]:
    """Map pair CSV file name -> manifest row (empty if there is no manifest)."""
    path = source / "manifest.csv"
    if not path.exists():
        return {}
    with path.open(newline="", encoding="utf-8-sig") as handle:
        return {Path(row["path"]).name: row for row in csv.DictReader(handle)}


def build(source: Path, out: Path) -> dict[str, int]:
    """Build the derived file ``out`` from the pair CSVs in ``source``; return sizes."""
    files = sorted(source.glob("oa_pair_*.csv"))
    if not files:
        raise BuildError(f"no oa_pair_*.csv files in {source}")
    manifest = _manifest(source)
    v_lead: list[np.ndarray] = []
    v_fol: list[np.ndarray] = []
    gaps: list[np.ndarray] = []
    pair_ids: list[str] = []
    f_make: list[str] = []
    l_make: list[str] = []
    offsets = [0]
    for path in files:
        cols = _read_pair(path)
        row = manifest.get(path.name, {})
        pair_ids.append(row.get("pair_id", path.stem.removeprefix("oa_pair_")))
        f_make.append(row.get("follower_make", ""))
        l_make.append(row.get("leader_make", ""))
        v_lead.append(np.maximum(cols["v_leader"], 0.0).astype(np.float32))
        v_fol.append(np.maximum(cols["v_follower"], 0.0).astype(np.float32))
        gaps.append(cols["spacing"].astype(np.float32))
        offsets.append(offsets[-1] + len(cols["t"]))
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(
        out,
        v_leader_mps=np.concatenate(v_lead),
        v_follower_mps=np.concatenate(v_fol),
        gap_m=np.concatenate(gaps),
        offsets=np.asarray(offsets, dtype=np.int64),
        pair_id=np.asarray(pair_ids),
        follower_make=np.asarray(f_make),
        leader_make=np.asarray(l_make),
        dt_s=np.float64(DT_S),
        source=np.asarray(ATTRIBUTION),
    )
    return {"pairs": len(files), "samples": offsets[-1], "bytes": out.stat().st_size}


def main(argv: list[str] | None = None) -> int:
    """Command line: build the shipped data file; return 0 on success, 1 on a bad source."""
    parser = argparse.ArgumentParser(prog="python -m tools.build_dataset", description=__doc__)
    parser.add_argument("--source", type=Path, default=DEFAULT_SOURCE, help="pair CSV folder")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="output .npz")
    args = parser.parse_args(argv)
    try:
        sizes = build(args.source, args.out)
    except (BuildError, OSError) as exc:
        print(f"build_dataset: error: {exc}")
        return 1
    print(
        f"wrote {args.out}: {sizes['pairs']} pairs, {sizes['samples']} samples, "
        f"{sizes['bytes'] / 1e6:.2f} MB"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
