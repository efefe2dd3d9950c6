"""The exception tree of :mod:`cloud_sync`, named by phase.

``CloudSyncError`` is the root; catch it to handle every failure of this package.
"""

from __future__ import annotations


class CloudSyncError(Exception):
    """Root of every error raised by :mod:`cloud_sync`."""


class TripLogError(CloudSyncError):
    """A trip log (MCAP or CSV) cannot be read or written: unknown, corrupt or truncated."""


class DemoError(CloudSyncError):
    """Demonstrations unusable for learning: empty, NaN-filled, too short, out of range."""


class TrainingError(CloudSyncError):
    """The IRL optimisation failed (non-finite objective, bad configuration)."""
