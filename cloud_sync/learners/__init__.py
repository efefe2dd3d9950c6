"""Learners: trips -> a driver's DGPT, behind one small interface.

:class:`Learner` — ``learn(trips, *, driver_id, seed) -> Dgpt`` (a table on the standard speed
axis, m over m/s, whose ``meta`` holds ``method`` and ``covered``, one bool per bin);
:func:`learn` adds ``learn_s`` (s) and ``learner``. Built-ins: ``irl``, ``empirical`` and ``gp``
(:mod:`cloud_sync.learners.builtin`); others from the ``pacc.learners`` entry points or
``module:attribute`` (:mod:`dbc.vocab.plugins`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

from cloud_sync.errors import CloudSyncError
from dbc.vocab.dgpt import Dgpt, DgptError
from dbc.vocab.plugins import PluginError, build
from dbc.vocab.triplog import Trip

GROUP = "pacc.learners"
#: built-in learners: name -> factory
BUILTIN_LEARNERS: dict[str, str] = {
    "irl": "cloud_sync.learners.builtin:IrlLearner",
    "empirical": "cloud_sync.learners.builtin:EmpiricalLearner",
    "gp": "cloud_sync.learners.builtin:GpLearner",
}


class LearnerError(CloudSyncError):
    """A learner returned something that is not a DGPT with the meta the interface asks."""


@runtime_checkable
class Learner(Protocol):
    """trips -> DGPT with meta (see the package docstring for units and meta)."""

    def learn(self, trips: Sequence[Trip], *, driver_id: str, seed: int) -> Dgpt:
        """The driver's table learned from ``trips``."""
        ...


def make_learner(spec: str, params: Mapping[str, Any] | None = None) -> Learner:
    """The learner named by ``spec`` built with ``params`` (PluginError if none)."""
    obj = build(GROUP, spec, BUILTIN_LEARNERS, params or {})
    if not callable(getattr(obj, "learn", None)):
        raise PluginError(f"learner {spec!r} has no learn(trips, *, driver_id, seed)")
    return obj  # type: ignore[no-any-return]


def learn(
    spec: str,
    trips: Sequence[Trip],
    *,
    driver_id: str,
    seed: int,
    params: Mapping[str, Any] | None = None,
) -> Dgpt:
    """Learn with the learner ``spec``; the table's meta gain ``learner`` and ``learn_s`` (s).
    PluginError: no such learner; LearnerError: no DGPT, no ``covered`` per bin, or out of
    bounds; the learner's own errors (DemoError ...) pass through."""
    learner = make_learner(spec, params)
    start = time.perf_counter()
    table = learner.learn(trips, driver_id=driver_id, seed=seed)
    wall = time.perf_counter() - start
    if not isinstance(table, Dgpt):
        raise LearnerError(f"learner {spec!r} returned {type(table).__name__}, not a Dgpt")
    try:
        table.check_bounds()  # a learner's table drives a car: inside the safety bounds or refused
    except DgptError as exc:
        raise LearnerError(f"learner {spec!r}: {exc}") from None
    covered = table.meta.get("covered")
    if not isinstance(covered, list) or len(covered) != table.speed_mps.size:
        raise LearnerError(f"learner {spec!r}: meta 'covered' must be one bool per speed bin")
    meta = {"method": spec, **table.meta, "learner": spec, "learn_s": round(wall, 4)}
    return dataclasses.replace(table, meta=meta)


__all__ = ["BUILTIN_LEARNERS", "GROUP", "Learner", "LearnerError", "learn", "make_learner"]
