"""Fixtures of the IRL tests: the synthetic follower of :mod:`cloud_sync.irl.synthetic`."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from cloud_sync.irl.synthetic import follower_trip, lead_speed
from pacc.vocab.triplog import Trip

__all__ = ["follower_trip", "lead_speed"]


@pytest.fixture(scope="session")
def follower() -> Callable[..., Trip]:
    """The :func:`follower_trip` factory."""
    return follower_trip


@pytest.fixture(scope="session")
def syn_trips() -> list[Trip]:
    """Four 5-minute manual drives of the follower with preference 4 m + 1.6 s·v."""
    return [follower_trip(s) for s in range(4)]
