"""The shipped real-data file ``sim_bus/data/openacc_human.npz`` (tools/build_dataset.py): the
human-driven leader->follower pairs of the JRC OpenACC AstaZero campaign (Makridis et al.,
2021), 10 Hz."""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from sim_bus.errors import DataError

DATA_PATH = Path(__file__).resolve().parent / "data" / "openacc_human.npz"


@dataclass(frozen=True)
class HumanPair:
    """One real leader->follower pair, 10 Hz; arrays float64, shape (n,)."""

    pair_id: str
    follower_make: str
    v_leader_mps: np.ndarray
    v_follower_mps: np.ndarray
    gap_m: np.ndarray
    dt_s: float


@lru_cache(maxsize=4)
def load_human_pairs(path: Path = DATA_PATH) -> tuple[HumanPair, ...]:
    """Load every pair of the shipped file (cached); raise DataError if it is unusable."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            offsets = npz["offsets"]
            v_lead = npz["v_leader_mps"].astype(np.float64)
            v_fol = npz["v_follower_mps"].astype(np.float64)
            gap = npz["gap_m"].astype(np.float64)
            ids = [str(s) for s in npz["pair_id"]]
            makes = [str(s) for s in npz["follower_make"]]
            dt_s = float(npz["dt_s"])
    except (OSError, KeyError, ValueError, zipfile.BadZipFile) as exc:  # BadZipFile: truncated
        raise DataError(f"cannot read the simulator data file {path}: {exc}") from exc
    if len(offsets) != len(ids) + 1 or offsets[-1] != len(v_lead):
        raise DataError(f"{path}: offsets do not match the arrays")
    cuts = [slice(int(a), int(b)) for a, b in zip(offsets[:-1], offsets[1:], strict=True)]
    return tuple(
        HumanPair(pair_id, make, v_lead[sl], v_fol[sl], gap[sl], dt_s)
        for pair_id, make, sl in zip(ids, makes, cuts, strict=True)
    )
