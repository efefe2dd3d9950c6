"""The built-in learners ``irl`` and ``empirical`` as implementations of the interface."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from cloud_sync.irl.trainer import IrlConfig, empirical_baseline, learn_dgpt
from dbc.vocab.dgpt import Dgpt
from dbc.vocab.triplog import Trip


class IrlLearner:
    """Maximum causal entropy IRL (:func:`~cloud_sync.irl.trainer.learn_dgpt`); parameters:
    any field of :class:`~cloud_sync.irl.trainer.IrlConfig`."""

    def __init__(self, **fields: Any) -> None:
        self.config = IrlConfig(**fields)

    def learn(self, trips: Sequence[Trip], *, driver_id: str, seed: int) -> Dgpt:
        """The IRL table; meta ``covered`` = the bins the demonstrations set."""
        res = learn_dgpt(list(trips), driver_id=driver_id, seed=seed, config=self.config)
        meta = {**res.table.meta, "method": "irl", "covered": res.covered.tolist()}
        return dataclasses.replace(res.table, meta=meta)


class EmpiricalLearner:
    """The median steady-state gap per speed bin (:func:`~cloud_sync.irl.trainer.
    empirical_baseline`); parameters: any field of :class:`~cloud_sync.irl.trainer.IrlConfig`
    (``max_gap_m``, ``min_coverage_s``, ``bounds``, ...)."""

    def __init__(self, **fields: Any) -> None:
        self.config = IrlConfig(**fields)

    def learn(self, trips: Sequence[Trip], *, driver_id: str, seed: int) -> Dgpt:
        """The baseline table (``seed`` is unused: the baseline is deterministic)."""
        return empirical_baseline(trips, driver_id=driver_id, config=self.config)


__all__ = ["EmpiricalLearner", "IrlLearner"]
