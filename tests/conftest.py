"""Test-wide settings: hypothesis without per-example deadlines (CI machines are slow and
shared); the example count can be raised with HYPOTHESIS_PROFILE=thorough; the shared Dask
cluster of the distributed tests."""

from __future__ import annotations

import os
from collections.abc import Iterator
from concurrent.futures import Executor

import pytest
from hypothesis import settings

from cloud_sync.engine import dask_executor

settings.register_profile("default", deadline=None, max_examples=100)
settings.register_profile("thorough", deadline=None, max_examples=1000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


@pytest.fixture(scope="session")
def dask_cluster() -> Iterator[Executor]:
    """One Dask LocalCluster of 2 single-threaded worker processes (each under a nanny),
    shared by the tests that need one within a test process (under pytest-xdist: at most
    one per xdist worker that runs such a test)."""
    executor = dask_executor("local", 2)  # Dask is imported (~1 s) only here
    try:
        yield executor
    finally:
        executor.shutdown()
