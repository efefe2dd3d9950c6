"""Fixtures of the cloud tests: the synthetic follower of :mod:`cloud_sync.irl.sources.synthetic`
and one served cloud per module (:mod:`tests.cloud_sync.served`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

import numpy as np
import pytest

from cloud_sync.irl.sources.synthetic import follower_trip, lead_speed
from dbc.vocab.acc_state import AccState
from dbc.vocab.triplog import Trip

if TYPE_CHECKING:  # imported by the fixtures that need them: Dask workers import this module
    from cloud_sync.irl.trainer import LearnResult
    from tests.cloud_sync.served import Served

__all__ = ["follower_trip", "lead_speed", "takeover_segment"]


@pytest.fixture(scope="module")
def http_server() -> Iterator[Served]:
    """One served cloud for a module's tests, each pointing it at its own service."""
    from tests.cloud_sync.served import Served  # noqa: PLC0415 - uvicorn: not in Dask workers

    served = Served()
    yield served
    served.stop()


def takeover_segment(
    seed: int, presses: list[tuple[int, int, str]], n: int = 200, driver_id: str = "syn"
) -> Trip:
    """A 10 Hz takeover segment of ``n`` samples of the follower: the ACC Active, and each
    press ``(first, end, pedal)`` a pedal held on samples ``first..end-1`` (``accel``:
    Override; ``brake``: cancelled to Standby, as ``brake_mode="cancel"`` does). Known answer:
    ``sum(end - first) * 0.1`` s of intervention and ``len(presses)`` takeovers (presses
    apart)."""
    base = follower_trip(seed, minutes=n / 600.0)
    state = np.full(n, int(AccState.ACTIVE), dtype=np.int64)
    accel, brake = np.zeros(n), np.zeros(n)
    for first, end, pedal in presses:
        if pedal == "accel":
            state[first:end], accel[first:end] = int(AccState.OVERRIDE), 0.3
        else:
            state[first:end], brake[first:end] = int(AccState.STANDBY), 0.4
    return dataclasses.replace(
        base,
        acc_state=state,
        accel_pedal=accel,
        brake_pedal=brake,
        meta={"driver_id": driver_id, "condition": "default", "mode": "takeover", "seed": seed},
    )


@pytest.fixture(scope="session")
def follower() -> Callable[..., Trip]:
    """The :func:`follower_trip` factory."""
    return follower_trip


@pytest.fixture(scope="session")
def syn_trips() -> list[Trip]:
    """Four 5-minute manual drives of the follower with preference 4 m + 1.6 s·v."""
    return [follower_trip(s) for s in range(4)]


@pytest.fixture(scope="session")
def syn_learned_one(syn_trips: list[Trip]) -> LearnResult:
    """What driver syn's first drive learns with seed 0 (tests only read it)."""
    from cloud_sync.irl.trainer import learn_dgpt  # noqa: PLC0415 - scipy: not in Dask workers

    return learn_dgpt(syn_trips[:1], driver_id="syn", seed=0)
