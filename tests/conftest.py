"""Test-wide settings: hypothesis without per-example deadlines (CI machines are slow and
shared); the example count can be raised with HYPOTHESIS_PROFILE=thorough; the shared Dask
cluster of the distributed tests."""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from hypothesis import settings

from cloud_sync.engine.base import Engine

settings.register_profile("default", deadline=None, max_examples=100)
settings.register_profile("thorough", deadline=None, max_examples=1000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


@pytest.fixture(scope="session")
def dask_cluster() -> Iterator[Engine]:
    """One Dask LocalCluster of 2 single-threaded worker processes (each under a nanny),
    shared by the tests that need one within a test process (under pytest-xdist: at most
    one per xdist worker that runs such a test)."""
    # Dask costs ~1 s of import: only the sessions that run a distributed test pay it
    from cloud_sync.engine.dask_backend import DaskEngine  # noqa: PLC0415

    engine = DaskEngine.local(2)
    try:
        yield engine
    finally:
        engine.close()
