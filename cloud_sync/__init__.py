"""Cloud side of pacc: trip logs, and each driver's DGPT learned by inverse RL.

Modules: :mod:`cloud_sync.triplog` (Trip, MCAP logs), :mod:`cloud_sync.tripfiles` (CSV,
dispatch by suffix), :mod:`cloud_sync.errors` (the exception tree). The learning modules
import numpy/scipy; import them explicitly.
"""

from __future__ import annotations

from cloud_sync.errors import CloudSyncError, DemoError, TrainingError, TripLogError

__all__ = ["CloudSyncError", "DemoError", "TrainingError", "TripLogError"]
