"""The exception tree of :mod:`cloud_sync`, named by phase.

``CloudSyncError`` is the root; catch it to handle every failure of this package.
"""

from __future__ import annotations

from dbc.errors import PaccError


class CloudSyncError(PaccError):
    """Root of every error raised by :mod:`cloud_sync`."""


class DemoError(CloudSyncError):
    """Demonstrations unusable for learning: empty, NaN-filled, too short, out of range."""


class TrainingError(CloudSyncError):
    """The IRL optimisation failed (non-finite objective, bad configuration)."""


class EngineError(CloudSyncError):
    """The compute engine cannot run the work: no scheduler at the address, Dask missing,
    a task that kept killing its workers, a worker pool that kept breaking."""
